//! The adaptive macro step of the implicit schemes: a local error estimate of the coupled
//! quantities, step-size control, rejection with bit-exact rollback.
//!
//! Estimate (predictor against corrector): the coupled inputs `U` of the last (up to) three
//! accepted communication points, extrapolated by their polynomial to the end of the step,
//! against the converged `U` of the step. For a smooth solution and a second-order integrator
//! in the units both differ from the exact values by O(h³), so the difference estimates the
//! local error at no extra cost (no step is taken twice). It is weighed per quantity by
//! `atol · scale_i + rtol · range_i`: `scale_i` the unit-group scale of the convergence test,
//! `range_i` the largest departure of the quantity from its initial value so far — relative
//! to how far each quantity moves, so that positions metres from the origin are not judged by
//! their distance to it.

use super::{Coupled, StepReport};
use crate::error::StepError;
use crate::step_control::{Controller, Decision, Tolerances};
use crate::system::Units;

/// One accepted adaptive step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveStep {
    /// The step size taken.
    pub h: f64,
    pub report: StepReport,
    /// Tries rejected before this step was accepted.
    pub rejected: usize,
    /// Its error norm (≤ 1).
    pub error: f64,
}

/// Accepted coupled values, newest first.
pub(super) struct History {
    t: [f64; 3],
    u: [Vec<f64>; 3],
    count: usize,
    u0: Vec<f64>,
    range: Vec<f64>,
    candidate: Vec<f64>,
    y: Vec<f64>,
    y_prev: Vec<f64>,
}

impl History {
    pub(super) fn new(n: usize) -> History {
        History {
            t: [0.0; 3],
            u: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            count: 0,
            u0: vec![0.0; n],
            range: vec![0.0; n],
            candidate: vec![0.0; n],
            y: Vec::new(),
            y_prev: Vec::new(),
        }
    }

    fn push(&mut self, t: f64, u: &[f64]) {
        self.t.rotate_right(1);
        self.u.rotate_right(1);
        self.t[0] = t;
        self.u[0].copy_from_slice(u);
        if self.count == 0 {
            self.u0.copy_from_slice(u);
        }
        self.count = (self.count + 1).min(3);
        for i in 0..u.len() {
            self.range[i] = self.range[i].max((u[i] - self.u0[i]).abs());
        }
    }

    /// Extrapolation of entry i to time `t` by the polynomial through the kept points.
    fn predict(&self, i: usize, t: f64) -> f64 {
        let m = self.count;
        let mut p = 0.0;
        for a in 0..m {
            let mut l = 1.0;
            for b in 0..m {
                if a != b {
                    l *= (t - self.t[b]) / (self.t[a] - self.t[b]);
                }
            }
            p += l * self.u[a][i];
        }
        p
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
                    "the adaptive step needs an implicit scheme (iterative, ijcsa, iqn-ils, iqn-imvj), not {}",
                    self.options.scheme.name()
                ),
            ));
        }
        let t = self.time;
        let n = self.work.guess.len();
        if self.adaptive.count == 0 {
            let Coupled { adaptive, units, y, .. } = self;
            let l = units.layout();
            for i in 0..n {
                adaptive.candidate[i] = l.coupled(i, y);
            }
            let c = std::mem::take(&mut adaptive.candidate);
            adaptive.push(t, &c);
            adaptive.candidate = c;
            adaptive.y = vec![0.0; y.len()];
            adaptive.y_prev = vec![0.0; y.len()];
        }
        let mut rejected = 0;
        let mut h = ctl.next_step();
        loop {
            // land on t_stop without leaving a sliver
            if t + 1.5 * h >= t_stop {
                h = if t + h >= t_stop { t_stop - t } else { 0.5 * (t_stop - t) };
            }
            self.adaptive.y.copy_from_slice(&self.y);
            self.adaptive.y_prev.copy_from_slice(&self.y_prev);
            let has_prev = self.has_prev;
            let report = match self.step(h) {
                Ok(r) => Some(r),
                Err(StepError::NotConverged { .. }) => None,
                Err(e) => return Err(e),
            };
            let (error, order) = match report {
                Some(_) => self.estimate(t + h, tol),
                None => (f64::INFINITY, 1),
            };
            let decision = match report {
                Some(_) => ctl.decide(error, h, order),
                None => ctl.shrink(h).map_or(Decision::Fail, |h_retry| Decision::Reject { h_retry }),
            };
            match decision {
                Decision::Accept { .. } => {
                    let Coupled { adaptive, .. } = self;
                    let c = std::mem::take(&mut adaptive.candidate);
                    adaptive.push(t + h, &c);
                    adaptive.candidate = c;
                    let report = report.expect("accepted steps have a report");
                    return Ok(AdaptiveStep { h, report, rejected, error });
                }
                Decision::Reject { h_retry } => {
                    self.roll_back(t, has_prev)?;
                    rejected += 1;
                    h = h_retry;
                }
                Decision::Fail => {
                    self.roll_back(t, has_prev)?;
                    return Err(StepError::StepTooSmall { time: t, error, h_min: ctl.limits().h_min });
                }
            }
        }
    }

    /// Undoes a step: every unit to its saved state, the coupled values and time as before.
    pub(super) fn roll_back(&mut self, t: f64, has_prev: bool) -> Result<(), StepError> {
        self.restore_states(t)?;
        self.y.copy_from_slice(&self.adaptive.y);
        self.y_prev.copy_from_slice(&self.adaptive.y_prev);
        self.has_prev = has_prev;
        self.time = t;
        self.iqn.discard_window();
        Ok(())
    }

    /// The error norm of the step that ended at `t1` and the order of the estimate in h;
    /// leaves the step's coupled values in `adaptive.candidate`.
    fn estimate(&mut self, t1: f64, tol: Tolerances) -> (f64, u32) {
        let Coupled { adaptive, units, y, .. } = self;
        let l = units.layout();
        let mut worst: f64 = 0.0;
        for i in 0..l.inputs() {
            let u = l.coupled(i, y);
            adaptive.candidate[i] = u;
            let e = (u - adaptive.predict(i, t1)).abs() / (tol.atol * l.scale[i] + tol.rtol * adaptive.range[i]);
            worst = worst.max(e);
        }
        (worst, adaptive.count as u32)
    }
}
