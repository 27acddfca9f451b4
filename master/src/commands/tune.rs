//! `master tune`: the second level's command filter chosen on runs of minutes, in parallel.
//!
//! Every candidate (a filter bandwidth; with an inertial unit a prediction horizon as a share of
//! the filter's lag (2τ, or 3τ with three stages); with a notch frequency the notch's quality) is run three ways: on the coupled (monolithic) model, on the
//! decoupled one (its commands replayed on the uncompensated run's cabin poses: the platform's
//! reactions never reach the cabin), and on the coupled model with the sensor's delay ×0.5 and
//! ×1.5 and the platform's mass ×0.8 and ×1.2. The design model (`--design`) picks: the lowest
//! feed error RMS among the candidates it calls stable — the coupled model every run of a
//! candidate stable (`master compensation`'s verdict: no stop, no growing error, the cabin's
//! peak within twice the uncompensated), the decoupled model cannot see instability. Written:
//! the scene with the chosen filter, `tune.csv` (every candidate, every run) and `tune.md` (the
//! choice, and what the decoupled model's choice does on the coupled one).

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use feedcore::scene::{FusionModel, Scene, SensorKind, ValidScene};
use stewart::Stewart;
use studies::table::Table;

use super::compensation::{History, Verdict, case_step, checked_steps, history, rms_peak};
use super::output::{Outputs, run_inputs};
use super::scheme_args::positive;
use super::{CmdResult, load_scene};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Design {
    /// The monolithic model: the platform's reactions move the cabin.
    Coupled,
    /// The cabin's uncompensated motion, the commands replayed on it.
    Decoupled,
}

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML) with a `[control]` section whose sensor is "sampled".
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Directory for tuned.toml, tune.csv and tune.md.
    #[arg(long, default_value = "out/tune")]
    pub(crate) out: PathBuf,
    /// The model the choice is made on.
    #[arg(long, value_enum, default_value_t = Design::Coupled)]
    pub(crate) design: Design,
    /// Simulated time of every run (s): long enough for a lightly damped mode pumped slowly to
    /// show (at C the 0.83 Hz cable–cabin mode takes minutes to double).
    #[arg(long, default_value_t = 300.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Filter bandwidths tried (Hz, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.25,0.5,1,1.5,2,2.5,3,4,5")]
    pub(crate) bandwidths: Vec<f64>,
    /// Numbers of filter stages tried, 2 or 3 (comma-separated; default: the scene's
    /// `filter_stages`): three keep the platform's acceleration continuous, at one more τ of lag.
    #[arg(long, value_delimiter = ',')]
    pub(crate) filter_stages: Vec<u32>,
    /// With [control.imu]: prediction horizons tried, as shares of the filter's lag (2τ; 3τ with three stages)
    /// (comma-separated; ignored without an inertial unit).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_value = "0,0.25,0.5")]
    pub(crate) predictions: Vec<f64>,
    /// With [control.imu]: scales of the noise the fusion filter assumes of the unit (its noise
    /// densities and bias walks; 1: the instrument's own figures) tried (comma-separated; ignored
    /// without an inertial unit). Above 1 the filter leans on the fixes, below on the unit.
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true, default_value = "1")]
    pub(crate) fusion_scales: Vec<f64>,
    /// A notch in the commands at this frequency (Hz; default: the scene's `notch_hz`, if any),
    /// e.g. the cable–cabin mode the loop pumps (`master modes`).
    #[arg(long, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) notch_hz: Option<f64>,
    /// With a notch: its qualities tried (comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "2,4,8")]
    pub(crate) notch_qs: Vec<f64>,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) jobs: Option<u16>,
}

/// What each candidate is run as.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Nominal,
    Decoupled,
    Delay(f64),
    Mass(f64),
}

const VARIANTS: [Variant; 6] = [
    Variant::Nominal,
    Variant::Decoupled,
    Variant::Delay(0.5),
    Variant::Delay(1.5),
    Variant::Mass(0.8),
    Variant::Mass(1.2),
];

impl Variant {
    fn label(&self) -> String {
        match self {
            Variant::Nominal => "coupled".into(),
            Variant::Decoupled => "decoupled".into(),
            Variant::Delay(f) => format!("coupled delay x{f}"),
            Variant::Mass(f) => format!("coupled platform mass x{f}"),
        }
    }
}

/// A filter tried.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    bandwidth_hz: f64,
    /// First-order stages of the filter: 2 or 3.
    stages: u32,
    prediction_s: Option<f64>,
    /// The notch: frequency, quality.
    notch: Option<(f64, f64)>,
    /// The scale of the unit's noise the fusion filter assumes (with an inertial unit).
    fusion_scale: Option<f64>,
}

impl Candidate {
    fn apply(&self, s: &mut Scene) {
        if let Some(c) = s.control.as_mut() {
            (c.bandwidth_hz, c.prediction_s) = (Some(self.bandwidth_hz), self.prediction_s);
            c.filter_stages = (self.stages != 2).then_some(self.stages);
            (c.notch_hz, c.notch_q) = (self.notch.map(|n| n.0), self.notch.map(|n| n.1));
            if let (Some(k), Some(m)) = (self.fusion_scale.filter(|&k| k != 1.0), c.fusion_model())
                && let Some(imu) = c.imu.as_mut()
            {
                let scaled = FusionModel {
                    accel_noise_density: m.accel_noise_density * k,
                    gyro_noise_density: m.gyro_noise_density * k,
                    accel_bias_walk: m.accel_bias_walk * k,
                    gyro_bias_walk: m.gyro_bias_walk * k,
                    ..m
                };
                imu.filter = Some(scaled.as_filter());
            }
        }
    }
}

/// One run: the candidate's scene as the variant makes it.
fn run_one(base: &ValidScene, off: &ValidScene, c: &Candidate, v: Variant, t_end: f64, off_run: &History) -> Verdict {
    let result = (|| -> anyhow::Result<History> {
        let scene = base.edited(|s| {
            c.apply(s);
            match v {
                Variant::Delay(f) => {
                    if let Some(control) = s.control.as_mut() {
                        control.delay_s *= f;
                    }
                }
                Variant::Mass(f) => studies::sweep::scale_platform_mass(s, f),
                Variant::Nominal | Variant::Decoupled => {}
            }
        })?;
        let comp = Stewart::from_scene(&scene)?.compensation().cloned().context("a scene with [control]")?;
        let h = case_step(&scene);
        let steps = checked_steps(&scene, h, t_end, "a tuning run")?;
        if v == Variant::Decoupled {
            let mut r = history(off, &comp, h, steps, Some(&comp))?;
            r.feed_mm = std::mem::take(&mut r.replayed_mm);
            Ok(r)
        } else {
            history(&scene, &comp, h, steps, None)
        }
    })();
    match result {
        Ok(r) => Verdict::judge(&r, off_run),
        Err(e) => Verdict::stopped(format!("{e:#}")),
    }
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let shown = args.scene.display();
    let control = scene.control.as_ref().with_context(|| format!("{shown}: the scene has no [control] section"))?;
    if control.sensor != SensorKind::Sampled {
        bail!("{shown}: [control] sensor = {:?}; `master tune` tunes a sampled sensor's filter", control.sensor);
    }
    if let Some(p) = args.predictions.iter().find(|p| !(p.is_finite() && **p >= 0.0)) {
        bail!("--predictions: {p} is not a non-negative share of the filter's lag");
    }
    let shares: Vec<Option<f64>> =
        if control.imu.is_some() { args.predictions.iter().map(|&p| Some(p)).collect() } else { vec![None] };
    let scales: Vec<Option<f64>> =
        if control.imu.is_some() { args.fusion_scales.iter().map(|&k| Some(k)).collect() } else { vec![None] };
    let notches: Vec<Option<(f64, f64)>> = match args.notch_hz.or(control.notch_hz) {
        Some(f) => args.notch_qs.iter().map(|&q| Some((f, q))).collect(),
        None => vec![None],
    };
    let stage_counts = if args.filter_stages.is_empty() {
        vec![control.filter_stages.unwrap_or(2)]
    } else {
        args.filter_stages.clone()
    };
    if let Some(n) = stage_counts.iter().find(|n| !feedcore::scene::FILTER_STAGES.contains(*n)) {
        bail!("--filter-stages: {n} stages; the command filter has 2 or 3");
    }
    let mut candidates = Vec::new();
    for &b in &args.bandwidths {
        for &stages in &stage_counts {
            // the filter's lag: one time constant per stage
            let lag = f64::from(stages) / (std::f64::consts::TAU * b);
            for share in &shares {
                for &notch in &notches {
                    for &fusion_scale in &scales {
                        let prediction_s = share.map(|s| s * lag);
                        candidates.push(Candidate { bandwidth_hz: b, stages, prediction_s, notch, fusion_scale });
                    }
                }
            }
        }
    }

    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
    let mut declare = |f: &str| outputs.declare("--out", &args.out.join(f), f.rsplit('.').next());
    let (scene_id, csv_id, report_id) = (declare("tuned.toml")?, declare("tune.csv")?, declare("tune.md")?);
    outputs.open()?;
    let jobs = args.jobs.map(usize::from);

    // the uncompensated run: the stability verdict's reference and the decoupled model's poses
    let off = studies::options::Compensation::Off.apply(&scene)?;
    let off_comp = Stewart::from_scene(&scene)?.compensation().cloned().context("a scene with [control]")?;
    let h = case_step(&scene);
    let steps = checked_steps(&scene, h, args.t_end, &format!("{shown}: the runs over {} s", args.t_end))?;
    let off_run = history(&off, &off_comp, h, steps, None).context("the uncompensated run")?;
    let off_rms = rms_peak(&off_run.feed_mm).0;

    let runs: Vec<(usize, Variant)> = (0..candidates.len()).flat_map(|i| VARIANTS.map(|v| (i, v))).collect();
    eprintln!("{shown}: {} candidates × {} runs over {} s …", candidates.len(), VARIANTS.len(), args.t_end);
    let verdicts = studies::parallel::map_in_order(&runs, jobs, |_, &(i, v)| {
        run_one(&scene, &off, &candidates[i], v, args.t_end, &off_run)
    })?;
    let verdict = |i: usize, v: Variant| {
        &verdicts[i * VARIANTS.len() + VARIANTS.iter().position(|x| *x == v).expect("a variant")]
    };
    let robust = |i: usize| VARIANTS.iter().filter(|v| **v != Variant::Decoupled).all(|&v| verdict(i, v).stable);
    let pick = |design: Design| {
        let (variant, admissible): (Variant, &dyn Fn(usize) -> bool) = match design {
            Design::Coupled => (Variant::Nominal, &robust),
            Design::Decoupled => (Variant::Decoupled, &|i| verdict(i, Variant::Decoupled).stable),
        };
        (0..candidates.len())
            .filter(|&i| admissible(i) && verdict(i, variant).rms.is_finite())
            .min_by(|&a, &b| verdict(a, variant).rms.total_cmp(&verdict(b, variant).rms))
    };
    let Some(chosen) = pick(args.design) else {
        bail!("{shown}: no candidate is stable on the {:?} model; try lower --bandwidths", args.design);
    };

    let tuned = tuned_scene(&scene, &args.scene, &candidates[chosen]);
    let tuned_text = format!(
        "# `master tune --design {}` on {} (t_end {} s): the chosen command filter; see tune.md.\n{}",
        design_name(args.design),
        shown,
        args.t_end,
        tuned.to_toml()
    );
    tuned.validated(&outputs.path(scene_id).display().to_string()).context("the tuned scene")?;
    outputs.write(scene_id, |w| w.write_all(tuned_text.as_bytes()))?;

    outputs.write(csv_id, |w| {
        writeln!(
            w,
            "bandwidth_hz,filter_stages,prediction_s,notch_hz,notch_q,fusion_scale,run,verdict,feed_err_rms_mm,feed_err_peak_mm,note"
        )?;
        for (i, c) in candidates.iter().enumerate() {
            for v in VARIANTS {
                let r = verdict(i, v);
                let p = c.prediction_s.map_or(String::new(), |p| format!("{p:e}"));
                let notch = c.notch.map_or(",".to_string(), |(f, q)| format!("{f},{q}"));
                let scale = c.fusion_scale.map_or(String::new(), |k| k.to_string());
                let state = if r.stable { "stable" } else { "unstable" };
                writeln!(
                    w,
                    "{},{},{p},{notch},{scale},{},{state},{:e},{:e},\"{}\"",
                    c.bandwidth_hz,
                    c.stages,
                    v.label(),
                    r.rms,
                    r.peak,
                    r.note.replace('"', "'")
                )?;
            }
        }
        Ok(())
    })?;

    // the report: every candidate, the choice of each design model, and both on the coupled one
    let describe = |i: usize| {
        let c = &candidates[i];
        let mut text = format!("{} Hz", c.bandwidth_hz);
        if c.stages != 2 {
            text += &format!(" in {} stages", c.stages);
        }
        if let Some(p) = c.prediction_s {
            text += &format!(", prediction {p:.4} s");
        }
        if let Some((f, q)) = c.notch {
            text += &format!(", notch {f} Hz Q {q}");
        }
        if let Some(k) = c.fusion_scale.filter(|&k| k != 1.0) {
            text += &format!(", unit noise assumed ×{k}");
        }
        text
    };
    let rms = |i: usize, v: Variant| {
        let r = verdict(i, v);
        if r.stable { format!("{:.3}", r.rms) } else { "unstable".into() }
    };
    let mut all = Table::new(["filter", "coupled RMS (mm)", "decoupled RMS (mm)", "robust (delay ±50 %, mass ±20 %)"]);
    for i in 0..candidates.len() {
        all.row(vec![describe(i), rms(i, Variant::Nominal), rms(i, Variant::Decoupled), yes(robust(i))]);
    }
    let mut choices =
        Table::new(["designed on", "filter", "predicted RMS (mm)", "coupled RMS (mm)", "robust on the coupled model"]);
    for design in [Design::Coupled, Design::Decoupled] {
        let predicted = if design == Design::Coupled { Variant::Nominal } else { Variant::Decoupled };
        match pick(design) {
            Some(i) => choices.row(vec![
                design_name(design).into(),
                describe(i),
                rms(i, predicted),
                rms(i, Variant::Nominal),
                yes(robust(i)),
            ]),
            None => choices.row(vec![
                design_name(design).into(),
                "none stable".into(),
                String::new(),
                String::new(),
                String::new(),
            ]),
        }
    }
    let report = format!(
        "# master tune: {}\n\nScene `{}`, {} s per run, h = {h} s; uncompensated feed error RMS {off_rms:.3} mm. Chosen on \
         the {} model: **{}**.\n\n## The choice of each design model\n\n{}\n## Every candidate\n\n{}",
        scene.name,
        shown,
        args.t_end,
        design_name(args.design),
        describe(chosen),
        choices.render_markdown(),
        all.render_markdown()
    );
    outputs.write(report_id, |w| w.write_all(report.as_bytes()))?;
    let paths: Vec<String> =
        [scene_id, csv_id, report_id].iter().map(|&i| outputs.path(i).display().to_string()).collect();
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    writeln!(out, "{}: {} s per run; uncompensated feed error RMS {off_rms:.3} mm", scene.name, args.t_end)?;
    write!(out, "{}", choices.render())?;
    writeln!(out, "chosen ({} design): {}\n{} written", design_name(args.design), describe(chosen), paths.join(", "))?;
    Ok(())
}

/// The scene with the candidate's filter, named `<name>_tuned`, its FMU paths made absolute (the
/// tuned file lives elsewhere).
fn tuned_scene(scene: &ValidScene, scene_file: &std::path::Path, c: &Candidate) -> Scene {
    let mut tuned = scene.to_scene();
    c.apply(&mut tuned);
    if let (Some(system), Some(dir)) = (tuned.system.as_mut(), scene_file.parent()) {
        for f in &mut system.fmus {
            let p = std::path::Path::new(&f.path);
            if p.is_relative() {
                let joined = dir.join(p);
                let absolute = std::fs::canonicalize(&joined).or_else(|_| std::path::absolute(&joined));
                f.path = absolute.unwrap_or(joined).display().to_string();
            }
        }
    }
    tuned.name = format!("{}_tuned", scene.name);
    tuned
}

fn design_name(d: Design) -> &'static str {
    match d {
        Design::Coupled => "coupled",
        Design::Decoupled => "decoupled",
    }
}

fn yes(b: bool) -> String {
    if b { "yes".into() } else { "no".into() }
}
