//! `master run --system FILE` as a library call: an SSP system file (an `.ssp` archive, or an
//! `.ssd` with its FMUs beside it) checked whole, then run, then summarized — for the command
//! line and the Python package alike.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use cosim::Options;
use cosim::ssp::read::{LoadedSsp, ReadLimits, load_within};
use serde_json::{Value, json};

use super::{Adaptive, Sinks, SystemOutcome, SystemRun};
use crate::limits::{Limits, num};
use crate::simulate::{Method, RunError};
use crate::stepping::Watch;

/// A system file, loaded and checked: its steps, its end time, what its scheme needs.
pub struct SystemFile {
    file: PathBuf,
    loaded: LoadedSsp,
    options: Options,
    adaptive: Option<Adaptive>,
    pub dt: f64,
    pub t_end: f64,
    limits: Limits,
    model_exchange: cosim::me::MeOptions,
}

impl SystemFile {
    /// Loads `file` within `read` and checks a run of `method` at `dt` (or the adaptive step) to
    /// `t_end` (default: the system's DefaultExperiment stopTime) within `limits`.
    pub fn prepare(
        file: &Path,
        method: Method,
        dt: Option<f64>,
        t_end: Option<f64>,
        read: &ReadLimits,
        limits: &Limits,
    ) -> anyhow::Result<SystemFile> {
        let (options, adaptive) = match method {
            Method::Cosim(o) => (o, None),
            Method::CosimAdaptive(o, a) => (o, Some(a)),
            other => bail!(
                "--scheme {}: runs only the LT50m scene (--scene); a --system runs with a coupling scheme \
                 (jacobi, gauss-seidel, iterative, ijcsa, iqn-ils)",
                other.name()
            ),
        };
        let loaded = load_within(file, read)?;
        crate::options::check_dt(adaptive.is_some(), dt)?;
        let dt = match (&adaptive, dt) {
            (None, Some(dt)) => dt,
            (None, None) => bail!("--dt: give the macro step of the system (s)"),
            // not used: the adaptive step chooses
            (Some(_), _) => f64::NAN,
        };
        let start = loaded.start_time.unwrap_or(0.0);
        if start != 0.0 {
            bail!("{}: DefaultExperiment startTime = {start}; the master starts at 0", file.display());
        }
        let given_end = t_end.is_some();
        let Some(t_end) = t_end.or(loaded.stop_time) else {
            bail!("--t-end: give the end time (the system description has no DefaultExperiment stopTime)");
        };
        SystemRun::prepare(&loaded.spec, options, adaptive.clone(), dt, t_end, limits).with_context(|| {
            let from = if given_end { "--t-end" } else { "the DefaultExperiment" };
            match &adaptive {
                Some(a) => format!(
                    "{}: adaptive steps within [{}, {}] s, end time {} s from {from}",
                    file.display(),
                    num(a.h_min),
                    num(a.h_max),
                    num(t_end)
                ),
                None => format!("{}: h = {} s, end time {} s from {from}", file.display(), num(dt), num(t_end)),
            }
        })?;
        Ok(SystemFile {
            file: file.to_owned(),
            loaded,
            options,
            adaptive,
            dt,
            t_end,
            limits: *limits,
            model_exchange: Default::default(),
        })
    }

    /// Runs the components `choice` names as the interface it names, Model Exchange ones with
    /// its integrator.
    pub fn with_model_exchange(mut self, choice: &super::ModelExchangeChoice) -> anyhow::Result<SystemFile> {
        choice.apply(&mut self.loaded.spec).map_err(|e| anyhow::anyhow!("{}: {e}", self.file.display()))?;
        self.model_exchange = choice.options;
        Ok(self)
    }

    /// The files the run reads: the system file and its FMUs.
    pub fn inputs(&self) -> impl Iterator<Item = PathBuf> + '_ {
        std::iter::once(self.file.clone()).chain(self.loaded.spec.components.iter().map(|c| c.source.clone()))
    }

    pub fn scheme(&self) -> &'static str {
        self.options.scheme.name()
    }

    pub fn adaptive(&self) -> Option<&Adaptive> {
        self.adaptive.as_ref()
    }

    /// Runs it, writing every step's outputs to `sinks`.
    pub fn execute(&self, watch: &mut dyn Watch, sinks: Sinks<'_>) -> Result<SystemOutcome, RunError> {
        let run = SystemRun::prepare(
            &self.loaded.spec,
            self.options,
            self.adaptive.clone(),
            self.dt,
            self.t_end,
            &self.limits,
        )?;
        let run = SystemRun { model_exchange: self.model_exchange, ..run };
        run.execute(watch, sinks)
    }

    /// `master run --system --json`.
    pub fn summary(&self, outcome: &SystemOutcome) -> Value {
        json!({
            "system": self.file.display().to_string(),
            "scheme": self.scheme(),
            "adaptive": self.adaptive.is_some(),
            "dt": self.adaptive.is_none().then_some(self.dt),
            "t_end": self.t_end,
            "steps": outcome.steps,
            "rejected_steps": outcome.rejected_steps,
            "h_min_used": outcome.h_min_used,
            "h_max_used": outcome.h_max_used,
            "wall_time_s": outcome.wall_time_s,
            "mean_iterations": outcome.mean_iterations,
            "max_interface_residual": outcome.max_residual,
            "outputs": outcome.columns.len() - 1,
            "stopped_early": outcome.stopped_early.is_some(),
            "stopped_at": outcome.stopped_early.as_ref().map(|s| s.0),
            "note": outcome.stopped_early.as_ref().map(|s| s.1.clone()),
            "model_exchange": outcome.model_exchange.iter().map(|(c, solver, s)| json!({
                "component": c,
                "solver": solver,
                "steps": s.steps,
                "rejected_steps": s.rejected,
                "state_events": s.state_events,
                "time_events": s.time_events,
                "step_events": s.step_events,
                "evaluations": s.evaluations,
            })).collect::<Vec<_>>(),
        })
    }
}
