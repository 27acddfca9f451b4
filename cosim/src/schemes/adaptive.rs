//! The adaptive macro step of the implicit schemes ([`crate::adaptive`]): the estimate watches
//! the coupled inputs `U` (the interface's values at the communication points), and a rejected
//! step is rolled back bit for bit — FMU states, coupled values, extrapolation and quasi-Newton
//! history.

use super::{Coupled, StepReport};
use crate::adaptive::{self, Accepted, Retake};
use crate::error::SetupError;
use crate::error::StepError;
use crate::error_estimate::ErrorEstimate;
use crate::step_control::{Controller, Tolerances};
use crate::system::{Layout, Units};

/// One accepted adaptive step.
pub type AdaptiveStep = Accepted<StepReport>;

/// What undoing a step restores besides the units' states, and the estimate of the adaptive step.
pub(super) struct History {
    pub(super) estimate: ErrorEstimate,
    /// The coupled inputs the estimate watches (indices into `U`), and their groups
    /// (renumbered from 0) and scales.
    pub(super) watched: Vec<usize>,
    pub(super) group: Vec<usize>,
    pub(super) scale: Vec<f64>,
    /// The coupled values and time before the last step (for rollback).
    pub(super) y: Vec<f64>,
    pub(super) y_prev: Vec<f64>,
    pub(super) prev_step: Option<f64>,
    pub(super) t_before: f64,
    /// IJCSA's reused interface Jacobian before the last step (its blocks, the step it belongs
    /// to, which units are recomputed), kept only with `--jacobian reuse`.
    pub(super) dydu: Vec<f64>,
    pub(super) jacobian_step: Option<f64>,
    pub(super) volatile: Vec<u32>,
}

impl History {
    /// Watching every coupled input of `layout`.
    pub(super) fn new(layout: &Layout) -> History {
        let (n, ny) = (layout.inputs(), layout.outputs());
        History {
            estimate: ErrorEstimate::new(n),
            watched: (0..n).collect(),
            group: layout.group.clone(),
            scale: layout.scale.clone(),
            y: vec![0.0; ny],
            y_prev: vec![0.0; ny],
            prev_step: None,
            t_before: 0.0,
            dydu: Vec::new(),
            jacobian_step: None,
            volatile: Vec::new(),
        }
    }
}

impl<S: Units> Coupled<S> {
    /// The adaptive step judges its error by the coupled inputs named in `names` only (each an
    /// input's `unit.variable`, or a prefix of such names ending before a `.` or `[`, as
    /// `stewart.cabin.v` for `stewart.cabin.v[1]` … `[3]`); every coupled input if empty. Call
    /// before the first step.
    pub fn watch(&mut self, names: &[String]) -> Result<(), SetupError> {
        let l = self.units.layout();
        let mut watched = Vec::new();
        for name in names {
            let mut found = false;
            for (i, input) in l.input_names.iter().enumerate() {
                let matches = input
                    .strip_prefix(name.as_str())
                    .is_some_and(|rest| rest.is_empty() || rest.starts_with('.') || rest.starts_with('['));
                found |= matches;
                if matches && !watched.contains(&i) {
                    watched.push(i);
                }
            }
            if !found {
                return Err(SetupError::Invalid(format!(
                    "watched quantity `{name}` is neither a coupled input nor a prefix of one ending \
                     before a `.` or `[`; the coupled inputs are {}",
                    l.input_names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
                )));
            }
        }
        if names.is_empty() {
            watched = (0..l.inputs()).collect();
        }
        watched.sort_unstable();
        let keys: Vec<usize> = watched.iter().map(|&i| l.group[i]).collect();
        let a = &mut self.adaptive;
        a.group = Layout::groups(&keys);
        a.scale = watched.iter().map(|&i| l.scale[i]).collect();
        a.estimate = ErrorEstimate::new(watched.len());
        a.watched = watched;
        Ok(())
    }

    /// One accepted step of the adaptive macro step, ending at most at `t_stop`: tries the
    /// controller's step, estimates its error, and rolls every unit back bit for bit to retry a
    /// smaller step until one is accepted.
    pub fn step_adaptive(
        &mut self,
        ctl: &mut Controller,
        tol: Tolerances,
        t_stop: f64,
    ) -> Result<AdaptiveStep, StepError> {
        if !self.options.scheme.is_implicit() {
            return Err(self.failed(
                self.time,
                format!(
                    "the adaptive step needs an implicit scheme (iterative, ijcsa, iqn-ils), not {}",
                    self.options.scheme.name()
                ),
            ));
        }
        // the estimate lives beside the units it judges; lent to the step for its duration
        let mut estimate = std::mem::replace(&mut self.adaptive.estimate, ErrorEstimate::new(0));
        let t = self.time;
        let result = adaptive::step(self, &mut estimate, ctl, tol, t, t_stop);
        self.adaptive.estimate = estimate;
        result
    }

    /// Undoes a step: every unit to its saved state, the coupled values and time as before.
    pub(super) fn roll_back(&mut self, t: f64) -> Result<(), StepError> {
        self.restore_states(t)?;
        self.y.copy_from_slice(&self.adaptive.y);
        self.y_prev.copy_from_slice(&self.adaptive.y_prev);
        self.prev_step = self.adaptive.prev_step;
        self.time = t;
        if self.options.scheme == super::Scheme::IqnIls {
            self.iqn_before.copy_into(&mut self.iqn);
        }
        if self.reuses_jacobian() {
            self.dydu.copy_from_slice(&self.adaptive.dydu);
            self.jacobian_step = self.adaptive.jacobian_step;
            self.volatile.copy_from_slice(&self.adaptive.volatile);
        }
        Ok(())
    }
}

/// The coupled inputs `U` (all, or those named to [`Coupled::watch`]) are what the adaptive step
/// watches, grouped and scaled as the convergence test groups and scales them; they are converged
/// to the interface tolerance.
impl<S: Units> Retake for Coupled<S> {
    type Report = StepReport;
    type Error = StepError;

    fn try_step(&mut self, h: f64) -> Result<Option<StepReport>, StepError> {
        match self.step(h) {
            Ok(r) => Ok(Some(r)),
            Err(StepError::NotConverged { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn undo(&mut self, t: f64) -> Result<(), StepError> {
        self.roll_back(t)
    }

    fn watched(&mut self, out: &mut [f64]) -> Result<(), StepError> {
        let l = self.units.layout();
        for (u, &i) in out.iter_mut().zip(&self.adaptive.watched) {
            *u = l.coupled(i, &self.y);
        }
        Ok(())
    }

    fn groups(&self) -> (&[usize], &[f64]) {
        (&self.adaptive.group, &self.adaptive.scale)
    }

    /// Each watched value's own interface residual `|C·Y_i − U_i|` at the end of the step: how
    /// much the last iteration still moved it (mostly far below the tolerance: IJCSA's Newton
    /// ends at 1e-12 … 1e-9 of the scales on LT50m, with a tolerance of 1e-8).
    fn noise(&self, out: &mut [f64]) {
        let l = self.units.layout();
        for (n, &i) in out.iter_mut().zip(&self.adaptive.watched) {
            *n = (l.coupled(i, &self.y) - self.work.guess[i]).abs();
        }
    }

    fn too_small(&self, t: f64, error: f64, h_min: f64) -> StepError {
        StepError::StepTooSmall { time: t, error, h_min }
    }
}
