//! The time integrator of every model: generalized-α (Chung & Hulbert 1993) in the form of
//! Arnold & Brüls (2007) on the configuration manifold, with one Newton controller.
//!
//! * [`coefficients`]: α_m, α_f, β, γ from ρ∞ and the factors β′, γ′ of the iteration matrix;
//! * [`problem`]: what a model provides — residual, iteration matrix (assemble and factorize),
//!   solve, and placing a trial configuration on its manifold;
//! * [`state`]: the integrated state and the reused scratch of a step;
//! * [`newton`]: one step — predictor, Newton corrector (stopping rule, refresh policy, slack
//!   safeguards), acceptance, and halving on failure;
//! * [`error`]: why a step or a set of options is refused.
//!
//! A model (the cable–cabin model, the monolithic model) implements [`Problem`] once; everything
//! about time stepping lives here, so the models cannot drift apart.

pub mod coefficients;
pub mod error;
pub mod newton;
pub mod problem;
pub mod state;

pub use coefficients::GenAlpha;
pub use error::{Failure, OptionsError, Quantity, StepError};
pub use newton::{Integrator, Newton, StepReport};
pub use problem::{Input, Iterate, IterationMatrix, Problem};
pub use state::{State, Workspace};
