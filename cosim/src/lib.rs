//! Co-simulation of FMI 2.0 Co-Simulation FMUs.
//!
//! * [`system`]: the coupled system — units, connections, layout, scales — as the schemes see
//!   it ([`Units`]), the FMU implementation ([`FmuSystem`]) and the name-based description it is
//!   built from ([`SystemSpec`]);
//! * [`schemes`]: the coupling schemes and the adaptive macro step ([`Coupled`]);
//! * [`iqn`]: interface quasi-Newton acceleration (IQN-ILS);
//! * [`adaptive`]: the adaptive step of any stepper that can undo a step;
//! * [`step_control`]: step-size control that sees only error norms and step sizes, and
//!   [`error_estimate`] the local error estimate it is given;
//! * [`ssp`]: SSP 1.0 system descriptions, read and written;
//! * [`error`]: set-up and run errors.

pub mod adaptive;
pub mod dense;
pub mod error;
pub mod error_estimate;
pub mod iqn;
pub mod me;
pub mod schemes;
pub mod ssp;
pub mod step_control;
pub mod system;

pub use error::{SetupError, StepError};
pub use iqn::IqnOptions;
pub use schemes::{
    AdaptiveStep, Coupled, Extrapolation, JacobianUpdate, Options, Relaxation, START_SUBSTEPS, Scheme, StepReport,
};
pub use system::fmu::{FmuSystem, Needs};
pub use system::spec::SystemSpec;
pub use system::{Capabilities, Layout, Slot, UnitError, UnitLayout, Units};
