//! The monolithic reference model: the paper's eq. (7) for the whole system in one set of
//! equations, integrated without any co-simulation splitting.
//!
//! Unknowns: the cable–cabin model's own (the free nodes of every cable and the cabin, whose
//! cable end nodes ride on it exactly), the 13 Stewart bodies (rigid, absolute coordinates,
//! orientations on SO(3)) and the Lagrange multipliers of the Stewart platform's Hooke,
//! prismatic, spherical and driving (stroke ℓ_k(t)) constraints ([`stewart::constraints`]).
//! Integration: index-3 generalized-α ([`feedcore::genalpha`], the integrator of the cable model
//! too), the equations of motion and Φ(q, t) = 0 enforced at t_{n+1}.
//!
//! * [`model`]: what does not change during a run;
//! * [`config`]: the configuration (cable–cabin configuration and the Stewart bodies' poses);
//! * [`feed`]: the feed's error over a run, what the second level's figures are measured from;
//! * [`kkt`]: the linear algebra of a Newton iteration — the cable chains condensed onto the
//!   cabin, the rigid bodies eliminated, and the constraints' dense Schur complement;
//! * [`schur`]: the constraints' Schur complement, factorized leg by leg onto the joints that
//!   touch the cabin or the platform;
//! * [`problem`]: residual and iteration matrix, as the integrator asks for them;
//! * [`linear`]: the model linearized at rest, the second level's design model;
//! * [`run`]: the model in time ([`Monolithic`]): stepping, samples, snapshots.
//!
//! The cable–cabin part is assembled by the cable crate itself ([`cable::system::System`]),
//! the rigid-body terms by [`feedcore::rigid::BodyTerms`], the joints by the Stewart crate: the
//! reference shares every physics term with the models it checks and none of their copies.
//!
//! Start: the cables and the cabin at rest in the static equilibrium with the platform at its
//! starting pose; the Stewart bodies already on their prescribed relative motion (with the
//! abrupt start, at full speed): the same initial state as the co-simulation.

pub mod config;
pub mod feed;
pub mod kkt;
pub mod linear;
pub mod model;
pub mod problem;
pub mod run;
pub mod schur;

pub use run::{Monolithic, MonolithicError, Sample, Snapshot};
