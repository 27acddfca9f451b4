//! The adaptive macro step of the implicit schemes ([`crate::adaptive`]): the estimate watches
//! the coupled inputs `U` (the interface's values at the communication points), and a rejected
//! step is rolled back bit for bit — FMU states, coupled values, extrapolation and quasi-Newton
//! history.

use super::{Coupled, StepReport};
use crate::adaptive::{self, Accepted, Retake};
use crate::error::StepError;
use crate::error_estimate::ErrorEstimate;
use crate::step_control::{Controller, Tolerances};
use crate::system::Units;

/// One accepted adaptive step.
pub type AdaptiveStep = Accepted<StepReport>;

/// What undoing a step restores besides the units' states, and the estimate of the adaptive step.
pub(super) struct History {
    pub(super) estimate: ErrorEstimate,
    /// The coupled values and time before the last step (for rollback).
    pub(super) y: Vec<f64>,
    pub(super) y_prev: Vec<f64>,
    pub(super) has_prev: bool,
    pub(super) t_before: f64,
    /// IJCSA's reused interface Jacobian before the last step (its blocks, whether there is one,
    /// which units are recomputed), kept only with `--jacobian reuse`.
    pub(super) dydu: Vec<f64>,
    pub(super) has_jacobian: bool,
    pub(super) volatile: Vec<u32>,
}

impl History {
    pub(super) fn new(n: usize, ny: usize) -> History {
        History {
            estimate: ErrorEstimate::new(n),
            y: vec![0.0; ny],
            y_prev: vec![0.0; ny],
            has_prev: false,
            t_before: 0.0,
            dydu: Vec::new(),
            has_jacobian: false,
            volatile: Vec::new(),
        }
    }
}

impl<S: Units> Coupled<S> {
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
        self.has_prev = self.adaptive.has_prev;
        self.time = t;
        if self.options.scheme == super::Scheme::IqnIls {
            self.iqn_before.copy_into(&mut self.iqn);
        }
        if self.reuses_jacobian() {
            self.dydu.copy_from_slice(&self.adaptive.dydu);
            self.has_jacobian = self.adaptive.has_jacobian;
            self.volatile.copy_from_slice(&self.adaptive.volatile);
        }
        Ok(())
    }
}

/// The coupled inputs `U` are what the adaptive step watches, grouped and scaled as the
/// convergence test groups and scales them; they are converged to the interface tolerance.
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
        for (i, u) in out.iter_mut().enumerate() {
            *u = l.coupled(i, &self.y);
        }
        Ok(())
    }

    fn groups(&self) -> (&[usize], &[f64]) {
        let l = self.units.layout();
        (&l.group, &l.scale)
    }

    fn noise(&self) -> f64 {
        self.options.tol
    }

    fn too_small(&self, t: f64, error: f64, h_min: f64) -> StepError {
        StepError::StepTooSmall { time: t, error, h_min }
    }
}
