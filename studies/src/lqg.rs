//! The second level's LQG design of a scene and its bound (`master design`): the design model
//! extracted from the nonlinear models (`monolithic::linear`), its error measured against them,
//! the controller made by the `design` crate with its penalties raised until the scene's limits
//! hold, the bound with each instrument made better and against the fixes' rate and delay, and
//! the designed scene run in the monolithic model on other wind records.

use std::path::Path;

use anyhow::{Context, bail};
use design::plant::Instruments;
use design::study::{self, Cell, Figures, Limits};
use feedcore::scene::{Law, LqgDesign, Scene, ValidScene};
use monolithic::feed::FeedRun;
use monolithic::linear::{ModelError, Options, linearize, model_error};
use serde_json::json;

use crate::limits::Limits as RunLimits;
use crate::observe::Observer;

/// Penalties the design starts from: small enough that only the scene's limits raise them.
const STROKE_WEIGHT: f64 = 1e-3;
const FORCE_WEIGHT_M_PER_N: f64 = 1e-7;
const COMMAND_WEIGHT: f64 = 1e-4;
/// Most poles of the wind's rational filter.
pub const MAX_WIND_SECTIONS: usize = 20;

/// What `master design` is asked.
#[derive(Clone, Debug)]
pub struct Settings {
    /// The lowest modes computed (platform locked).
    pub modes: usize,
    /// Every mode up to this frequency is kept (Hz).
    pub keep_below_hz: f64,
    /// Above it a mode is kept when the cabin carries at least this share of its kinetic energy.
    pub min_cabin_share: f64,
    /// Poles of the wind's rational filter.
    pub wind_sections: usize,
    /// Length of the comparison of the linear and the nonlinear model (s; its first 10 s left out).
    pub error_t_end: f64,
    /// The weight of the feed's rotation against its position (m per rad).
    pub tilt_weight_m: f64,
    /// The bound against the fixes' rate (Hz; empty: no such sweep) and delay (s).
    pub rates: Vec<f64>,
    pub delays: Vec<f64>,
    /// Wind seeds on which the designed scene, the scene as given and uncompensated are run.
    pub evaluate: Vec<u64>,
    /// Simulated time of each evaluation run (s).
    pub t_end: f64,
    /// Worker threads of the evaluation (None: one per core).
    pub jobs: Option<usize>,
    pub limits: RunLimits,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            modes: 90,
            keep_below_hz: 3.0,
            min_cabin_share: 0.02,
            wind_sections: 6,
            error_t_end: 100.0,
            tilt_weight_m: 1.0,
            rates: Vec::new(),
            delays: vec![0.0, 0.02, 0.05, 0.1, 0.2, 0.3],
            evaluate: Vec::new(),
            t_end: 300.0,
            jobs: None,
            limits: RunLimits::default(),
        }
    }
}

/// The monolithic runs of one variant of the scene, one per evaluated seed.
pub type Evaluation = Vec<(String, Vec<Result<FeedRun, String>>)>;

/// A design ready to run: the settings checked against the scene, its instruments read.
pub struct Designing {
    scene: ValidScene,
    shown: String,
    settings: Settings,
    instruments: Instruments,
    /// The fixes' delay the design assumes.
    delay_s: f64,
}

/// What the design found.
pub struct Results {
    pub scene: String,
    pub settings: Settings,
    pub instruments: Instruments,
    /// The lowest modes: (frequency Hz, cabin share, kept).
    pub modes: Vec<(f64, f64, bool)>,
    pub wind_fit: design::kaimal::Fit,
    /// The linear model against the nonlinear one at the scene's wind.
    pub error: ModelError,
    /// The design, its penalties raised until the limits hold.
    pub design: LqgDesign,
    pub limits: Limits,
    /// The predicted figures of the LQG controller: the bound.
    pub bound: Figures,
    /// The uncompensated fluctuation as the linear model alone predicts it.
    pub open: Figures,
    /// The Riccati equations' residuals and doublings (regulator, filter), the filter's periodicity gap.
    pub riccati: [(f64, usize); 2],
    pub periodicity_gap: f64,
    /// The bound with each instrument made better: (what, feed RMS m or why not).
    pub improved: Vec<(String, Result<f64, String>)>,
    /// The bound against the fixes' rate and delay.
    pub cells: Vec<Cell>,
    /// The scene with `law = "lqg"` and the design.
    pub designed: Scene,
    pub evaluation: Evaluation,
}

impl Designing {
    /// The design of `scene` (read from `scene_file`, named `shown` in messages): a `[control]`
    /// with a sampled sensor and an inertial unit needed.
    pub fn new(scene: &ValidScene, shown: &str, settings: Settings) -> anyhow::Result<Designing> {
        let control = scene.control.as_ref().with_context(|| format!("{shown}: the scene has no [control] section"))?;
        if let Some(d) = settings.delays.iter().find(|d| !(d.is_finite() && **d >= 0.0)) {
            bail!("--delays: {d} is not a delay (s, not negative)");
        }
        if let Some(r) = settings.rates.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
            bail!("--rates: {r} is not a rate (Hz, positive)");
        }
        if !(1..=feedcore::scene::MAX_DESIGN_MODES).contains(&settings.modes) {
            bail!("--modes {}: from 1 to {} modes", settings.modes, feedcore::scene::MAX_DESIGN_MODES);
        }
        if !(0.0..=1.0).contains(&settings.min_cabin_share) {
            bail!("--min-cabin-share {}: a share in [0, 1]", settings.min_cabin_share);
        }
        if !(1..=MAX_WIND_SECTIONS).contains(&settings.wind_sections) {
            bail!("--wind-sections {}: from 1 to {MAX_WIND_SECTIONS} poles", settings.wind_sections);
        }
        for (name, x) in [
            ("--keep-below", settings.keep_below_hz),
            ("--tilt-weight", settings.tilt_weight_m),
            ("--t-end", settings.t_end),
        ] {
            if !(x.is_finite() && x > 0.0) {
                bail!("{name} {x}: a positive number");
            }
        }
        let instruments = Instruments::of(scene).with_context(|| format!("{shown}: the instruments"))?;
        let delay_s = control.lqg.as_ref().map_or(control.delay_s, |d| d.delay_s);
        if !settings.evaluate.is_empty() && control.delay_s >= settings.t_end {
            bail!(
                "{shown}: control.delay_s = {} s is not shorter than an evaluation run (--t-end {} s): no fix would \
                 arrive within it",
                control.delay_s,
                settings.t_end
            );
        }
        if !(settings.error_t_end > 10.0) {
            bail!("--error-t-end {}: the comparison leaves out its first 10 s; give more", settings.error_t_end);
        }
        Ok(Designing { scene: scene.clone(), shown: shown.to_owned(), settings, instruments, delay_s })
    }

    /// Designs, predicts, sweeps and evaluates; `scene_file` is where the scene was read from
    /// (the designed scene's FMU paths are made absolute from it).
    pub fn run(&self, scene_file: &Path, observer: &dyn Observer) -> anyhow::Result<Results> {
        let (scene, s, shown, ins) = (&self.scene, &self.settings, &self.shown, &self.instruments);
        let control = scene.control.as_ref().expect("checked by Designing::new");
        let options = Options {
            modes: s.modes,
            keep_below_hz: s.keep_below_hz,
            min_cabin_share: s.min_cabin_share,
            wind_sections: s.wind_sections,
            delay_s: self.delay_s,
            model_error: (0.0, 0.0),
            tilt_weight_m: s.tilt_weight_m,
            stroke_weight: STROKE_WEIGHT,
            force_weight_m_per_n: FORCE_WEIGHT_M_PER_N,
            command_weight: COMMAND_WEIGHT,
        };
        let lin = linearize(scene, &options).with_context(|| format!("{shown}: the design model"))?;
        let error = model_error(scene, &lin.design, s.error_t_end, 10.0, scene.solver.dt_s)
            .with_context(|| format!("{shown}: the linear model against the nonlinear one"))?;
        let mut design = lin.design.clone();
        (design.model_error_force_n, design.model_error_moment_nm) = (error.force_density, error.moment_density);
        let limits = Limits {
            stroke_m: control.stroke_m.map(|s| [s; 6]),
            force_margin_n: control.force_limit_n.map(|f| lin.static_forces.map(|s| f - s.abs())),
        };
        let (design, _, syn, bound) =
            study::keep_within(scene, &design, ins, &limits).with_context(|| format!("{shown}: the LQG design"))?;
        // the uncompensated fluctuation as the linear model alone predicts it (no error term)
        let mut exact = design.clone();
        (exact.model_error_force_n, exact.model_error_moment_nm) = (0.0, 0.0);
        let open = study::uncompensated(&design::plant::build(scene, &exact, ins)?)?;
        let improved = study::improvements(scene, &design, ins);
        let cells =
            if s.rates.is_empty() { Vec::new() } else { study::sweep(scene, &design, ins, &s.rates, &s.delays) };
        let designed = designed_scene(scene, scene_file, &design);
        let evaluation = self.evaluate(&designed, observer)?;
        Ok(Results {
            scene: scene.name.clone(),
            settings: s.clone(),
            instruments: *ins,
            modes: lin.modes,
            wind_fit: lin.wind_fit,
            error,
            design,
            limits,
            bound,
            open,
            riccati: [(syn.regulator.residual, syn.regulator.doublings), (syn.filter.residual, syn.filter.doublings)],
            periodicity_gap: syn.periodicity_gap,
            improved,
            cells,
            designed,
            evaluation,
        })
    }

    /// The designed scene, the scene as given and uncompensated, each on every seed of
    /// `evaluate`; the robustness runs on the first seed.
    fn evaluate(&self, designed: &Scene, observer: &dyn Observer) -> anyhow::Result<Evaluation> {
        let (scene, s) = (&self.scene, &self.settings);
        if s.evaluate.is_empty() {
            return Ok(Vec::new());
        }
        let lqg = designed.clone().validated(scene.file()).context("the designed scene")?;
        let off = crate::options::Compensation::Off.apply(scene)?;
        let mut variants = vec![
            ("LQG (designed)".to_string(), lqg.clone()),
            (format!("{} (as given)", scene.name), scene.clone()),
            ("uncompensated".to_string(), off),
        ];
        // robust as `master tune` asks: the delay ×0.5 and ×1.5, the platform's mass ×0.8 and ×1.2
        // (the controller designed for the nominal ones)
        for f in [0.5, 1.5] {
            variants
                .push((format!("LQG, delay ×{f}"), lqg.edited(|s| s.control.iter_mut().for_each(|c| c.delay_s *= f))?));
        }
        for f in [0.8, 1.2] {
            variants
                .push((format!("LQG, platform mass ×{f}"), lqg.edited(|s| crate::sweep::scale_platform_mass(s, f))?));
        }
        let h = monolithic::feed::step_for(scene);
        let steps = crate::compensation::checked_steps(scene, h, s.t_end, "an evaluation run", &s.limits)?;
        let seeds = |v: usize| if v < 3 { s.evaluate.clone() } else { vec![s.evaluate[0]] };
        let runs: Vec<(usize, u64)> =
            (0..variants.len()).flat_map(|v| seeds(v).into_iter().map(move |seed| (v, seed))).collect();
        observer.begin(&format!("{}: {} runs of {} s", self.shown, runs.len(), s.t_end));
        let results = crate::parallel::map_in_order(&runs, s.jobs, |_, &(v, seed)| {
            variants[v]
                .1
                .edited(|s| s.wind.iter_mut().for_each(|w| w.seed = seed))
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
}

/// The scene with `law = "lqg"` and its design, the filter's own keys taken out, named
/// `<name>_lqg`, its FMU paths made absolute (the designed file lives elsewhere).
pub fn designed_scene(scene: &ValidScene, scene_file: &Path, design: &LqgDesign) -> Scene {
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

fn mm(m: f64) -> f64 {
    m * 1e3
}

/// Mean and (sample) standard deviation.
fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sd = if x.len() > 1 { (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
    (mean, sd)
}

impl Results {
    /// The report (design.md): the design model, the Riccati residuals, the bound against the
    /// uncompensated model, the instruments made better, the sweep and the evaluation.
    pub fn report(&self) -> String {
        let (s, ins, error, design) = (&self.settings, &self.instruments, &self.error, &self.design);
        let kept = self.modes.iter().filter(|m| m.2).count();
        let highest = self.modes.last().map_or(0.0, |m| m.0);
        let band = |k: usize| self.designed.wind.as_ref().map_or(0.0, |w| w.band_hz[k]);
        let mut report = format!("# master design: {}\n\n", self.scene);
        report += &format!(
            "Design model: {kept} of the lowest {} modes (up to {highest:.3} Hz: all to {} Hz, above with a cabin share \
             ≥ {}; the rest's static compliance at the cabin as {} pseudo-modes at 20 Hz), the servo {} × {} Hz, \
             readings at {} Hz, a fix every {} readings {} readings late; the wind's Kaimal filter of {} poles within \
             {:.3} dB over {}–{} Hz (variance {:+.2e}); the model's error against the nonlinear model over {} s: \
             {:.3} mm and {:.3} mrad RMS of {:.3} mm and {:.3} mrad, a white wrench of {:.3} N/√Hz and {:.3} N·m/√Hz.\n\n",
            self.modes.len(),
            s.keep_below_hz,
            s.min_cabin_share,
            design.modes_hz.len() - kept,
            ins.servo_stages,
            ins.servo_hz,
            1.0 / ins.period,
            ins.fix_every,
            ins.delay_steps,
            self.wind_fit.poles_hz.len(),
            self.wind_fit.worst_db,
            band(0),
            band(1),
            self.wind_fit.variance_error,
            s.error_t_end,
            mm(error.residual.0),
            mm(error.residual.1),
            mm(error.response.0),
            mm(error.response.1),
            error.force_density,
            error.moment_density,
        );
        let [(reg, reg_doublings), (filter, filter_doublings)] = self.riccati;
        report += &format!(
            "Riccati equations: regulator residual {reg:.1e} ({reg_doublings} doublings), filter {filter:.1e} \
             ({filter_doublings} doublings), the filter's period closes to {:.1e}.\n\n",
            self.periodicity_gap
        );
        report += &self.figures_table();
        report += "\n| instrument made better | bound, feed RMS (mm) |\n|---|---|\n";
        for (what, feed) in &self.improved {
            report +=
                &format!("| {what} | {} |\n", feed.as_ref().map_or_else(|e| e.clone(), |f| format!("{:.4}", mm(*f))));
        }
        if !self.cells.is_empty() {
            report += &self.sweep_table();
        }
        if !self.evaluation.is_empty() {
            report += &self.evaluation_table();
        }
        report
    }

    /// The predicted figures against the uncompensated model's.
    fn figures_table(&self) -> String {
        let (bound, open) = (&self.bound, &self.open);
        let worst = |v: &[f64; 6]| v.iter().fold(0.0f64, |a, b| a.max(*b));
        let mut s = String::from("| predicted RMS | LQG (the bound) | uncompensated (fluctuation) |\n|---|---|---|\n");
        s += &format!("| feed position | {:.4} mm | {:.3} mm |\n", mm(bound.feed_m), mm(open.feed_m));
        let [b, o] = [bound.feed_components_m.map(mm), open.feed_components_m.map(mm)];
        s += &format!(
            "| feed x, y, z | {:.4}, {:.4}, {:.4} mm | {:.3}, {:.3}, {:.3} mm |\n",
            b[0], b[1], b[2], o[0], o[1], o[2]
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
            100.0 * self.limits.usage(bound)
        );
        s
    }

    fn cell(&self, rate_hz: f64, delay_s: f64) -> Option<&Cell> {
        self.cells.iter().find(|c| c.rate_hz == rate_hz && c.delay_s == delay_s)
    }

    fn sweep_table(&self) -> String {
        let (rates, delays) = (&self.settings.rates, &self.settings.delays);
        let mut s = String::from("\nThe bound (feed RMS, mm) against the fixes' rate and delay:\n\n| rate \\ delay |");
        for d in delays {
            s += &format!(" {} ms |", d * 1e3);
        }
        s += "\n|---|";
        s += &"---|".repeat(delays.len());
        for r in rates {
            s += &format!("\n| {r} Hz |");
            for d in delays {
                match self.cell(*r, *d).map(|c| &c.feed_m) {
                    Some(Ok(f)) => s += &format!(" {:.4} |", mm(*f)),
                    _ => s += " – |",
                }
            }
        }
        s + "\n"
    }

    fn evaluation_table(&self) -> String {
        let seeds: Vec<String> = self.settings.evaluate.iter().map(u64::to_string).collect();
        let mut s = format!(
            "\nThe monolithic model, {} s, wind seeds {} of {} (mean ± standard deviation over the seeds; feed RMS \
             per seed in brackets; the robustness runs on the first seed):\n\n| run | feed RMS (mm) | feed peak (mm) | \
             tilt RMS (mrad) | steps beyond a limit |\n|---|---|---|---|---|\n",
            self.settings.t_end,
            seeds.join(", "),
            self.scene
        );
        for (label, runs) in &self.evaluation {
            let ok: Vec<&FeedRun> = runs.iter().filter_map(|r| r.as_ref().ok()).collect();
            if let Some(why) = runs.iter().find_map(|r| r.as_ref().err()) {
                s += &format!("| {label} | stopped: {why} | | | |\n");
                continue;
            }
            let col = |f: &dyn Fn(&FeedRun) -> f64| mean_sd(&ok.iter().map(|r| f(r)).collect::<Vec<_>>());
            let (rms, peak, tilt) = (col(&|r| mm(r.rms_m)), col(&|r| mm(r.peak_m)), col(&|r| mm(r.tilt_rms_rad)));
            let each: Vec<String> = ok.iter().map(|r| format!("{:.4}", mm(r.rms_m))).collect();
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

    /// The bound against the fixes' rate and delay (bound.csv).
    pub fn bound_csv(&self) -> String {
        let mut csv = String::from("rate_hz,delay_s,bound_feed_rms_mm,note\n");
        for c in &self.cells {
            match &c.feed_m {
                Ok(f) => csv += &format!("{},{},{:.6},\n", c.rate_hz, c.delay_s, mm(*f)),
                Err(e) => csv += &format!("{},{},,{}\n", c.rate_hz, c.delay_s, e.replace(',', ";")),
            }
        }
        csv
    }

    /// The bound against the fixes' delay, a line per rate (bound.svg).
    pub fn bound_svg(&self) -> anyhow::Result<String> {
        use plotters::prelude::*;
        let points = |r: f64| -> Vec<(f64, f64)> {
            self.cells
                .iter()
                .filter(|c| c.rate_hz == r)
                .filter_map(|c| c.feed_m.as_ref().ok().map(|f| (c.delay_s * 1e3, mm(*f))))
                .collect()
        };
        let rates = &self.settings.rates;
        let all: Vec<(f64, f64)> = rates.iter().flat_map(|&r| points(r)).collect();
        let x1 = all.iter().map(|p| p.0).fold(1.0f64, f64::max);
        let y1 = all.iter().map(|p| p.1).fold(0.0f64, f64::max) * 1.1;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (800, 500)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(format!("{}: the LQG bound against the fixes' rate and delay", self.scene), ("sans-serif", 18))
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
                crate::plot::palette_line(&mut chart, i, points(r), &format!("fixes at {r} Hz"))?;
            }
            crate::plot::legend(&mut chart, 13)?;
            root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        Ok(svg)
    }

    /// The results as JSON (`master design --json`), `written` the files written.
    pub fn json(&self, written: &[String]) -> serde_json::Value {
        let f = |x: &Figures| {
            json!({"feed_rms_mm": mm(x.feed_m), "feed_components_rms_mm": x.feed_components_m.map(mm),
                   "tilt_rms_mrad": mm(x.tilt_rad), "strokes_rms_mm": x.strokes_m.map(mm), "forces_rms_n": x.forces_n})
        };
        let per_run = |runs: &[Result<FeedRun, String>], g: &dyn Fn(&FeedRun) -> serde_json::Value| {
            runs.iter().map(|r| r.as_ref().ok().map(g)).collect::<Vec<_>>()
        };
        let error = &self.error;
        json!({
            "scene": self.scene,
            "modes_kept_hz": self.design.modes_hz,
            "model_error": {"residual_mm": mm(error.residual.0), "residual_mrad": mm(error.residual.1),
                            "force_density_n": error.force_density, "moment_density_nm": error.moment_density},
            "bound": f(&self.bound),
            "uncompensated": f(&self.open),
            "riccati_residuals": self.riccati.map(|r| r.0),
            "improvements": self.improved.iter()
                .map(|(w, r)| json!({"what": w, "bound_feed_rms_mm": r.as_ref().ok().map(|f| mm(*f))}))
                .collect::<Vec<_>>(),
            "evaluation": self.evaluation.iter().map(|(label, runs)| json!({"run": label,
                "feed_rms_mm": per_run(runs, &|r| json!(mm(r.rms_m))),
                "feed_peak_mm": per_run(runs, &|r| json!(mm(r.peak_m))),
                "tilt_rms_mrad": per_run(runs, &|r| json!(mm(r.tilt_rms_rad))),
                "steps_beyond_limits": per_run(runs, &|r| json!(r.steps_beyond_limits))})).collect::<Vec<_>>(),
            "sweep": self.cells.iter()
                .map(|c| json!({"rate_hz": c.rate_hz, "delay_s": c.delay_s,
                                "bound_feed_rms_mm": c.feed_m.as_ref().ok().map(|f| mm(*f))}))
                .collect::<Vec<_>>(),
            "written": written,
        })
    }
}
