//! What a model gives the integrator.
//!
//! Unknowns are velocity-level: `n` motion unknowns (node displacements, rigid-body translations
//! and world-frame rotation vectors) followed by `m` Lagrange multipliers. The residual has the
//! same layout: the equations of motion `M v̇ + g − f + Φ_qᵀ λ`, then the position constraints
//! `Φ(q, t)` times a scale (β′, so that the constraint rows weigh like the equations of motion).

/// The model side of one time step.
pub trait Problem {
    /// Positions and orientations: a point of the configuration manifold.
    type Config;
    /// What drives a step from outside (e.g. a wrench); interpolated when a step is halved.
    type Input: Input;
    /// Why the model cannot go on.
    type Error: std::error::Error + 'static;

    /// How many leading motion unknowns have accelerations smooth enough in time to be
    /// predicted by linear extrapolation from the last two steps; the others (and the
    /// multipliers) are predicted constant. Unknowns tied to constraints at index 3 carry the
    /// method's spurious oscillations in their accelerations, which extrapolation amplifies.
    fn extrapolated_unknowns(&self) -> usize {
        0
    }

    /// Moves `base` by the velocity-level `increment` into `trial` (positions add; rotations
    /// compose through the exponential map).
    fn place(&self, base: &Self::Config, increment: &[f64], trial: &mut Self::Config);

    /// Prepares a step that ends at `time` under `input` (time-dependent data, such as a
    /// prescribed motion, is evaluated here once per step).
    fn begin_step(&mut self, time: f64, input: &Self::Input) -> Result<(), Self::Error>;

    /// Writes the residual at `at`: equations of motion, then constraints × `constraint_scale`.
    fn residual(&mut self, at: &Iterate<'_, Self::Config>, constraint_scale: f64, residual: &mut [f64]);

    /// Writes the residual as [`Problem::residual`] does, and assembles and factorizes the
    /// iteration matrix `matrix` at `at`; the factorization is kept until the next call.
    fn factorize(
        &mut self,
        at: &Iterate<'_, Self::Config>,
        matrix: &IterationMatrix,
        residual: &mut [f64],
    ) -> Result<(), Self::Error>;

    /// The step size the kept factorization was built for; `None` when there is none.
    fn factorized_step(&self) -> Option<f64>;

    /// Overwrites `rhs` with the solution of `S x = rhs`, `S` the kept factorization.
    fn solve(&mut self, rhs: &mut [f64]);

    /// What unknown `index` is (motion unknowns, then multipliers), for error messages.
    fn unknown_name(&self, index: usize) -> String;

    /// Largest violation of the position constraints at `config` (m or rad); checked when a
    /// step is accepted. Without constraints, zero.
    fn constraint_violation(&mut self, config: &Self::Config) -> f64 {
        let _ = config;
        0.0
    }
}

/// A Newton iterate of one step.
#[derive(Clone, Copy, Debug)]
pub struct Iterate<'a, C> {
    /// End of the step.
    pub time: f64,
    pub config: &'a C,
    /// Velocity-level increment from the step's start (rotations: world-frame rotation vectors);
    /// its rotation parts give the tangent of the exponential map.
    pub increment: &'a [f64],
    pub velocity: &'a [f64],
    /// True acceleration v̇.
    pub acceleration: &'a [f64],
    pub multipliers: &'a [f64],
}

/// The iteration matrix to assemble: `mass·M + damping·∂r/∂v + ∂r/∂q·T` with the constraint
/// rows `constraint_scale·Φ_q·T`, where `T` maps increments of the rotation coordinates to
/// world-frame rotations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterationMatrix {
    /// The step size it is built for.
    pub step: f64,
    /// β′ = ∂v̇/∂Δq.
    pub mass: f64,
    /// γ′ = ∂v/∂Δq.
    pub damping: f64,
    pub constraint_scale: f64,
    /// Give slack tension-only elements their taut axial stiffness. The first matrix of a step
    /// does: Newton then cannot jump across the tension-only kink from the slack side and
    /// cycle. A matrix refreshed again in the same step does not (the exact, semismooth
    /// tangent), so that the set of slack elements settles.
    pub slack_as_taut: bool,
}

/// An input that can be interpolated linearly between a step's ends (for halved steps).
pub trait Input: Copy {
    fn midpoint(&self, other: &Self) -> Self;
}

impl Input for () {
    fn midpoint(&self, _: &()) {}
}

impl Input for nalgebra::Vector6<f64> {
    fn midpoint(&self, other: &Self) -> Self {
        (self + other) * 0.5
    }
}
