//! The adaptive macro step of the implicit schemes: a local error estimate of the coupled
//! quantities, step-size control, rejection with bit-exact rollback.
//!
//! Estimate (predictor against corrector): the coupled inputs `U` of the last three accepted
//! communication points, extrapolated by their parabola to the end of the step, against the
//! converged `U` of the step. Their difference is the third divided difference of `U` over the
//! four points times `(t − t₀)(t − t₁)(t − t₂)`, so it gives `U'''` at no extra cost (no step
//! is taken twice), and with it the local error of a second-order integrator, about
//! `h³ |U'''| / 12` (the trapezoidal rule's constant; see [`ERROR_CONSTANT`]).
//!
//! Tolerance: local errors of an oscillating system add up (a phase error grows with every
//! step), so the estimate is held per unit of time — error per unit step over the run's
//! horizon T: `|est_i| · T / h ≤ atol · scale_i + rtol · range_i`, whose sum over the run stays
//! within the tolerance; the norm is the root mean square over the quantities. `scale_i` is the
//! unit-group scale of the convergence test and `range_i` the largest departure of the
//! quantities of its unit group from their initial values so far — relative to
//! how far each quantity moves, so that positions metres from the origin are not judged by
//! their distance to it. The history starts after the first step (the start may be abrupt, a
//! kink no extrapolation may span), so the first three steps have nothing to be judged by: they
//! are taken at the controller's first step size (keep it small), and the controller grows the
//! step from there.

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

/// The local error is taken as `h³ |U'''| / ERROR_CONSTANT`: 12 is the trapezoidal rule's
/// constant; 6 leaves room for the dips of `|U'''|` that the memory below does not fill and for
/// integrators with a larger constant (generalized-α with numerical damping). Measured on an
/// undamped two-mass oscillator with the trapezoidal rule (tests/linear_system.rs, 32 steps of
/// memory): with 12 the error exceeds the tolerance by 1.1× at rtol 1e-3, with 8 by 1.01× at
/// 1e-4; with 6 it stays at 0.45–0.8 of it from rtol 1e-2 to 1e-4.
const ERROR_CONSTANT: f64 = 6.0;

/// Accepted steps over which the largest `|U'''|` is kept.
const MEMORY: usize = 32;

/// Accepted coupled values, newest first.
pub(super) struct History {
    t: [f64; 3],
    u: [Vec<f64>; 3],
    count: usize,
    u0: Vec<f64>,
    started: bool,
    /// Per unit group: the largest departure of its quantities from their initial values.
    range: Vec<f64>,
    group: Vec<usize>,
    candidate: Vec<f64>,
    /// |U'''| of the step being judged, and of the last MEMORY accepted steps (ring, per input).
    third: Vec<f64>,
    recent: Vec<f64>,
    slot: usize,
    /// The coupled values and time before the last step (for rollback).
    pub(super) y: Vec<f64>,
    pub(super) y_prev: Vec<f64>,
    pub(super) has_prev: bool,
    pub(super) t_before: f64,
}

impl History {
    pub(super) fn new(n: usize, ny: usize) -> History {
        History {
            t: [0.0; 3],
            u: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            count: 0,
            u0: vec![0.0; n],
            started: false,
            range: vec![0.0; n],
            group: Vec::new(),
            candidate: vec![0.0; n],
            third: vec![0.0; n],
            recent: vec![0.0; n * MEMORY],
            slot: 0,
            y: vec![0.0; ny],
            y_prev: vec![0.0; ny],
            has_prev: false,
            t_before: 0.0,
        }
    }

    fn push(&mut self, t: f64, u: &[f64]) {
        self.t.rotate_right(1);
        self.u.rotate_right(1);
        self.t[0] = t;
        self.u[0].copy_from_slice(u);
        self.count = (self.count + 1).min(3);
        for i in 0..u.len() {
            let moved = (u[i] - self.u0[i]).abs();
            let g = self.group[i];
            self.range[g] = self.range[g].max(moved);
            self.recent[i * MEMORY + self.slot] = self.third[i];
        }
        self.slot = (self.slot + 1) % MEMORY;
    }

    /// The Lagrange weight of history point `a` for extrapolating to `t`.
    fn weight(&self, a: usize, t: f64) -> f64 {
        let mut l = 1.0;
        for b in 0..self.count {
            if a != b {
                l *= (t - self.t[b]) / (self.t[a] - self.t[b]);
            }
        }
        l
    }

    /// Extrapolation of entry i to time `t` by the polynomial through the kept points.
    fn predict(&self, i: usize, t: f64) -> f64 {
        (0..self.count).map(|a| self.weight(a, t) * self.u[a][i]).sum()
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
        let t = self.time;
        let n = self.work.guess.len();
        if !self.adaptive.started {
            // the origin of the ranges; not a history point: the start may be a discontinuity
            // (an abrupt start), which no smooth extrapolation across it may see
            let Coupled { adaptive, units, y, .. } = self;
            let l = units.layout();
            for i in 0..n {
                adaptive.u0[i] = l.coupled(i, y);
            }
            adaptive.started = true;
            adaptive.group = l.group.clone();
        }
        let mut rejected = 0;
        let mut h = ctl.next_step();
        loop {
            // land on t_stop without leaving a sliver
            if self.adaptive.count < 3 {
                h = h.min(ctl.limits().h_init);
            }
            if t + 1.5 * h >= t_stop {
                h = if t + h >= t_stop { t_stop - t } else { 0.5 * (t_stop - t) };
            }
            let report = match self.step(h) {
                Ok(r) => Some(r),
                Err(StepError::NotConverged { .. }) => None,
                Err(e) => return Err(e),
            };
            if report.is_some() {
                let Coupled { adaptive, units, y, .. } = self;
                let l = units.layout();
                for i in 0..n {
                    adaptive.candidate[i] = l.coupled(i, y);
                }
            }
            let (error, order) = match report {
                Some(_) if self.adaptive.count < 3 => (0.0, 2), // too little history to estimate from
                Some(_) => self.estimate(t + h, h, t_stop, tol),
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
                    self.roll_back(t)?;
                    rejected += 1;
                    h = h_retry;
                }
                Decision::Fail => {
                    self.roll_back(t)?;
                    return Err(StepError::StepTooSmall { time: t, error, h_min: ctl.limits().h_min });
                }
            }
        }
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
        Ok(())
    }

    /// The error norm of the step that ended at `t1` (its coupled values in
    /// `adaptive.candidate`) and the order of the norm in h. `|U'''|` is taken as its largest
    /// value over this and the last few accepted steps: for an oscillation it passes through zero
    /// twice a period while the phase error it stands for keeps growing. The interface is only
    /// converged to `tol · scale`: the part of the predictor–corrector difference that this
    /// noise can explain (amplified by the extrapolation weights) is not counted as error.
    fn estimate(&mut self, t1: f64, h: f64, horizon: f64, tol: Tolerances) -> (f64, u32) {
        let Coupled { adaptive, units, options, .. } = self;
        let l = units.layout();
        let a = &mut *adaptive;
        // U''' ≈ 6 (U − P(t1)) / ((t1 − t0)(t1 − t1')(t1 − t2)), P the parabola of the history
        let spread = (t1 - a.t[0]) * (t1 - a.t[1]) * (t1 - a.t[2]);
        let amplification = 1.0 + (0..3).map(|k| a.weight(k, t1).abs()).sum::<f64>();
        // root mean square over the coupled quantities (one quantity at its limit does not force
        // the step down alone)
        let mut worst: f64 = 0.0;
        for i in 0..l.inputs() {
            let noise = amplification * options.tol * l.scale[i];
            let difference = ((a.candidate[i] - a.predict(i, t1)).abs() - noise).max(0.0);
            let third = 6.0 * difference / spread.abs();
            a.third[i] = third;
            let recent = a.recent[i * MEMORY..(i + 1) * MEMORY].iter().fold(third, |m, x| m.max(*x));
            let local = h * h * h * recent / ERROR_CONSTANT;
            let e = local * horizon / (h * (tol.atol * l.scale[i] + tol.rtol * a.range[l.group[i]]));
            worst += e * e / l.inputs() as f64;
        }
        worst = worst.sqrt();
        (worst, 2)
    }
}
