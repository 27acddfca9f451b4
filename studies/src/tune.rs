//! The second level's command filter chosen on runs of minutes, in parallel.
//!
//! Every candidate (a filter bandwidth; with an inertial unit a prediction horizon as a share of
//! the filter's lag (2τ, or 3τ with three stages); with a notch frequency the notch's quality) is run three ways: on the coupled (monolithic) model, on the
//! decoupled one (its commands replayed on the uncompensated run's cabin poses: the platform's
//! reactions never reach the cabin), and on the coupled model with the sensor's delay ×0.5 and
//! ×1.5 and the platform's mass ×0.8 and ×1.2. The design model (the settings' `design`) picks: the lowest
//! feed error RMS among the candidates it calls stable — the coupled model every run of a
//! candidate stable (`master compensation`'s verdict: no stop, no growing error, the cabin's
//! peak within twice the uncompensated), the decoupled model cannot see instability. Written:
//! the scene with the chosen filter, `tune.csv` (every candidate, every run) and `tune.md` (the
//! choice, and what the decoupled model's choice does on the coupled one).

use anyhow::{Context, bail};
use feedcore::scene::{FusionModel, Scene, SensorKind, ValidScene};
use stewart::Stewart;

use crate::compensation::{History, Verdict, case_step, checked_steps, history, rms_peak};
use crate::limits::Limits;
use crate::observe::Observer;
use crate::options::Named;
use crate::table::Table;

/// The model the choice is made on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Design {
    Coupled,
    Decoupled,
}

impl Named for Design {
    const ALL: &'static [Design] = &[Design::Coupled, Design::Decoupled];

    fn name(self) -> &'static str {
        match self {
            Design::Coupled => "coupled",
            Design::Decoupled => "decoupled",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Design::Coupled => "The monolithic model: the platform's reactions move the cabin",
            Design::Decoupled => "The cabin's uncompensated motion, the commands replayed on it",
        }
    }
}

/// What is tried.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub design: Design,
    /// Simulated time of every run, s.
    pub t_end: f64,
    /// Filter bandwidths tried, Hz.
    pub bandwidths: Vec<f64>,
    /// Numbers of filter stages tried (empty: the scene's).
    pub filter_stages: Vec<u32>,
    /// With an inertial unit: prediction horizons tried, as shares of the filter's lag.
    pub predictions: Vec<f64>,
    /// With an inertial unit: scales of the unit noise the fusion filter assumes.
    pub fusion_scales: Vec<f64>,
    /// A notch in the commands at this frequency, Hz (`None`: the scene's, if any).
    pub notch_hz: Option<f64>,
    /// With a notch: its qualities tried.
    pub notch_qs: Vec<f64>,
    /// Worker threads (`None`: one per core).
    pub jobs: Option<usize>,
    pub limits: Limits,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            design: Design::Coupled,
            t_end: 300.0,
            bandwidths: vec![0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0],
            filter_stages: Vec::new(),
            predictions: vec![0.0, 0.25, 0.5],
            fusion_scales: vec![1.0],
            notch_hz: None,
            notch_qs: vec![2.0, 4.0, 8.0],
            jobs: None,
            limits: Limits::default(),
        }
    }
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
pub struct Candidate {
    pub bandwidth_hz: f64,
    /// First-order stages of the filter: 2 or 3.
    pub stages: u32,
    pub prediction_s: Option<f64>,
    /// The notch: frequency, quality.
    pub notch: Option<(f64, f64)>,
    /// The scale of the unit's noise the fusion filter assumes (with an inertial unit).
    pub fusion_scale: Option<f64>,
}

impl Candidate {
    pub fn apply(&self, s: &mut Scene) {
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
fn run_one(
    base: &ValidScene,
    off: &ValidScene,
    c: &Candidate,
    v: Variant,
    t_end: f64,
    off_run: &History,
    limits: &Limits,
) -> Verdict {
    let result = (|| -> anyhow::Result<History> {
        let scene = base.edited(|s| {
            c.apply(s);
            match v {
                Variant::Delay(f) => {
                    if let Some(control) = s.control.as_mut() {
                        control.delay_s *= f;
                    }
                }
                Variant::Mass(f) => crate::sweep::scale_platform_mass(s, f),
                Variant::Nominal | Variant::Decoupled => {}
            }
        })?;
        let comp = Stewart::from_scene(&scene)?.compensation().cloned().context("a scene with [control]")?;
        let h = case_step(&scene);
        let steps = checked_steps(&scene, h, t_end, "a tuning run", limits)?;
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

/// A tuning ready to run: its candidates made, the runs' steps checked.
pub struct Tuning {
    scene: ValidScene,
    /// How messages name the scene (its file).
    shown: String,
    settings: Settings,
    pub candidates: Vec<Candidate>,
    h: f64,
    steps: usize,
}

/// The tuning's results.
pub struct Results {
    pub scene: String,
    shown: String,
    pub settings: Settings,
    pub h: f64,
    /// The uncompensated run's feed error RMS, mm.
    pub off_rms: f64,
    pub candidates: Vec<Candidate>,
    /// Every candidate's run of every variant, by candidate then variant.
    verdicts: Vec<Verdict>,
    /// The candidate chosen on the settings' design model.
    pub chosen: usize,
}

impl Tuning {
    /// The tuning of `scene` (named `shown` in messages): a sampled sensor needed.
    pub fn new(scene: &ValidScene, shown: &str, settings: Settings) -> anyhow::Result<Tuning> {
        let control = scene.control.as_ref().with_context(|| format!("{shown}: the scene has no [control] section"))?;
        if control.sensor != SensorKind::Sampled {
            bail!("{shown}: [control] sensor = {:?}; `master tune` tunes a sampled sensor's filter", control.sensor);
        }
        if let Some(p) = settings.predictions.iter().find(|p| !(p.is_finite() && **p >= 0.0)) {
            bail!("--predictions: {p} is not a non-negative share of the filter's lag");
        }
        let shares: Vec<Option<f64>> =
            if control.imu.is_some() { settings.predictions.iter().map(|&p| Some(p)).collect() } else { vec![None] };
        let scales: Vec<Option<f64>> =
            if control.imu.is_some() { settings.fusion_scales.iter().map(|&k| Some(k)).collect() } else { vec![None] };
        let notches: Vec<Option<(f64, f64)>> = match settings.notch_hz.or(control.notch_hz) {
            Some(f) => settings.notch_qs.iter().map(|&q| Some((f, q))).collect(),
            None => vec![None],
        };
        let stage_counts = if settings.filter_stages.is_empty() {
            vec![control.filter_stages.unwrap_or(2)]
        } else {
            settings.filter_stages.clone()
        };
        if let Some(n) = stage_counts.iter().find(|n| !feedcore::scene::FILTER_STAGES.contains(*n)) {
            bail!("--filter-stages: {n} stages; the command filter has 2 or 3");
        }
        let mut candidates = Vec::new();
        for &b in &settings.bandwidths {
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
        let h = case_step(scene);
        let what = format!("{shown}: the runs over {} s", settings.t_end);
        let steps = checked_steps(scene, h, settings.t_end, &what, &settings.limits)?;
        Ok(Tuning { scene: scene.clone(), shown: shown.to_owned(), settings, candidates, h, steps })
    }

    /// Runs the uncompensated reference, then every candidate every way, in parallel.
    pub fn run(&self, observer: &dyn Observer) -> anyhow::Result<Results> {
        let (scene, s) = (&self.scene, &self.settings);
        // the uncompensated run: the stability verdict's reference and the decoupled model's poses
        let off = crate::options::Compensation::Off.apply(scene)?;
        let off_comp = Stewart::from_scene(scene)?.compensation().cloned().context("a scene with [control]")?;
        let off_run = history(&off, &off_comp, self.h, self.steps, None).context("the uncompensated run")?;
        let off_rms = rms_peak(&off_run.feed_mm).0;
        let runs: Vec<(usize, Variant)> = (0..self.candidates.len()).flat_map(|i| VARIANTS.map(|v| (i, v))).collect();
        observer.begin(&format!(
            "{}: {} candidates × {} runs over {} s",
            self.shown,
            self.candidates.len(),
            VARIANTS.len(),
            s.t_end
        ));
        let verdicts = crate::parallel::map_in_order(&runs, s.jobs, |_, &(i, v)| {
            run_one(scene, &off, &self.candidates[i], v, s.t_end, &off_run, &s.limits)
        })?;
        let mut results = Results {
            scene: scene.name.clone(),
            shown: self.shown.clone(),
            settings: s.clone(),
            h: self.h,
            off_rms,
            candidates: self.candidates.clone(),
            verdicts,
            chosen: 0,
        };
        results.chosen = results.pick(s.design).with_context(|| {
            format!("{}: no candidate is stable on the {:?} model; try lower --bandwidths", self.shown, s.design)
        })?;
        Ok(results)
    }
}

impl Results {
    fn verdict(&self, i: usize, v: Variant) -> &Verdict {
        &self.verdicts[i * VARIANTS.len() + VARIANTS.iter().position(|x| *x == v).expect("a variant")]
    }

    /// Whether candidate `i` is stable on the coupled model every way it was run.
    fn robust(&self, i: usize) -> bool {
        VARIANTS.iter().filter(|v| **v != Variant::Decoupled).all(|&v| self.verdict(i, v).stable)
    }

    /// The candidate a design model picks: the lowest feed error among those it calls stable.
    fn pick(&self, design: Design) -> Option<usize> {
        let variant = match design {
            Design::Coupled => Variant::Nominal,
            Design::Decoupled => Variant::Decoupled,
        };
        let admissible = |i: usize| {
            if design == Design::Coupled { self.robust(i) } else { self.verdict(i, Variant::Decoupled).stable }
        };
        (0..self.candidates.len())
            .filter(|&i| admissible(i) && self.verdict(i, variant).rms.is_finite())
            .min_by(|&a, &b| self.verdict(a, variant).rms.total_cmp(&self.verdict(b, variant).rms))
    }

    /// A candidate in words.
    pub fn describe(&self, i: usize) -> String {
        let c = &self.candidates[i];
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
    }

    fn rms(&self, i: usize, v: Variant) -> String {
        let r = self.verdict(i, v);
        if r.stable { format!("{:.3}", r.rms) } else { "unstable".into() }
    }

    /// The choice of each design model, and both on the coupled one.
    pub fn choices(&self) -> Table {
        let mut choices = Table::new([
            "designed on",
            "filter",
            "predicted RMS (mm)",
            "coupled RMS (mm)",
            "robust on the coupled model",
        ]);
        for design in [Design::Coupled, Design::Decoupled] {
            let predicted = if design == Design::Coupled { Variant::Nominal } else { Variant::Decoupled };
            match self.pick(design) {
                Some(i) => choices.row(vec![
                    design.name().into(),
                    self.describe(i),
                    self.rms(i, predicted),
                    self.rms(i, Variant::Nominal),
                    yes(self.robust(i)),
                ]),
                None => choices.row(vec![
                    design.name().into(),
                    "none stable".into(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
        }
        choices
    }

    /// `tune.csv`: every candidate, every run.
    pub fn csv(&self) -> String {
        let mut csv = String::from(
            "bandwidth_hz,filter_stages,prediction_s,notch_hz,notch_q,fusion_scale,run,verdict,feed_err_rms_mm,feed_err_peak_mm,note\n",
        );
        for (i, c) in self.candidates.iter().enumerate() {
            for v in VARIANTS {
                let r = self.verdict(i, v);
                let p = c.prediction_s.map_or(String::new(), |p| format!("{p:e}"));
                let notch = c.notch.map_or(",".to_string(), |(f, q)| format!("{f},{q}"));
                let scale = c.fusion_scale.map_or(String::new(), |k| k.to_string());
                let state = if r.stable { "stable" } else { "unstable" };
                csv.push_str(&format!(
                    "{},{},{p},{notch},{scale},{},{state},{:e},{:e},\"{}\"\n",
                    c.bandwidth_hz,
                    c.stages,
                    v.label(),
                    r.rms,
                    r.peak,
                    r.note.replace('"', "'")
                ));
            }
        }
        csv
    }

    /// `tune.md`: every candidate, the choice of each design model, and both on the coupled one.
    pub fn report(&self) -> String {
        let mut all =
            Table::new(["filter", "coupled RMS (mm)", "decoupled RMS (mm)", "robust (delay ±50 %, mass ±20 %)"]);
        for i in 0..self.candidates.len() {
            all.row(vec![
                self.describe(i),
                self.rms(i, Variant::Nominal),
                self.rms(i, Variant::Decoupled),
                yes(self.robust(i)),
            ]);
        }
        format!(
            "# master tune: {}\n\nScene `{}`, {} s per run, h = {} s; uncompensated feed error RMS {:.3} mm. Chosen on \
             the {} model: **{}**.\n\n## The choice of each design model\n\n{}\n## Every candidate\n\n{}",
            self.scene,
            self.shown,
            self.settings.t_end,
            self.h,
            self.off_rms,
            self.settings.design.name(),
            self.describe(self.chosen),
            self.choices().render_markdown(),
            all.render_markdown()
        )
    }

    /// The chosen candidate.
    pub fn chosen(&self) -> &Candidate {
        &self.candidates[self.chosen]
    }
}

/// The scene with the candidate's filter, named `<name>_tuned`, its FMU paths made absolute (the
/// tuned file lives elsewhere).
pub fn tuned_scene(scene: &ValidScene, scene_file: &std::path::Path, c: &Candidate) -> Scene {
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

fn yes(b: bool) -> String {
    if b { "yes".into() } else { "no".into() }
}
