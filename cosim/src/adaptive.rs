//! The adaptive step of any time stepper that can take a step back: tries the controller's step,
//! judges it by the [`ErrorEstimate`] of the quantities it watches, and undoes it to retry a
//! smaller one until a step is accepted. The co-simulation's macro step ([`crate::Coupled`])
//! and the monolithic model (in the master) both step through it, so they are judged alike.

use crate::error_estimate::{self, ErrorEstimate, Kind};
use crate::step_control::{Controller, Decision, Tolerances};

/// A time stepper whose steps can be undone.
pub trait Retake {
    /// What a converged step reports.
    type Report;
    type Error;
    /// Takes a step of `h` from the current time; `Ok(None)` when it did not converge (it is
    /// undone and retried smaller).
    fn try_step(&mut self, h: f64) -> Result<Option<Self::Report>, Self::Error>;
    /// Returns to the state before the last step, which started at `t`.
    fn undo(&mut self, t: f64) -> Result<(), Self::Error>;
    /// Keeps the present state in a second slot, which steps and undos leave alone.
    fn checkpoint(&mut self) -> Result<(), Self::Error>;
    /// Returns to the state of the last [`Retake::checkpoint`], over any steps since.
    fn back_to_checkpoint(&mut self) -> Result<(), Self::Error>;
    /// What two steps taken one after the other cost together (a doubled step is three).
    fn then(first: Self::Report, next: Self::Report) -> Self::Report;
    /// The watched quantities now, into `out`.
    fn watched(&mut self, out: &mut [f64]) -> Result<(), Self::Error>;
    /// The group (numbered from 0) and the positive scale of every watched quantity.
    fn groups(&self) -> (&[usize], &[f64]);
    /// How far each watched value is converged (absolute, in its own unit; zero if exactly),
    /// into `out`.
    fn noise(&self, out: &mut [f64]);
    /// The error of a run that cannot go on: no step of at least `h_min` converged at `t`
    /// (`error`: the last error norm, infinite where the step did not converge).
    fn too_small(&self, t: f64, error: f64, h_min: f64) -> Self::Error;
}

/// One accepted adaptive step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accepted<R> {
    /// The step size taken.
    pub h: f64,
    pub report: R,
    /// Tries rejected before this step was accepted.
    pub rejected: usize,
    /// Its error norm (≤ 1, or above it for a step forced at h_min).
    pub error: f64,
}

/// One accepted step of `stepper`, from `t` and ending at most at `t_stop` (landing on it
/// without leaving a sliver). The predictor's history starts after the first step: the first
/// three steps cannot be judged and are taken at the controller's first step size (keep it
/// small). With doubling every step is judged, and an accepted step of `h` is two half steps.
pub fn step<T: Retake>(
    stepper: &mut T,
    estimate: &mut ErrorEstimate,
    ctl: &mut Controller,
    tol: Tolerances,
    t: f64,
    t_stop: f64,
) -> Result<Accepted<T::Report>, T::Error> {
    if !estimate.is_started() {
        let mut u0 = vec![0.0; estimate.candidate_mut().len()];
        stepper.watched(&mut u0)?;
        let (group, scale) = stepper.groups();
        estimate.start(&u0, group, scale);
    }
    let mut rejected = 0;
    let mut h = ctl.next_step();
    let doubling = estimate.kind() == Kind::Doubling;
    loop {
        if !estimate.can_judge() {
            h = h.min(ctl.limits().h_init);
        }
        if t + 1.5 * h >= t_stop {
            h = if t + h >= t_stop { t_stop - t } else { 0.5 * (t_stop - t) };
        }
        let report = if doubling { try_doubled(stepper, estimate, h)? } else { stepper.try_step(h)? };
        let error = match report {
            Some(_) => {
                stepper.watched(estimate.candidate_mut())?;
                stepper.noise(estimate.candidate_noise_mut());
                if estimate.can_judge() { estimate.norm(t + h, h, t_stop, tol) } else { 0.0 }
            }
            None => f64::INFINITY,
        };
        let decision = match report {
            Some(_) => ctl.decide(error, h, error_estimate::ORDER),
            None => ctl.shrink(h).map_or(Decision::Fail, |h_retry| Decision::Reject { h_retry }),
        };
        match (decision, report) {
            (Decision::Accept { .. }, Some(report)) => {
                estimate.accept(t + h);
                return Ok(Accepted { h, report, rejected, error });
            }
            (Decision::Reject { h_retry }, _) => {
                back(stepper, doubling, t)?;
                rejected += 1;
                h = h_retry;
            }
            _ => {
                back(stepper, doubling, t)?;
                return Err(stepper.too_small(t, error, ctl.limits().h_min));
            }
        }
    }
}

/// Step doubling: the whole step of `h` from a checkpoint (its values into the estimate), back,
/// then two half steps; what the three cost together, `None` if any did not converge.
fn try_doubled<T: Retake>(
    stepper: &mut T,
    estimate: &mut ErrorEstimate,
    h: f64,
) -> Result<Option<T::Report>, T::Error> {
    stepper.checkpoint()?;
    let Some(whole_step) = stepper.try_step(h)? else { return Ok(None) };
    let (whole, noise) = estimate.whole_mut();
    stepper.watched(whole)?;
    stepper.noise(noise);
    stepper.back_to_checkpoint()?;
    let Some(first) = stepper.try_step(0.5 * h)? else { return Ok(None) };
    Ok(stepper.try_step(0.5 * h)?.map(|second| T::then(T::then(whole_step, first), second)))
}

/// Back to the start `t` of the step being tried: one step back, or with doubling to the
/// checkpoint (over the half steps).
fn back<T: Retake>(stepper: &mut T, doubling: bool, t: f64) -> Result<(), T::Error> {
    if doubling { stepper.back_to_checkpoint() } else { stepper.undo(t) }
}
