//! One stepper per kind of method: the model in time as the step loop drives it.

mod cable;
mod cosimulation;
mod monolithic;

pub(super) use cable::CableStepper;
pub use cosimulation::CABIN_POSE;
pub(super) use cosimulation::{CosimStepper, Coupling};
pub(super) use monolithic::MonolithicStepper;

use stewart::Compensation;

use crate::net::Frame;

use super::RunError;
use super::record::{Observed, Probe};
use crate::stepping::{Request, Step};

/// A method's model in time.
pub(super) trait Stepper {
    /// What the model shows now.
    fn probe(&mut self) -> Result<Probe, RunError>;
    /// The step the loop asks for, and what it left.
    fn step(&mut self, request: Request) -> Result<Step<Observed>, RunError>;
    /// The compensation that places the feed (scenes with `[control]`).
    fn compensation(&self) -> Option<&Compensation> {
        None
    }
    /// The net now, into `frame`, for the methods that have it (false: this one has not).
    fn net(&mut self, _frame: &mut Frame) -> bool {
        false
    }
}

/// The step and its end time of a method without an adaptive step (the run's preparation gives
/// it no other).
fn fixed(method: &'static str, request: Request) -> Result<(f64, f64), RunError> {
    match request {
        Request::Fixed { h, t } => Ok((h, t)),
        Request::Adaptive { .. } => {
            Err(RunError::Refused { method, reason: "this method has no adaptive step".into() })
        }
    }
}

fn stopped(method: &'static str, time: f64, reason: String) -> RunError {
    RunError::Stopped { method, time, reason }
}

fn vec6(v: &nalgebra::Vector6<f64>) -> [f64; 6] {
    [v[0], v[1], v[2], v[3], v[4], v[5]]
}
