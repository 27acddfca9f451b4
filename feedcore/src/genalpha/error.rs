//! Why a step, or a set of integrator options, is refused.

use std::fmt;

/// A quantity of a step that can stop being finite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    Residual,
    Correction,
    Increment,
    Velocity,
    Acceleration,
    PseudoAcceleration,
    Multiplier,
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Quantity::Residual => "residual",
            Quantity::Correction => "Newton correction",
            Quantity::Increment => "position increment",
            Quantity::Velocity => "velocity",
            Quantity::Acceleration => "acceleration",
            Quantity::PseudoAcceleration => "pseudo-acceleration",
            Quantity::Multiplier => "Lagrange multiplier",
        })
    }
}

/// Why one step failed. `E`: the model's own errors.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError<E> {
    #[error("invalid step size {0} s: it must be positive and finite")]
    StepSize(f64),
    #[error(
        "Newton did not converge in {iterations} iterations (last correction {correction:.3e}, tolerance {tolerance:.1e}); reduce the step size or check the input for jumps"
    )]
    NotConverged { iterations: usize, correction: f64, tolerance: f64 },
    #[error("the {quantity} of {unknown} is {value} (the motion diverged)")]
    NotFinite { quantity: Quantity, unknown: String, value: f64 },
    #[error(
        "the constraint residual {residual:.3e} of the converged step exceeds {bound:.3e} (100 × the Newton tolerance): the iteration settled on a wrong solution; reduce the step size"
    )]
    ConstraintResidual { residual: f64, bound: f64 },
    #[error(transparent)]
    Model(E),
}

/// A step that failed: the time it was to reach and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("at t = {time:.6} s: {reason}")]
pub struct Failure<E> {
    pub time: f64,
    pub reason: StepError<E>,
}

/// Integrator options that cannot work.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OptionsError {
    #[error("rho_inf = {0}: the high-frequency spectral radius must lie in [0, 1] (e.g. 0.9)")]
    SpectralRadius(f64),
    #[error("newton_tol = {0:e}: the Newton tolerance must be a positive, finite length (m), e.g. 1e-10")]
    Tolerance(f64),
    #[error(
        "newton_tol = {tolerance:e} m is above {bound:.1e} m ({RELATIVE_TOLERANCE_BOUND:e} of the model's smallest length, {length:.3} m): Newton would accept steps that have not converged; use at most {bound:.1e} m (e.g. 1e-10)"
    )]
    ToleranceTooLoose { tolerance: f64, bound: f64, length: f64 },
    #[error("newton_max_iter = {0}: give at least 1")]
    Iterations(usize),
}

/// The largest Newton tolerance, relative to the model's smallest length. Measured on the
/// monolithic model at C (100 s; smallest length 0.4 m): against newton_tol = 1e-10 the cabin
/// path moves by 5e-6 of its peak at 1e-7 m, 8e-5 at 1e-5 m, 4e-3 at 1e-4 m and 57 % at 1e-3 m
/// (issue 10: 0.1 gave 67 mm instead of 1.66 mm and NaN rows before this bound).
pub(crate) const RELATIVE_TOLERANCE_BOUND: f64 = 1e-5;
