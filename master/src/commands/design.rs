//! `master design`: the second level's LQG design of a scene (`monolithic::linear` extracts the
//! design model, `design::study` makes the controller and its bound); writes the scene with
//! `law = "lqg"` and a report.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use design::plant::Instruments;
use design::study::{self, Figures, Limits};
use feedcore::scene::{Law, ValidScene};
use monolithic::linear::{Options, linearize, model_error};
use serde_json::json;

use super::output::{Outputs, run_inputs};
use super::scheme_args::positive;
use super::{CmdResult, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML) with [wind], a sampled sensor and [control.imu].
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Directory for <name>_lqg.toml and design.md (and bound.csv with --rates).
    #[arg(long, default_value = "out/design")]
    pub(crate) out: PathBuf,
    /// The lowest modes computed (platform locked).
    #[arg(long, default_value_t = 90, value_parser = clap::value_parser!(u32).range(1..=feedcore::scene::MAX_DESIGN_MODES as i64))]
    pub(crate) modes: u32,
    /// Every mode up to this frequency is kept (Hz): the band the design model answers for.
    #[arg(long, default_value_t = 3.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) keep_below: f64,
    /// Above it a mode is kept when the cabin carries at least this share of its kinetic energy
    /// (the others, as the cabin's static compliance they leave, become pseudo-modes at 20 Hz).
    #[arg(long, default_value_t = 0.02, value_parser = share)]
    pub(crate) min_cabin_share: f64,
    /// Poles of the wind's rational filter.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=20))]
    pub(crate) wind_sections: u32,
    /// Length of the comparison of the linear and the nonlinear model that measures the model's
    /// error (s; its first 10 s left out).
    #[arg(long, default_value_t = 100.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) error_t_end: f64,
    /// The weight of the feed's rotation against its position (m per rad).
    #[arg(long, default_value_t = 1.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) tilt_weight: f64,
    /// The bound against the fixes' rate (Hz, comma-separated; each the unit's rate divided by a
    /// whole number) and delay (--delays): bound.csv.
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true)]
    pub(crate) rates: Vec<f64>,
    /// Delays of the bound's sweep (s, comma-separated).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_value = "0,0.02,0.05,0.1,0.2,0.3")]
    pub(crate) delays: Vec<f64>,
    /// Wind seeds (comma-separated) on which to run the designed scene, the scene as given and
    /// uncompensated in the monolithic model (the design measures its model's error on the
    /// scene's own seed: give others).
    #[arg(long, value_delimiter = ',')]
    pub(crate) evaluate: Vec<u64>,
    /// Simulated time of each evaluation run (s).
    #[arg(long, default_value_t = 300.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Worker threads of the evaluation (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) jobs: Option<u16>,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
}

fn share(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if (0.0..=1.0).contains(&x) => Ok(x),
        Ok(x) => Err(format!("{x} is not a share in [0, 1]")),
        Err(e) => Err(format!("`{text}`: {e}")),
    }
}

/// Penalties the design starts from: small enough that only the scene's limits raise them.
const STROKE_WEIGHT: f64 = 1e-3;
const FORCE_WEIGHT_M_PER_N: f64 = 1e-7;
const COMMAND_WEIGHT: f64 = 1e-4;

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let shown = args.scene.display().to_string();
    let control = scene.control.as_ref().with_context(|| format!("{shown}: the scene has no [control] section"))?;
    if let Some(d) = args.delays.iter().find(|d| !(d.is_finite() && **d >= 0.0)) {
        bail!("--delays: {d} is not a delay (s, not negative)");
    }
    let ins = Instruments::of(&scene).with_context(|| format!("{shown}: the instruments"))?;
    let delay = control.lqg.as_ref().map_or(control.delay_s, |d| d.delay_s);
    if !args.evaluate.is_empty() && control.delay_s >= args.t_end {
        bail!(
            "{shown}: control.delay_s = {} s is not shorter than an evaluation run (--t-end {} s): no fix would \
             arrive within it",
            control.delay_s,
            args.t_end
        );
    }
    if !(args.error_t_end > 10.0) {
        bail!("--error-t-end {}: the comparison leaves out its first 10 s; give more", args.error_t_end);
    }
    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
    let name = format!("{}_lqg.toml", scene.name);
    let scene_id = outputs.declare("--out", &args.out.join(&name), Some("toml"))?;
    let report_id = outputs.declare("--out", &args.out.join("design.md"), Some("md"))?;
    let sweep_ids = if args.rates.is_empty() {
        None
    } else {
        Some((
            outputs.declare("--out", &args.out.join("bound.csv"), Some("csv"))?,
            outputs.declare("--out", &args.out.join("bound.svg"), Some("svg"))?,
        ))
    };
    outputs.open()?;

    let options = Options {
        modes: args.modes as usize,
        keep_below_hz: args.keep_below,
        min_cabin_share: args.min_cabin_share,
        wind_sections: args.wind_sections as usize,
        delay_s: delay,
        model_error: (0.0, 0.0),
        tilt_weight_m: args.tilt_weight,
        stroke_weight: STROKE_WEIGHT,
        force_weight_m_per_n: FORCE_WEIGHT_M_PER_N,
        command_weight: COMMAND_WEIGHT,
    };
    let lin = linearize(&scene, &options).with_context(|| format!("{shown}: the design model"))?;
    let h = scene.solver.dt_s;
    let error = model_error(&scene, &lin.design, args.error_t_end, 10.0, h)
        .with_context(|| format!("{shown}: the linear model against the nonlinear one"))?;
    let mut design = lin.design.clone();
    (design.model_error_force_n, design.model_error_moment_nm) = (error.force_density, error.moment_density);
    let limits = Limits {
        stroke_m: control.stroke_m.map(|s| [s; 6]),
        force_margin_n: control.force_limit_n.map(|f| lin.static_forces.map(|s| f - s.abs())),
    };
    let (design, cp, syn, bound) =
        study::keep_within(&scene, &design, &ins, &limits).with_context(|| format!("{shown}: the LQG design"))?;
    // the uncompensated fluctuation as the linear model alone predicts it (no error term)
    let mut exact = design.clone();
    (exact.model_error_force_n, exact.model_error_moment_nm) = (0.0, 0.0);
    let open = study::uncompensated(&design::plant::build(&scene, &exact, &ins)?)?;
    let _ = &cp;
    let improved = study::improvements(&scene, &design, &ins);
    let cells =
        if args.rates.is_empty() { Vec::new() } else { study::sweep(&scene, &design, &ins, &args.rates, &args.delays) };

    let designed = designed_scene(&scene, &args.scene, &design);
    designed.clone().validated(&outputs.path(scene_id).display().to_string()).context("the designed scene")?;
    let header = format!("# `master design --scene {shown}`: the second level's LQG controller; see design.md.\n");
    outputs.write(scene_id, |w| w.write_all((header + &designed.to_toml()).as_bytes()))?;
    let kept = lin.modes.iter().filter(|m| m.2).count();
    let highest = lin.modes.last().map_or(0.0, |m| m.0);
    let mm = |m: f64| m * 1e3;
    let mut report = String::new();
    report += &format!("# master design: {}\n\n", scene.name);
    report += &format!(
        "Design model: {kept} of the lowest {} modes (up to {highest:.3} Hz: all to {} Hz, above with a cabin share ≥ {}; \
         the rest's static compliance at the cabin as {} pseudo-modes at 20 Hz), the servo {} × {} Hz, \
         readings at {} Hz, a fix every {} readings {} readings late; the wind's Kaimal filter of {} poles within \
         {:.3} dB over {}–{} Hz (variance {:+.2e}); the model's error against the nonlinear model over {} s: \
         {:.3} mm and {:.3} mrad RMS of {:.3} mm and {:.3} mrad, a white wrench of {:.3} N/√Hz and {:.3} N·m/√Hz.\n\n",
        lin.modes.len(),
        args.keep_below,
        args.min_cabin_share,
        design.modes_hz.len() - kept,
        ins.servo_stages,
        ins.servo_hz,
        1.0 / ins.period,
        ins.fix_every,
        ins.delay_steps,
        lin.wind_fit.poles_hz.len(),
        lin.wind_fit.worst_db,
        scene.wind.as_ref().map_or(0.0, |w| w.band_hz[0]),
        scene.wind.as_ref().map_or(0.0, |w| w.band_hz[1]),
        lin.wind_fit.variance_error,
        args.error_t_end,
        mm(error.residual.0),
        mm(error.residual.1),
        mm(error.response.0),
        mm(error.response.1),
        error.force_density,
        error.moment_density,
    );
    report += &format!(
        "Riccati equations: regulator residual {:.1e} ({} doublings), filter {:.1e} ({} doublings), the filter's \
         period closes to {:.1e}.\n\n",
        syn.regulator.residual, syn.regulator.doublings, syn.filter.residual, syn.filter.doublings, syn.periodicity_gap
    );
    report += &figures_table(&bound, &open, &limits);
    report += "\n| instrument made better | bound, feed RMS (mm) |\n|---|---|\n";
    for (what, feed) in &improved {
        report += &format!("| {what} | {} |\n", feed.as_ref().map_or_else(|e| e.clone(), |f| format!("{:.4}", mm(*f))));
    }
    if let Some((id, svg_id)) = sweep_ids {
        let svg = bound_plot(&scene.name, &cells, &args.rates)?;
        outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
        outputs.write(id, |w| {
            writeln!(w, "rate_hz,delay_s,bound_feed_rms_mm,note")?;
            for c in &cells {
                match &c.feed_m {
                    Ok(f) => writeln!(w, "{},{},{:.6},", c.rate_hz, c.delay_s, mm(*f))?,
                    Err(e) => writeln!(w, "{},{},,{}", c.rate_hz, c.delay_s, e.replace(',', ";"))?,
                }
            }
            Ok(())
        })?;
        report += &sweep_table(&cells, &args.rates, &args.delays);
    }
    let evaluation = evaluate(&scene, &designed, args)?;
    if !evaluation.is_empty() {
        report += &evaluation_table(&scene.name, &evaluation, args);
    }
    outputs.write(report_id, |w| w.write_all(report.as_bytes()))?;
    let mut ids = vec![scene_id, report_id];
    ids.extend(sweep_ids.iter().flat_map(|(a, b)| [*a, *b]));
    let paths: Vec<String> = ids.iter().map(|&i| outputs.path(i).display().to_string()).collect();
    outputs.commit()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        let f = |x: &Figures| {
            json!({"feed_rms_mm": mm(x.feed_m), "feed_components_rms_mm": x.feed_components_m.map(mm),
                   "tilt_rms_mrad": mm(x.tilt_rad), "strokes_rms_mm": x.strokes_m.map(mm), "forces_rms_n": x.forces_n})
        };
        let value = json!({
            "scene": scene.name,
            "modes_kept_hz": design.modes_hz,
            "model_error": {"residual_mm": mm(error.residual.0), "residual_mrad": mm(error.residual.1),
                            "force_density_n": error.force_density, "moment_density_nm": error.moment_density},
            "bound": f(&bound),
            "uncompensated": f(&open),
            "riccati_residuals": [syn.regulator.residual, syn.filter.residual],
            "improvements": improved.iter().map(|(w, r)| json!({"what": w, "bound_feed_rms_mm": r.as_ref().ok().map(|f| mm(*f))})).collect::<Vec<_>>(),
            "evaluation": evaluation.iter().map(|(label, runs)| json!({"run": label,
                "feed_rms_mm": runs.iter().map(|r| r.as_ref().ok().map(|r| mm(r.rms_m))).collect::<Vec<_>>(),
                "feed_peak_mm": runs.iter().map(|r| r.as_ref().ok().map(|r| mm(r.peak_m))).collect::<Vec<_>>(),
                "tilt_rms_mrad": runs.iter().map(|r| r.as_ref().ok().map(|r| mm(r.tilt_rms_rad))).collect::<Vec<_>>(),
                "steps_beyond_limits": runs.iter().map(|r| r.as_ref().ok().map(|r| r.steps_beyond_limits)).collect::<Vec<_>>()})).collect::<Vec<_>>(),
            "sweep": cells.iter().map(|c| json!({"rate_hz": c.rate_hz, "delay_s": c.delay_s, "bound_feed_rms_mm": c.feed_m.as_ref().ok().map(|f| mm(*f))})).collect::<Vec<_>>(),
            "written": paths,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&value)?)?;
    } else {
        write!(out, "{report}")?;
        writeln!(out, "\nwritten: {}", paths.join(", "))?;
    }
    Ok(())
}

/// The predicted figures against the uncompensated model's.
fn figures_table(bound: &Figures, open: &Figures, limits: &Limits) -> String {
    let mm = |m: f64| m * 1e3;
    let worst = |v: &[f64; 6]| v.iter().fold(0.0f64, |a, b| a.max(*b));
    let mut s = String::from("| predicted RMS | LQG (the bound) | uncompensated (fluctuation) |\n|---|---|---|\n");
    s += &format!("| feed position | {:.4} mm | {:.3} mm |\n", mm(bound.feed_m), mm(open.feed_m));
    s += &format!(
        "| feed x, y, z | {:.4}, {:.4}, {:.4} mm | {:.3}, {:.3}, {:.3} mm |\n",
        mm(bound.feed_components_m[0]),
        mm(bound.feed_components_m[1]),
        mm(bound.feed_components_m[2]),
        mm(open.feed_components_m[0]),
        mm(open.feed_components_m[1]),
        mm(open.feed_components_m[2])
    );
    s += &format!("| feed tilt | {:.4} mrad | {:.3} mrad |\n", mm(bound.tilt_rad), mm(open.tilt_rad));
    s += &format!("| largest stroke | {:.3} mm | |\n", mm(worst(&bound.strokes_m)));
    s += &format!(
        "| largest actuator force change | {:.2} N | {:.2} N |\n",
        worst(&bound.forces_n),
        worst(&open.forces_n)
    );
    s += &format!(
        "\nThe predicted peaks (×{}) take {:.1} % of the scene's stroke and force limits at most.\n",
        study::PEAK_FACTOR,
        100.0 * limits.usage(bound)
    );
    s
}

fn sweep_table(cells: &[study::Cell], rates: &[f64], delays: &[f64]) -> String {
    let mut s = String::from("\nThe bound (feed RMS, mm) against the fixes' rate and delay:\n\n| rate \\ delay |");
    for d in delays {
        s += &format!(" {} ms |", d * 1e3);
    }
    s += "\n|---|";
    s += &"---|".repeat(delays.len());
    for r in rates {
        s += &format!("\n| {r} Hz |");
        for d in delays {
            let cell = cells.iter().find(|c| c.rate_hz == *r && c.delay_s == *d);
            match cell.map(|c| &c.feed_m) {
                Some(Ok(f)) => s += &format!(" {:.4} |", f * 1e3),
                _ => s += " – |",
            }
        }
    }
    s + "\n"
}

/// The scene with `law = "lqg"` and its design, the filter's own keys taken out, named
/// `<name>_lqg`, its FMU paths made absolute (the designed file lives elsewhere).
fn designed_scene(
    scene: &ValidScene,
    scene_file: &std::path::Path,
    design: &feedcore::scene::LqgDesign,
) -> feedcore::scene::Scene {
    let mut s = scene.to_scene();
    if let Some(c) = s.control.as_mut() {
        c.law = Law::Lqg;
        c.lqg = Some(design.clone());
        (c.notch_hz, c.notch_q, c.prediction_s) = (None, None, None);
    }
    if let (Some(system), Some(dir)) = (s.system.as_mut(), scene_file.parent()) {
        for f in &mut system.fmus {
            let joined = dir.join(&f.path);
            let absolute = std::fs::canonicalize(&joined).ok();
            f.path = absolute.unwrap_or(joined).display().to_string();
        }
    }
    s.name = format!("{}_lqg", scene.name);
    s
}

type Evaluation = Vec<(String, Vec<Result<monolithic::feed::FeedRun, String>>)>;

/// The designed scene, the scene as given and uncompensated, each on every seed of --evaluate.
fn evaluate(scene: &ValidScene, designed: &feedcore::scene::Scene, args: &Args) -> anyhow::Result<Evaluation> {
    if args.evaluate.is_empty() {
        return Ok(Vec::new());
    }
    let lqg = designed.clone().validated(scene.file()).context("the designed scene")?;
    let off = studies::options::Compensation::Off.apply(scene)?;
    let mut variants = vec![
        ("LQG (designed)".to_string(), lqg.clone()),
        (format!("{} (as given)", scene.name), scene.clone()),
        ("uncompensated".to_string(), off),
    ];
    // robust as `master tune` asks: the delay ×0.5 and ×1.5, the platform's mass ×0.8 and ×1.2
    // (the controller designed for the nominal ones), on the first seed
    for f in [0.5, 1.5] {
        variants.push((format!("LQG, delay ×{f}"), lqg.edited(|s| s.control.iter_mut().for_each(|c| c.delay_s *= f))?));
    }
    for f in [0.8, 1.2] {
        variants.push((format!("LQG, platform mass ×{f}"), lqg.edited(|s| studies::sweep::scale_platform_mass(s, f))?));
    }
    let h = monolithic::feed::step_for(scene);
    let steps = studies::compensation::checked_steps(scene, h, args.t_end, "an evaluation run", &super::caps().run)?;
    let seeds = |v: usize| if v < 3 { args.evaluate.clone() } else { vec![args.evaluate[0]] };
    let runs: Vec<(usize, u64)> = (0..variants.len()).flat_map(|v| seeds(v).into_iter().map(move |s| (v, s))).collect();
    eprintln!("{}: {} runs of {} s …", scene.name, runs.len(), args.t_end);
    let results = studies::parallel::map_in_order(&runs, args.jobs.map(usize::from), |_, &(v, seed)| {
        let seeded = variants[v].1.edited(|s| {
            if let Some(w) = s.wind.as_mut() {
                w.seed = seed;
            }
        });
        seeded
            .map_err(|e| e.to_string())
            .and_then(|s| monolithic::feed::feed_run(&s, h, steps).map_err(|e| e.to_string()))
    })?;
    let mut results = results.into_iter();
    Ok(variants
        .iter()
        .enumerate()
        .map(|(v, (label, _))| (label.clone(), results.by_ref().take(seeds(v).len()).collect()))
        .collect())
}

/// Mean and (sample) standard deviation.
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sd = if x.len() > 1 { (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
    (mean, sd)
}

fn evaluation_table(name: &str, evaluation: &Evaluation, args: &Args) -> String {
    let seeds: Vec<String> = args.evaluate.iter().map(u64::to_string).collect();
    let mut s = format!(
        "\nThe monolithic model, {} s, wind seeds {} of {name} (mean ± standard deviation over the seeds; feed RMS \
         per seed in brackets; the robustness runs on the first seed):\n\n| run | feed RMS (mm) | feed peak (mm) | tilt RMS (mrad) | steps beyond a limit |\n|---|---|---|---|---|\n",
        args.t_end,
        seeds.join(", ")
    );
    for (label, runs) in evaluation {
        let ok: Vec<&monolithic::feed::FeedRun> = runs.iter().filter_map(|r| r.as_ref().ok()).collect();
        if ok.len() < runs.len() {
            let why: Vec<&String> = runs.iter().filter_map(|r| r.as_ref().err()).collect();
            s += &format!("| {label} | stopped: {} | | | |\n", why[0]);
            continue;
        }
        let col = |f: &dyn Fn(&monolithic::feed::FeedRun) -> f64| mean_sd(&ok.iter().map(|r| f(r)).collect::<Vec<_>>());
        let (rms, peak, tilt) = (col(&|r| r.rms_m * 1e3), col(&|r| r.peak_m * 1e3), col(&|r| r.tilt_rms_rad * 1e3));
        let each: Vec<String> = ok.iter().map(|r| format!("{:.4}", r.rms_m * 1e3)).collect();
        let beyond: usize = ok.iter().map(|r| r.steps_beyond_limits).sum();
        s += &format!(
            "| {label} | {:.4} ± {:.4} ({}) | {:.3} ± {:.3} | {:.4} ± {:.4} | {beyond} |\n",
            rms.0,
            rms.1,
            each.join(", "),
            peak.0,
            peak.1,
            tilt.0,
            tilt.1
        );
    }
    s
}

/// The bound against the fixes' delay, a line per rate.
fn bound_plot(name: &str, cells: &[study::Cell], rates: &[f64]) -> anyhow::Result<String> {
    use plotters::prelude::*;
    let points = |r: f64| -> Vec<(f64, f64)> {
        cells
            .iter()
            .filter(|c| c.rate_hz == r)
            .filter_map(|c| c.feed_m.as_ref().ok().map(|f| (c.delay_s * 1e3, f * 1e3)))
            .collect()
    };
    let all: Vec<(f64, f64)> = rates.iter().flat_map(|&r| points(r)).collect();
    let x1 = all.iter().map(|p| p.0).fold(1.0f64, f64::max);
    let y1 = all.iter().map(|p| p.1).fold(0.0f64, f64::max) * 1.1;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{name}: the LQG bound against the fixes' rate and delay"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..x1, 0.0..y1.max(1e-6))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc("delay of the fixes (ms)")
            .y_desc("bound: feed RMS (mm)")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        for (i, &r) in rates.iter().enumerate() {
            studies::plot::palette_line(&mut chart, i, points(r), &format!("fixes at {r} Hz"))?;
        }
        studies::plot::legend(&mut chart, 13)?;
        root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    Ok(svg)
}
