//! The C types of the FMI 2.0 standard (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`), shared by
//! the exporter and the importer. Only the Co-Simulation subset (34 functions) is declared.

#![allow(non_camel_case_types, non_upper_case_globals, non_snake_case)]

use std::ffi::{c_char, c_int, c_void};

pub type fmi2Component = *mut c_void;
pub(crate) type fmi2ComponentEnvironment = *mut c_void;
pub type fmi2FMUstate = *mut c_void;
pub(crate) type fmi2ValueReference = u32;
pub type fmi2Real = f64;
pub(crate) type fmi2Integer = c_int;
pub type fmi2Boolean = c_int;
pub type fmi2String = *const c_char;
pub type fmi2Byte = c_char;
/// `fmi2Status`, `fmi2Type` and `fmi2StatusKind` are C enums: `int` on every platform we target.
/// They stay plain integers here because a foreign FMU may return any value.
pub type fmi2Status = c_int;
pub type fmi2Type = c_int;
pub type fmi2StatusKind = c_int;

pub const fmi2True: fmi2Boolean = 1;
pub const fmi2False: fmi2Boolean = 0;

pub(crate) const fmi2OK: fmi2Status = 0;
pub(crate) const fmi2Warning: fmi2Status = 1;
pub const fmi2Discard: fmi2Status = 2;
pub const fmi2Error: fmi2Status = 3;
pub(crate) const fmi2Fatal: fmi2Status = 4;
pub(crate) const fmi2Pending: fmi2Status = 5;

pub const fmi2ModelExchange: fmi2Type = 0;
pub const fmi2CoSimulation: fmi2Type = 1;

pub const fmi2DoStepStatus: fmi2StatusKind = 0;
pub const fmi2PendingStatus: fmi2StatusKind = 1;
pub const fmi2LastSuccessfulTime: fmi2StatusKind = 2;
pub const fmi2Terminated: fmi2StatusKind = 3;

/// The importer's printf-style logger. Variadic: stable Rust can call it but not define it.
pub(crate) type fmi2CallbackLogger =
    Option<unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...)>;
pub(crate) type fmi2CallbackAllocateMemory = Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>;
pub(crate) type fmi2CallbackFreeMemory = Option<unsafe extern "C" fn(*mut c_void)>;
pub(crate) type fmi2StepFinished = Option<unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2Status)>;

#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct fmi2CallbackFunctions {
    pub logger: fmi2CallbackLogger,
    pub allocateMemory: fmi2CallbackAllocateMemory,
    pub freeMemory: fmi2CallbackFreeMemory,
    pub stepFinished: fmi2StepFinished,
    pub componentEnvironment: fmi2ComponentEnvironment,
}

// Function pointer types of the 34 Co-Simulation functions (the importer resolves them by name).
pub(crate) type fmi2GetTypesPlatformTYPE = unsafe extern "C" fn() -> *const c_char;
pub(crate) type fmi2GetVersionTYPE = unsafe extern "C" fn() -> *const c_char;
pub(crate) type fmi2SetDebugLoggingTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, usize, *const fmi2String) -> fmi2Status;
pub(crate) type fmi2InstantiateTYPE = unsafe extern "C" fn(
    fmi2String,
    fmi2Type,
    fmi2String,
    fmi2String,
    *const fmi2CallbackFunctions,
    fmi2Boolean,
    fmi2Boolean,
) -> fmi2Component;
pub(crate) type fmi2FreeInstanceTYPE = unsafe extern "C" fn(fmi2Component);
pub(crate) type fmi2SetupExperimentTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real) -> fmi2Status;
pub(crate) type fmi2ComponentOnlyTYPE = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
/// `fmi2GetReal`, `fmi2GetInteger`, `fmi2GetBoolean`, `fmi2GetString`: values of C type `T`.
pub(crate) type fmi2GetTYPE<T> =
    unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *mut T) -> fmi2Status;
/// `fmi2SetReal`, `fmi2SetInteger`, `fmi2SetBoolean`, `fmi2SetString`: values of C type `T`.
pub(crate) type fmi2SetTYPE<T> =
    unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *const T) -> fmi2Status;
pub(crate) type fmi2GetFMUstateTYPE = unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status;
pub(crate) type fmi2SetFMUstateTYPE = unsafe extern "C" fn(fmi2Component, fmi2FMUstate) -> fmi2Status;
pub(crate) type fmi2FreeFMUstateTYPE = unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status;
pub(crate) type fmi2SerializedFMUstateSizeTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut usize) -> fmi2Status;
pub(crate) type fmi2SerializeFMUstateTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut fmi2Byte, usize) -> fmi2Status;
pub(crate) type fmi2DeSerializeFMUstateTYPE =
    unsafe extern "C" fn(fmi2Component, *const fmi2Byte, usize, *mut fmi2FMUstate) -> fmi2Status;
pub(crate) type fmi2GetDirectionalDerivativeTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2ValueReference,
    usize,
    *const fmi2Real,
    *mut fmi2Real,
) -> fmi2Status;
pub(crate) type fmi2SetRealInputDerivativesTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Integer,
    *const fmi2Real,
) -> fmi2Status;
pub(crate) type fmi2GetRealOutputDerivativesTYPE = unsafe extern "C" fn(
    fmi2Component,
    *const fmi2ValueReference,
    usize,
    *const fmi2Integer,
    *mut fmi2Real,
) -> fmi2Status;
pub(crate) type fmi2DoStepTYPE = unsafe extern "C" fn(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean) -> fmi2Status;
pub(crate) type fmi2GetStatusTYPE = unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Status) -> fmi2Status;
pub(crate) type fmi2GetRealStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Real) -> fmi2Status;
pub(crate) type fmi2GetIntegerStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Integer) -> fmi2Status;
pub(crate) type fmi2GetBooleanStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2Boolean) -> fmi2Status;
pub(crate) type fmi2GetStringStatusTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut fmi2String) -> fmi2Status;

/// What `fmi2NewDiscreteStates` reports (Model Exchange).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct fmi2EventInfo {
    pub newDiscreteStatesNeeded: fmi2Boolean,
    pub terminateSimulation: fmi2Boolean,
    pub nominalsOfContinuousStatesChanged: fmi2Boolean,
    pub valuesOfContinuousStatesChanged: fmi2Boolean,
    pub nextEventTimeDefined: fmi2Boolean,
    pub nextEventTime: fmi2Real,
}

// The Model Exchange functions.
pub(crate) type fmi2NewDiscreteStatesTYPE = unsafe extern "C" fn(fmi2Component, *mut fmi2EventInfo) -> fmi2Status;
pub(crate) type fmi2CompletedIntegratorStepTYPE =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, *mut fmi2Boolean, *mut fmi2Boolean) -> fmi2Status;
pub(crate) type fmi2SetTimeTYPE = unsafe extern "C" fn(fmi2Component, fmi2Real) -> fmi2Status;
pub(crate) type fmi2SetContinuousStatesTYPE = unsafe extern "C" fn(fmi2Component, *const fmi2Real, usize) -> fmi2Status;
/// `fmi2GetDerivatives`, `fmi2GetEventIndicators`, `fmi2GetContinuousStates`,
/// `fmi2GetNominalsOfContinuousStates`.
pub(crate) type fmi2GetRealArrayTYPE = unsafe extern "C" fn(fmi2Component, *mut fmi2Real, usize) -> fmi2Status;

/// The status an FMI function returned, for the safe API.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok,
    Warning,
    Discard,
    Error,
    Fatal,
    Pending,
}

impl Status {
    /// `None` for a value outside the enum (a broken FMU).
    pub(crate) fn from_raw(raw: fmi2Status) -> Option<Status> {
        Some(match raw {
            fmi2OK => Status::Ok,
            fmi2Warning => Status::Warning,
            fmi2Discard => Status::Discard,
            fmi2Error => Status::Error,
            fmi2Fatal => Status::Fatal,
            fmi2Pending => Status::Pending,
            _ => return None,
        })
    }

    /// The standard's spelling, e.g. `fmi2Error`.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "fmi2OK",
            Status::Warning => "fmi2Warning",
            Status::Discard => "fmi2Discard",
            Status::Error => "fmi2Error",
            Status::Fatal => "fmi2Fatal",
            Status::Pending => "fmi2Pending",
        }
    }
}
