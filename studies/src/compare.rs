//! Each method's error against the monolithic model at the same step: the cabin-centre
//! displacement's largest and RMS difference, iterations per step and run time.

use std::path::Path;

use anyhow::Context;
use feedcore::scene::ValidScene;
use serde_json::{Value, json};

use crate::limits::Limits;
use crate::observe::Observer;
use crate::options::{SchemeName, SchemeOptions};
use crate::simulate::{Run, RunError, Trace};
use crate::table::Table;

/// What is compared.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub schemes: Vec<SchemeName>,
    /// Macro step of every run, s (`None`: the scene's `solver.dt_s`).
    pub dt: Option<f64>,
    /// End time, s (`None`: the scene's `solver.t_end_s`).
    pub t_end: Option<f64>,
    pub options: SchemeOptions,
    pub limits: Limits,
}

impl Default for Settings {
    fn default() -> Self {
        use SchemeName::*;
        Settings {
            schemes: vec![Ijcsa, IqnIls, Iterative, GaussSeidel, Jacobi, Decoupled],
            dt: None,
            t_end: None,
            options: SchemeOptions::default(),
            limits: Limits::default(),
        }
    }
}

/// A comparison ready to run: the scene sampled at every step, every run checked.
pub struct Comparison<'a> {
    file: &'a Path,
    sampled: ValidScene,
    settings: Settings,
    pub dt: f64,
    pub t_end: f64,
}

/// The comparison's results.
#[derive(Clone, Debug)]
pub struct Compared {
    pub scene: String,
    pub dt: f64,
    pub t_end: f64,
    pub reference: Trace,
    /// Each method's run, or why it broke down (a result, not a reason to stop).
    pub runs: Vec<(SchemeName, Result<Trace, String>)>,
}

impl<'a> Comparison<'a> {
    /// The comparison on `scene` (read from `file`), every run checked before any starts.
    pub fn new(scene: &ValidScene, file: &'a Path, settings: Settings) -> anyhow::Result<Comparison<'a>> {
        let dt = settings.dt.unwrap_or(scene.solver.dt_s);
        let t_end = settings.t_end.unwrap_or(scene.solver.t_end_s);
        // errors at every step: every run samples every step
        let sampled = scene.edited(|s| s.outputs.sample_interval_s = dt).context("the step")?;
        let c = Comparison { file, sampled, settings, dt, t_end };
        c.reference()?;
        c.runs()?;
        Ok(c)
    }

    fn prepare(&self, options: &SchemeOptions, name: SchemeName) -> anyhow::Result<Run<'_>> {
        let method = options.method(name)?;
        Ok(Run::prepare(&self.sampled, self.file, method, self.dt, self.t_end, &self.settings.limits)?)
    }

    /// The monolithic reference, at the fixed step even when the schemes take the adaptive one.
    fn reference(&self) -> anyhow::Result<Run<'_>> {
        self.prepare(&self.settings.options.fixed_step(), SchemeName::Monolithic)
    }

    fn runs(&self) -> anyhow::Result<Vec<(SchemeName, Run<'_>)>> {
        self.settings.schemes.iter().map(|&name| Ok((name, self.prepare(&self.settings.options, name)?))).collect()
    }

    /// Runs the reference, then every method.
    pub fn run(&self, observer: &dyn Observer) -> anyhow::Result<Compared> {
        let reference = self.reference()?.execute_watched(&mut *observer.watch())?;
        let mut runs = Vec::new();
        for (name, run) in self.runs()? {
            match run.execute_watched(&mut *observer.watch()) {
                Ok(t) => runs.push((name, Ok(t))),
                Err(e @ RunError::Stopped { .. }) => runs.push((name, Err(e.to_string()))),
                Err(e) => return Err(e.into()),
            }
        }
        Ok(Compared { scene: self.sampled.name.clone(), dt: self.dt, t_end: self.t_end, reference, runs })
    }
}

impl Compared {
    /// Each method's figures (`master compare --json`'s `schemes`).
    fn rows(&self) -> Vec<Value> {
        let peak = self.reference.peak_mm();
        self.runs
            .iter()
            .map(|(name, run)| match run {
                Ok(t) => {
                    let (max, rms) = t.error_against(&self.reference);
                    json!({"scheme": name.as_str(), "max_error_mm": max, "rms_error_mm": rms,
                        "max_error_percent_of_peak": 100.0 * max / peak, "mean_iterations": t.mean_iterations(),
                        "wall_time_s": t.wall_time_s, "peak_disp_mm": t.peak_mm()})
                }
                Err(e) => json!({"scheme": name.as_str(), "failed": e}),
            })
            .collect()
    }

    /// Everything, as `master compare --json` prints it.
    pub fn json(&self) -> Value {
        let r = &self.reference;
        json!({"scene": self.scene, "dt": self.dt, "t_end": self.t_end, "monolithic": {"peak_disp_mm": r.peak_mm(),
            "wall_time_s": r.wall_time_s, "mean_iterations": r.mean_iterations()}, "schemes": self.rows()})
    }

    /// The report as text: the reference, then a row per method.
    pub fn text(&self) -> String {
        let r = &self.reference;
        let mut text = format!(
            "{}: errors of the cabin-centre displacement against monolithic, h = {} s, {} s\n",
            self.scene, self.dt, self.t_end
        );
        text.push_str(&format!(
            "monolithic: peak {:.4} mm, {:.2} Newton iterations per step, {:.2} s\n\n",
            r.peak_mm(),
            r.mean_iterations(),
            r.wall_time_s
        ));
        let mut t =
            Table::new(["scheme", "max error mm", "RMS error mm", "max error % of peak", "iterations/step", "wall s"]);
        for row in self.rows() {
            let name = row["scheme"].as_str().unwrap_or("?").to_string();
            if let Some(f) = row.get("failed") {
                let reason: String = f.as_str().unwrap_or("").chars().take(60).collect();
                t.row([name, "failed".into(), "".into(), "".into(), "".into(), reason]);
                continue;
            }
            let g = |k: &str| row[k].as_f64().unwrap_or(f64::NAN);
            t.row([
                name,
                format!("{:.3e}", g("max_error_mm")),
                format!("{:.3e}", g("rms_error_mm")),
                format!("{:.3}", g("max_error_percent_of_peak")),
                format!("{:.2}", g("mean_iterations")),
                format!("{:.2}", g("wall_time_s")),
            ]);
        }
        text.push_str(&t.render());
        text
    }

    /// The reference's and every finished run's trace, reference first.
    pub fn traces(&self) -> Vec<&Trace> {
        std::iter::once(&self.reference).chain(self.runs.iter().filter_map(|(_, r)| r.as_ref().ok())).collect()
    }
}
