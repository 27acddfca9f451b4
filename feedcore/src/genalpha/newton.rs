//! One generalized-α step with its Newton controller.
//!
//! Predictor: the acceleration extrapolated linearly from the last two steps where the model
//! says it is smooth, constant elsewhere. Corrector: Newton on the position increment Δq (and the
//! multipliers), with `v̇ = v̇* + β′ δ` and `v = v* + γ′ δ` following each correction δ. The
//! iteration matrix is factorized by the model and kept from step to step while Newton converges
//! quickly with it:
//!
//! * **stopping rule**: the largest motion correction is below the tolerance, or the error it
//!   leaves — estimated from the observed contraction ρ as ρ/(1−ρ)·|δ| — is ten times below it
//!   (ρ < 0.2 only, where that estimate holds);
//! * **refresh policy**: a new factorization when there is none for this step size, when a
//!   correction shrinks by less than [`SLOW_CONTRACTION`] per iteration, and in any case from
//!   half the iteration limit on;
//! * **slack safeguards**: the first matrix of a step gives slack tension-only elements their
//!   taut stiffness; a matrix refreshed in the step that still contracts by less than
//!   [`STILL_SLOW`] is replaced by the exact (semismooth) tangent; a correction that does not
//!   lower the residual has jumped across a tension-only kink and is taken back in halves until
//!   it does; a step that does not converge (an element snapping taut is an impact) is retaken
//!   as two halves, down to 1/2^[`HALVINGS`] of it;
//! * **acceptance**: the constraint residual of the converged configuration must be within
//!   [`CONSTRAINT_BOUND`] tolerances, and every number of the new state finite.

use super::coefficients::GenAlpha;
use super::error::{Failure, OptionsError, Quantity, RELATIVE_TOLERANCE_BOUND, StepError};
use super::problem::{Input, Iterate, IterationMatrix, Problem};
use super::state::{State, Workspace};

/// Refresh the kept factorization when a correction shrinks by less than this factor per
/// iteration. Measured on LT50m, 20 s at h = 0.01 (callgrind): the monolithic model needs 2.0
/// Newton iterations per step at 0.02–0.05, 2.2 at 0.1 and 2.3–2.7 at 0.25; the cable model
/// alone does not care; IJCSA's cable FMU (tolerance 1e-12, rolled back every macro step) does
/// 6 % less work at 0.25 than at 0.05 — and at 0.05 its outputs turn rough where a cable goes
/// slack, so that IJCSA's interface Newton stalls (tests/slack.rs of the master). 0.1 keeps that
/// robustness at 5 % more monolithic work than the optimum.
pub(crate) const SLOW_CONTRACTION: f64 = 0.1;
/// A matrix refreshed in this step that still contracts by less than this has met an element at
/// its slack limit: from then on the exact tangent, slack elements at zero stiffness.
pub(crate) const STILL_SLOW: f64 = 0.25;
/// The error estimate ρ/(1−ρ)·|δ| is trusted below this contraction.
const FAST_CONTRACTION: f64 = 0.2;
/// Halvings of one correction at most while backtracking.
const BACKTRACKS: usize = 12;
/// Residuals below this (N, N·m) are round-off of the forces involved: no backtracking.
const RESIDUAL_FLOOR: f64 = 1e-6;
/// A step that fails is retaken as halves, down to 1/2^HALVINGS of it.
pub(crate) const HALVINGS: u32 = 6;
/// Constraint residual allowed at acceptance, in Newton tolerances: a converged position error
/// below the tolerance moves a joint point by less than (1 + lever arm) tolerances, a few for
/// the arms here; a hundred leaves a margin of ten.
pub(crate) const CONSTRAINT_BOUND: f64 = 100.0;

/// Newton settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Newton {
    /// Largest correction (m, rad) at convergence.
    pub tolerance: f64,
    pub max_iterations: usize,
}

impl Newton {
    /// Checked settings for a model whose smallest length (an element, a body) is
    /// `length_scale`: the tolerance must be positive and at most
    /// [`RELATIVE_TOLERANCE_BOUND`] of it, otherwise the stopping rule accepts steps that have
    /// not converged and the results are garbage.
    pub fn new(tolerance: f64, max_iterations: usize, length_scale: f64) -> Result<Newton, OptionsError> {
        if !(tolerance > 0.0 && tolerance.is_finite()) {
            return Err(OptionsError::Tolerance(tolerance));
        }
        let bound = RELATIVE_TOLERANCE_BOUND * length_scale;
        if !(tolerance <= bound) {
            return Err(OptionsError::ToleranceTooLoose { tolerance, bound, length: length_scale });
        }
        if max_iterations == 0 {
            return Err(OptionsError::Iterations(max_iterations));
        }
        Ok(Newton { tolerance, max_iterations })
    }
}

/// The work of one step (of all its parts, if it was halved).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    pub iterations: usize,
    pub factorizations: usize,
    /// Corrections taken back by half.
    pub backtracks: usize,
    /// Size of the last part taken (the step itself unless it was halved).
    pub last_step: f64,
}

impl StepReport {
    /// What this step and the `next` one, taken after it, cost together.
    pub fn then(self, next: StepReport) -> StepReport {
        StepReport {
            iterations: self.iterations + next.iterations,
            factorizations: self.factorizations + next.factorizations,
            backtracks: self.backtracks + next.backtracks,
            last_step: next.last_step,
        }
    }
}

/// The generalized-α integrator: coefficients and Newton settings (immutable).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Integrator {
    coefficients: GenAlpha,
    newton: Newton,
}

impl Integrator {
    pub fn new(rho_inf: f64, newton: Newton) -> Result<Integrator, OptionsError> {
        if !(0.0..=1.0).contains(&rho_inf) {
            return Err(OptionsError::SpectralRadius(rho_inf));
        }
        Ok(Integrator { coefficients: GenAlpha::new(rho_inf), newton })
    }

    pub fn coefficients(&self) -> &GenAlpha {
        &self.coefficients
    }

    pub fn newton(&self) -> &Newton {
        &self.newton
    }

    /// Advances `state` by `h`, the input going linearly from `from` to `to` over the step (only
    /// halved steps see the values in between). On failure `state` is as before; only the
    /// model's kept factorization may have been refreshed.
    pub fn step<P: Problem>(
        &self,
        problem: &mut P,
        state: &mut State<P::Config>,
        work: &mut Workspace<P::Config>,
        h: f64,
        from: &P::Input,
        to: &P::Input,
    ) -> Result<StepReport, Failure<P::Error>> {
        self.split(problem, state, work, h, from, to, 0)
    }

    #[allow(clippy::too_many_arguments)]
    fn split<P: Problem>(
        &self,
        problem: &mut P,
        state: &mut State<P::Config>,
        work: &mut Workspace<P::Config>,
        h: f64,
        from: &P::Input,
        to: &P::Input,
        depth: u32,
    ) -> Result<StepReport, Failure<P::Error>> {
        match self.step_once(problem, state, work, h, to) {
            Ok(report) => Ok(report),
            Err(StepError::NotConverged { .. } | StepError::ConstraintResidual { .. }) if depth < HALVINGS => {
                let mid = from.midpoint(to);
                let a = self.split(problem, state, work, 0.5 * h, from, &mid, depth + 1)?;
                let b = self.split(problem, state, work, 0.5 * h, &mid, to, depth + 1)?;
                Ok(a.then(b))
            }
            Err(reason) => Err(Failure { time: state.time + h, reason }),
        }
    }

    /// One step without halving; `state` changes only on success.
    fn step_once<P: Problem>(
        &self,
        p: &mut P,
        state: &mut State<P::Config>,
        work: &mut Workspace<P::Config>,
        h: f64,
        input: &P::Input,
    ) -> Result<StepReport, StepError<P::Error>> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(StepError::StepSize(h));
        }
        let t1 = state.time + h;
        p.begin_step(t1, input).map_err(StepError::Model)?;
        let ga = self.coefficients;
        let (bp, gp) = (ga.beta_prime(h), ga.gamma_prime(h));
        let (tol, max_iter) = (self.newton.tolerance, self.newton.max_iterations);
        let n = state.velocity.len();
        let Workspace { trial, increment, velocity, acceleration, multipliers, residual, delta } = work;

        // Predictor: the acceleration extrapolated linearly from the last two steps (where the
        // model allows; constant before the first step and elsewhere); a, v and the increment
        // follow from v̇.
        let c_acc = 1.0 / (1.0 - ga.alpha_m);
        let slope = if state.previous_step > 0.0 { h / state.previous_step } else { 0.0 };
        let smooth = p.extrapolated_unknowns().min(n);
        let last = state.acceleration.iter().zip(&state.previous_acceleration);
        for (i, (vd, vd0)) in last.enumerate() {
            acceleration[i] = if i < smooth { vd + slope * (vd - vd0) } else { *vd };
        }
        let old = state.acceleration.iter().zip(&state.pseudo_acceleration).zip(&state.velocity);
        let new = acceleration.iter().zip(velocity.iter_mut()).zip(increment.iter_mut());
        for (((vd, a), v), ((vd1, v1), u)) in old.zip(new) {
            let a1 = c_acc * ((1.0 - ga.alpha_f) * vd1 + ga.alpha_f * vd - ga.alpha_m * a);
            *v1 = v + h * (1.0 - ga.gamma) * a + h * ga.gamma * a1;
            *u = h * v + h * h * (0.5 - ga.beta) * a + h * h * ga.beta * a1;
        }
        multipliers.copy_from_slice(&state.multipliers);
        p.place(&state.config, increment, trial);

        macro_rules! at {
            () => {
                Iterate {
                    time: t1,
                    config: &*trial,
                    increment: &increment[..],
                    velocity: &velocity[..],
                    acceleration: &acceleration[..],
                    multipliers: &multipliers[..],
                }
            };
        }
        let matrix =
            |slack_as_taut| IterationMatrix { step: h, mass: bp, damping: gp, constraint_scale: bp, slack_as_taut };

        let mut report = StepReport { last_step: h, ..StepReport::default() };
        let (mut previous, mut previous_residual) = (f64::INFINITY, f64::INFINITY);
        let mut fresh = false;
        // `residual` already holds the residual at the current iterate (from a factorization).
        let mut residual_current = false;
        let mut converged = false;
        for it in 0..max_iter {
            let stale = p.factorized_step() != Some(h);
            if stale || (it > 0 && !fresh && it >= max_iter / 2) {
                p.factorize(&at!(), &matrix(true), residual).map_err(StepError::Model)?;
                report.factorizations += 1;
                fresh = true;
                residual_current = true;
            }
            if !residual_current {
                p.residual(&at!(), bp, residual);
            }
            residual_current = false;
            let mut rmax = max_abs(residual);
            // A correction that did not lower the residual has jumped across the tension-only
            // kink of an element (Newton would cycle): take back halves of it until it does.
            let mut backtracks = 0;
            while it > 0
                && rmax.is_finite()
                && rmax >= previous_residual
                && rmax > RESIDUAL_FLOOR
                && backtracks < BACKTRACKS
            {
                backtracks += 1;
                for i in 0..n {
                    let d = 0.5 * delta[i];
                    delta[i] = d;
                    increment[i] -= d;
                    acceleration[i] -= bp * d;
                    velocity[i] -= gp * d;
                }
                for (l, d) in multipliers.iter_mut().zip(&mut delta[n..]) {
                    *d *= 0.5;
                    *l -= *d;
                }
                p.place(&state.config, increment, trial);
                p.residual(&at!(), bp, residual);
                rmax = max_abs(residual);
            }
            report.backtracks += backtracks;
            if !rmax.is_finite() {
                return Err(not_finite(p, Quantity::Residual, residual, 0));
            }
            previous_residual = rmax;
            // δ = −S⁻¹ r: negate the residual and solve in its place (the buffers swap roles;
            // the old correction is not needed any more)
            residual.iter_mut().for_each(|r| *r = -*r);
            std::mem::swap(residual, delta);
            p.solve(delta);
            if !max_abs(&delta[n..]).is_finite() {
                return Err(not_finite(p, Quantity::Correction, delta, 0));
            }
            let dmax = max_abs(&delta[..n]);
            if !dmax.is_finite() {
                return Err(not_finite(p, Quantity::Correction, delta, 0));
            }
            let (motion, lambda) = delta.split_at(n);
            let moved = increment.iter_mut().zip(acceleration.iter_mut()).zip(velocity.iter_mut());
            for (((x, a), v), d) in moved.zip(motion) {
                *x += d;
                *a += bp * d;
                *v += gp * d;
            }
            for (l, d) in multipliers.iter_mut().zip(lambda) {
                *l += d;
            }
            p.place(&state.config, increment, trial);
            report.iterations = it + 1;
            let rate = dmax / previous;
            if dmax <= tol || (it > 0 && rate < FAST_CONTRACTION && rate / (1.0 - rate) * dmax <= 0.1 * tol) {
                converged = true;
                break;
            }
            // Slow contraction with a kept factorization: refresh it at the current iterate.
            // Still slow with a fresh one: an element sits at its slack limit, where the taut
            // stiffness given to slack elements is a poor guess; from then on the exact tangent.
            if it > 0 && dmax > if fresh { STILL_SLOW } else { SLOW_CONTRACTION } * previous {
                p.factorize(&at!(), &matrix(!fresh), residual).map_err(StepError::Model)?;
                report.factorizations += 1;
                fresh = true;
                residual_current = true;
            }
            previous = dmax;
        }
        if !converged {
            return Err(StepError::NotConverged { iterations: max_iter, correction: previous, tolerance: tol });
        }

        // Acceptance: the constraints hold to the tolerance, and the new state is finite.
        let violation = p.constraint_violation(trial);
        let bound = CONSTRAINT_BOUND * tol;
        if !(violation <= bound) {
            return Err(StepError::ConstraintResidual { residual: violation, bound });
        }
        let pseudo = &mut delta[..n];
        let new = pseudo.iter_mut().zip(&acceleration[..]).zip(&state.acceleration).zip(&state.pseudo_acceleration);
        for (((p, vd1), vd), a) in new {
            *p = c_acc * ((1.0 - ga.alpha_f) * vd1 + ga.alpha_f * vd - ga.alpha_m * a);
        }
        // one pass over everything new: a sum of finite numbers times zero is zero
        let all = increment.iter().zip(&velocity[..]).zip(&acceleration[..]).zip(&delta[..n]);
        let zero = all.fold(0.0, |z, (((x, v), a), p)| z + (x + v + a + p) * 0.0);
        if !(zero == 0.0 && max_abs(multipliers).is_finite()) {
            for (quantity, values, offset) in [
                (Quantity::Increment, &increment[..], 0),
                (Quantity::Velocity, &velocity[..], 0),
                (Quantity::Acceleration, &acceleration[..], 0),
                (Quantity::PseudoAcceleration, &delta[..n], 0),
                (Quantity::Multiplier, &multipliers[..], n),
            ] {
                if values.iter().any(|x| !x.is_finite()) {
                    return Err(not_finite(p, quantity, values, offset));
                }
            }
        }
        state.pseudo_acceleration.copy_from_slice(&delta[..n]);
        std::mem::swap(&mut state.previous_acceleration, &mut state.acceleration);
        state.previous_step = h;
        state.acceleration.copy_from_slice(acceleration);
        state.velocity.copy_from_slice(velocity);
        state.multipliers.copy_from_slice(multipliers);
        std::mem::swap(&mut state.config, trial);
        state.time = t1;
        Ok(report)
    }
}

/// Largest magnitude; NaN if any entry is not finite (a plain `f64::max` would skip NaN).
pub(crate) fn max_abs(v: &[f64]) -> f64 {
    // Four lanes, so that it vectorizes; `x·0` is 0 for a finite x and NaN otherwise.
    let (mut m, mut zero) = ([0.0f64; 4], [0.0f64; 4]);
    let chunks = v.chunks_exact(4);
    for &x in chunks.remainder() {
        let a = x.abs();
        m[0] = if a > m[0] { a } else { m[0] };
        zero[0] += x * 0.0;
    }
    for c in chunks {
        let c: &[f64; 4] = c.try_into().expect("chunks of four");
        for k in 0..4 {
            let a = c[k].abs();
            m[k] = if a > m[k] { a } else { m[k] };
            zero[k] += c[k] * 0.0;
        }
    }
    if (zero[0] + zero[1]) + (zero[2] + zero[3]) == 0.0 { m[0].max(m[1]).max(m[2].max(m[3])) } else { f64::NAN }
}

/// The error for the first entry of `values` that is not finite (`offset`: index of its first
/// entry among the unknowns).
fn not_finite<P: Problem>(p: &P, quantity: Quantity, values: &[f64], offset: usize) -> StepError<P::Error> {
    let i = values.iter().position(|x| !x.is_finite()).unwrap_or(0);
    StepError::NotFinite {
        quantity,
        unknown: p.unknown_name(offset + i),
        value: values.get(i).copied().unwrap_or(f64::NAN),
    }
}
