//! What can go wrong: setting a system up, and running it.

use std::path::PathBuf;

use crate::system::UnitError;

/// A system that cannot be set up: files, descriptions, connections, capabilities.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    /// A call into an FMU failed while loading or initializing it.
    #[error("component `{component}`: {source}")]
    Fmu { component: String, source: fmi::import::Error },
    /// The description does not fit the FMUs (names, types, units, values); the message names
    /// where, what and how to fix it.
    #[error("{0}")]
    Invalid(String),
    /// A scheme needs a capability a component lacks.
    #[error("{what} needs {capability} from every FMU: component `{component}` ({fmu}) does not declare {attribute}")]
    Capability { what: String, capability: &'static str, component: String, fmu: String, attribute: &'static str },
    /// The connected values did not settle in initialization mode.
    #[error(
        "initialization: the connected values did not settle in {iterations} passes over the loop \
         (still changing: `{variable}` by {change:.3e}); the system's algebraic loop does not contract"
    )]
    Initialization { iterations: usize, variable: String, change: f64 },
}

/// A run that could not go on: at what time ([`StepError::time`]) and why
/// ([`StepError::reason`]). Its message is `co-simulation stopped at t = … s: ` and the reason;
/// a scheme refused before the first step says only why.
#[derive(Debug)]
pub enum StepError {
    Unit {
        time: f64,
        unit: String,
        source: Box<UnitError>,
    },
    NotConverged {
        time: f64,
        scheme: &'static str,
        iterations: usize,
        residual: f64,
        variable: String,
        tol: f64,
    },
    /// The coupled values ran away (explicit schemes on a strongly coupled system).
    Unstable {
        cause: Box<StepError>,
        growth: f64,
        variable: String,
        value: f64,
        scheme: &'static str,
    },
    Failed {
        time: f64,
        reason: String,
    },
    /// A scheme that does not iterate, on a system with an algebraic loop: refused before the
    /// first step. It would take every input from the last communication point — a delay of one
    /// step the system does not have — and so solve another system, which is unstable wherever
    /// the loop's gain reaches 1.
    AlgebraicLoop {
        scheme: &'static str,
        cycle: String,
    },
    /// The adaptive step found no step down to the smallest allowed that converged with a
    /// finite error estimate.
    StepTooSmall {
        time: f64,
        error: f64,
        h_min: f64,
    },
}

impl StepError {
    /// Why the run stopped, without the time.
    pub fn reason(&self) -> String {
        match self {
            StepError::Unit { unit, source, .. } => format!("FMU `{unit}`: {source}"),
            StepError::NotConverged { scheme, iterations, residual, variable, tol, .. } => format!(
                "{scheme} did not converge in {iterations} iterations: interface residual {residual:.3e} (relative) \
                 at `{variable}` (tolerance {tol:.1e}); reduce the step size, raise --max-iter or loosen --tol"
            ),
            StepError::Unstable { cause, growth, variable, value, scheme } => format!(
                "{}; the coupled inputs had grown to {growth:.0}× their scale (`{variable}` = {value:.3e}): \
                 {scheme} is unstable here (a strongly coupled interface, e.g. an added mass); use ijcsa, iqn-ils or \
                 iterative",
                cause.reason()
            ),
            StepError::Failed { reason, .. } => reason.clone(),
            StepError::AlgebraicLoop { scheme, cycle } => format!(
                "scheme {scheme} cannot solve the system's algebraic loop {cycle} (each output on it responds at once \
                 to the input before it, as the FMUs declare in <ModelStructure>; an output without a dependencies \
                 list depends on every input): a non-iterating scheme would delay the loop by one step and solve a \
                 different system; use ijcsa, iqn-ils or iterative, which solve the loop at every step"
            ),
            StepError::StepTooSmall { error, h_min, .. } => format!(
                "no step down to --h-min {h_min} s converged with a finite error estimate (last: {error:.3e} \
                 relative to the tolerance); lower --h-min or check the FMUs"
            ),
        }
    }
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepError::AlgebraicLoop { .. } => f.write_str(&self.reason()),
            _ => write!(f, "co-simulation stopped at t = {:.6} s: {}", self.time(), self.reason()),
        }
    }
}

impl std::error::Error for StepError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            StepError::Unit { source, .. } => Some(&**source),
            _ => None,
        }
    }
}

impl StepError {
    /// The time the run stopped at.
    pub fn time(&self) -> f64 {
        match self {
            StepError::Unit { time, .. }
            | StepError::NotConverged { time, .. }
            | StepError::Failed { time, .. }
            | StepError::StepTooSmall { time, .. } => *time,
            StepError::AlgebraicLoop { .. } => 0.0,
            StepError::Unstable { cause, .. } => cause.time(),
        }
    }

    /// A unit ended the run on purpose (fmi2Discard / fmi2Terminated): not a failure. Returns
    /// the unit and the error of the unit.
    pub fn ended(&self) -> Option<(&str, &UnitError)> {
        match self {
            StepError::Unit { unit, source, .. } if matches!(**source, UnitError::Ended { .. }) => Some((unit, source)),
            _ => None,
        }
    }
}
