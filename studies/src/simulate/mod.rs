//! One run of the LT50m system with a chosen method, recorded as a [`Trace`]: the cabin-centre
//! displacement and rotation from the static equilibrium and the Stewart wrench, sampled at the
//! scene's output interval, and a [`Summary`] (peaks, iterations, residuals) taken at every
//! step. Methods: the monolithic eq. (7) model, a co-simulation scheme on the FMUs, the
//! decoupled model of the paper's ref. \[3\] (the Stewart FMU with its cabin held at the static
//! pose, its wrench applied to the cable FMU), or the cable–cabin model alone.
//!
//! A run is checked whole before its first step ([`Run::prepare`]): the steps reach the end
//! time exactly (fixed steps) or land on it (the adaptive step of a co-simulation), their number
//! is capped, the memory the models need fits, the scene has what the method needs. Every
//! method steps through the one loop of [`crate::stepping`]; any non-finite value seen while
//! stepping stops the run with the time and the quantity.
//!
//! * [`run`]: the run's checks and its execution; [`steppers`]: one stepper per kind of method
//!   (the cable model alone, the monolithic model, a co-simulation) behind one trait;
//! * [`record`]: what a step leaves and the recorder that checks it; [`trace`]: what a run keeps;
//! * [`error`]: why a run gives no result.

mod error;
mod record;
mod run;
mod steppers;
mod trace;

pub use error::{Detached, RunError};
pub use run::{Run, simulate};
pub use steppers::CABIN_POSE;
pub use trace::{Summary, Trace};

use cosim::Options;

use crate::system::Adaptive;

/// How the system is solved.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// The cable–cabin model alone (platform locked or absent) under the scene's disturbance;
    /// in-process, no FMU.
    CableOnly,
    Monolithic,
    /// The monolithic model with the adaptive step.
    MonolithicAdaptive(Adaptive),
    Cosim(Options),
    /// A co-simulation with the adaptive macro step (schemes that iterate).
    CosimAdaptive(Options, Adaptive),
    Decoupled(Options),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::CableOnly => "cable",
            Method::Monolithic | Method::MonolithicAdaptive(_) => "monolithic",
            Method::Cosim(o) | Method::CosimAdaptive(o, _) => o.scheme.name(),
            Method::Decoupled(_) => "decoupled",
        }
    }

    /// Why a run of this method cannot hand out the net (every cable node in time), if it cannot.
    pub fn net_refusal(&self) -> Option<String> {
        match self {
            Method::CableOnly | Method::Monolithic | Method::MonolithicAdaptive(_) => None,
            _ => Some(format!(
                "a {} run has the net only as the cable FMU's outputs, which are the cabin's motion and the \
                 end tensions: the node positions are not among them (their number follows the FMU's \
                 elements_per_cable parameter, and an FMI 2.0 description lists a fixed set of variables); \
                 run the same system with --scheme monolithic (IJCSA agrees with it to 1e-4 mm at LT50m C), \
                 or --scheme cable for the cable–cabin model alone",
                self.name()
            )),
        }
    }
}
