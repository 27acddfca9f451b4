//! Why a run did not give a result.

use cosim::StepError;

/// Why a run did not give a result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Refused before anything was built (steps, caps, memory, what the method needs).
    #[error("the {method} run cannot start: {reason}")]
    Refused { method: &'static str, reason: String },
    /// The model or the FMUs could not be set up (missing FMU, failed form-finding, ...).
    #[error("setting up the {method} run")]
    Setup {
        method: &'static str,
        #[source]
        source: Detached,
    },
    /// A step failed or gave a non-finite value.
    #[error("the {method} run stopped at t = {time:.6} s: {reason}")]
    Stopped { method: &'static str, time: f64, reason: String },
    /// Ctrl-C: the run stopped after the step in hand.
    #[error("the {method} run was interrupted at t = {time:.6} s (Ctrl-C)")]
    Interrupted { method: &'static str, time: f64 },
    /// The results could not be written.
    #[error("writing the results of the {method} run")]
    Output {
        method: &'static str,
        #[source]
        source: std::io::Error,
    },
}

impl RunError {
    /// A co-simulation step that failed: its time and its reason.
    pub fn stopped_by(method: &'static str, e: &StepError) -> RunError {
        RunError::Stopped { method, time: e.time(), reason: e.reason() }
    }

    /// A system that could not be set up.
    pub fn setup(method: &'static str, e: &(dyn std::error::Error + 'static)) -> RunError {
        RunError::Setup { method, source: Detached::of(e) }
    }
}

/// An error's message chain, kept as text so that it can cross threads (`Send + Sync`) whatever
/// the error it came from.
#[derive(Debug)]
pub struct Detached {
    message: String,
    source: Option<Box<Detached>>,
}

impl Detached {
    pub fn of(e: &(dyn std::error::Error + 'static)) -> Detached {
        Detached { message: e.to_string(), source: e.source().map(|s| Box::new(Detached::of(s))) }
    }
}

impl std::fmt::Display for Detached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Detached {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source.as_deref().map(|s| s as _)
    }
}
