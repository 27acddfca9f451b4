//! One FMU instance (what `fmi2Component` points to): the model, the FMI 2.0 Co-Simulation
//! state machine around it, and the importer's logger.

use std::ffi::{CStr, CString};
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{Model, ModelError};
use crate::description::{ModelInfo, SetPhase, VarInfo, VarType};
use crate::ffi::*;
use crate::fmi3::ffi::{fmi3InstanceEnvironment, fmi3LogMessageCallback};
use crate::fmi3::layout::Layout3;

/// The phases of the FMI 2.0 Co-Simulation state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum Phase {
    Instantiated,
    InitializationMode,
    StepMode,
    Terminated,
    Error,
    Fatal,
    /// `fmi2DoStep` returned `fmi2Discard` (the model stopped early): values and statuses can be
    /// read, the state can be set back; no further step.
    StepFailed,
    /// Model Exchange: at an event (discrete states updated) and between events.
    EventMode,
    ContinuousTime,
}

impl Phase {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "instantiated",
            Phase::InitializationMode => "initialization mode",
            Phase::StepMode => "step mode",
            Phase::Terminated => "terminated",
            Phase::Error => "error",
            Phase::Fatal => "fatal",
            Phase::StepFailed => "step failed (discarded)",
            Phase::EventMode => "event mode",
            Phase::ContinuousTime => "continuous-time mode",
        }
    }

    /// The phase whose rules `fmi2Set*` follows.
    pub(crate) fn set_phase(self) -> SetPhase {
        match self {
            Phase::Instantiated => SetPhase::Instantiated,
            Phase::InitializationMode => SetPhase::InitializationMode,
            _ => SetPhase::StepMode,
        }
    }
}

/// Where an instance's messages go: the importer's callback, as its FMI version defines it.
#[derive(Clone, Copy)]
pub(crate) enum Logger {
    /// printf-style (variadic), with the instance name.
    Fmi2(fmi2CallbackLogger, fmi2ComponentEnvironment),
    /// Plain text.
    Fmi3(fmi3LogMessageCallback, fmi3InstanceEnvironment),
}

/// What an instance exported as FMI 3.0 holds besides: its variables, the importer's choice
/// of early return, and buffers reused by every call.
pub(crate) struct V3 {
    pub(crate) layout: &'static Layout3,
    pub(crate) early_return_allowed: bool,
    /// The model's value references of one call's elements (a derivative's unknowns).
    pub(crate) scalars: Vec<u32>,
    /// A derivative's knowns; the Float64 elements the model answers for one `fmi3GetFloat64`.
    pub(crate) knowns: Vec<u32>,
    pub(crate) reals: Vec<f64>,
}

/// What an instance of Model Exchange holds besides: the value references of its states and
/// their derivatives, in state order, and reused buffers.
pub(crate) struct MeInstance {
    pub(crate) states: Vec<u32>,
    pub(crate) derivatives: Vec<u32>,
    pub(crate) event_indicators: usize,
}

impl MeInstance {
    pub(crate) fn of(info: &ModelInfo) -> Option<MeInstance> {
        let me = info.description.model_exchange.as_ref()?;
        Some(MeInstance {
            states: me.states.iter().map(|s| s.state).collect(),
            derivatives: me.states.iter().map(|s| s.derivative).collect(),
            event_indicators: me.event_indicators,
        })
    }
}

/// One FMU instance.
pub(crate) struct Instance<M: Model> {
    pub(crate) info: &'static ModelInfo,
    pub(crate) name: CString,
    pub(crate) resources: Option<PathBuf>,
    pub(crate) logger: Logger,
    /// `Some` for an instance of the FMI 3.0 export.
    pub(crate) v3: Option<V3>,
    /// `Some` for an instance of Model Exchange.
    pub(crate) me: Option<MeInstance>,
    pub(crate) log_errors: bool,
    /// On unless the importer switches `logWarning` off: a warning is meant to be seen.
    pub(crate) log_warnings: bool,
    pub(crate) log_info: bool,
    pub(crate) phase: Phase,
    pub(crate) time: f64,
    pub(crate) start_time: f64,
    pub(crate) stop_time: Option<f64>,
    /// The model ended the simulation (a step returned [`super::StepOutcome::Terminated`]).
    pub(crate) terminated: bool,
    pub(crate) model: M,
    /// Strings handed out by `fmi2GetString`; valid until the next `fmi2GetString`.
    pub(crate) strings: Vec<CString>,
    /// Reused by the derivative calls (no allocation per call).
    pub(crate) scratch_knowns: Vec<u32>,
    pub(crate) scratch_seed: Vec<f64>,
}

impl<M: Model> Instance<M> {
    /// A new instance of `model`, in the instantiated state, its instantiation logged; the
    /// FMI 3.0 part for an instance of that export.
    pub(crate) fn new(
        info: &'static ModelInfo,
        name: CString,
        resources: Option<PathBuf>,
        logger: Logger,
        v3: Option<V3>,
        log_info: bool,
        model: M,
    ) -> Instance<M> {
        let inst = Instance {
            info,
            name,
            resources,
            logger,
            v3,
            me: None,
            log_errors: true,
            log_warnings: true,
            log_info,
            phase: Phase::Instantiated,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            terminated: false,
            model,
            strings: Vec::new(),
            scratch_knowns: Vec::new(),
            scratch_seed: Vec::new(),
        };
        let resources = &inst.resources;
        inst.log(fmi2OK, &format!("instantiated `{}` (resources: {resources:?})", info.description.model_name));
        inst
    }

    pub(crate) fn log(&self, status: fmi2Status, message: &str) {
        // A discarded step is reported like an error: the importer must learn why the model ended.
        let (category, enabled) = match status {
            s if s >= fmi2Discard => ("logError", self.log_errors),
            s if s == fmi2Warning => ("logWarning", self.log_warnings),
            _ => ("logInfo", self.log_info),
        };
        if enabled {
            log_to(self.logger, &self.name, status, category, message);
        }
    }

    /// Runs `body` if the call is allowed in the current phase; an `Err` puts the instance in the
    /// error state (as the standard says) with the message logged under the function's name.
    /// Panics are the caller's to contain.
    pub(crate) fn run(
        &mut self,
        func: &str,
        allowed: &[Phase],
        body: impl FnOnce(&mut Self) -> Result<fmi2Status, String>,
    ) -> fmi2Status {
        if !allowed.contains(&self.phase) {
            if self.phase == Phase::Fatal {
                let free = if self.v3.is_some() { "fmi3FreeInstance" } else { "fmi2FreeInstance" };
                let message = format!("{func}: the instance is in the fatal state; only {free} is allowed");
                self.log(fmi2Fatal, &message);
                return fmi2Fatal;
            }
            self.log(fmi2Error, &format!("{func}: not allowed in state `{}`", self.phase.name()));
            self.phase = Phase::Error;
            return fmi2Error;
        }
        match body(self) {
            Ok(status) => status,
            Err(message) => {
                self.phase = Phase::Error;
                self.log(fmi2Error, &format!("{func}: {message}"));
                fmi2Error
            }
        }
    }

    /// The variable of this type with this value reference, or an error naming both.
    pub(crate) fn find(&self, t: VarType, vr: u32) -> Result<&'static VarInfo, String> {
        let info: &'static ModelInfo = self.info;
        info.lookup(t, vr).ok_or_else(|| format!("unknown value reference {vr} (no {} variable has it)", t.as_str()))
    }
}

/// `` `name` (causality, variability) ``, for messages.
pub(crate) fn describe(v: &VarInfo) -> String {
    format!("`{}` ({}, {})", v.var.name, v.var.causality.as_str(), v.var.variability.as_str())
}

/// Calls the importer's logger; for FMI 2.0's printf-style one `message` is the format, its
/// `%` escaped.
pub(crate) fn log_to(logger: Logger, name: &CStr, status: fmi2Status, category: &str, message: &str) {
    let cat = CString::new(category).unwrap_or_default();
    match logger {
        Logger::Fmi2(Some(logger), env) => {
            let text = CString::new(message.replace('%', "%%").replace('\0', "")).unwrap_or_default();
            // SAFETY: `logger` is the function the importer gave in fmi2CallbackFunctions, which
            // FMI 2.0 requires to stay callable while the instance lives, with its own
            // environment pointer; the three strings are NUL-terminated and outlive the call;
            // `text` has no conversion specifier left (every `%` is doubled), so no variadic
            // argument is read.
            unsafe { logger(env, name.as_ptr(), status, cat.as_ptr(), text.as_ptr()) };
        }
        Logger::Fmi3(Some(logger), env) => {
            let text = CString::new(message.replace('\0', "")).unwrap_or_default();
            // SAFETY: `logger` is the importer's logMessage of fmi3InstantiateCoSimulation,
            // callable while the instance lives (FMI 3.0), with its instanceEnvironment; both
            // strings are NUL-terminated and outlive the call.
            unsafe { logger(env, status, cat.as_ptr(), text.as_ptr()) };
        }
        Logger::Fmi2(None, _) | Logger::Fmi3(None, _) => {}
    }
}

/// Model errors as the layer's messages.
pub(crate) trait Msg<T> {
    fn msg(self) -> Result<T, String>;
}

impl<T> Msg<T> for Result<T, ModelError> {
    fn msg(self) -> Result<T, String> {
        self.map_err(|e| error_chain(&*e))
    }
}

/// An error with its chain of sources, `a: b: c`.
pub(crate) fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}

pub(crate) fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_owned()
    }
}
