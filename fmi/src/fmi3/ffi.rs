//! The C types of the FMI 3.0 standard (`fmi3PlatformTypes.h`, `fmi3FunctionTypes.h`) that this
//! workspace uses: the exporter defines every function the standard declares, the importer calls
//! the Co-Simulation subset.

#![allow(non_camel_case_types, non_upper_case_globals, non_snake_case)]

use std::ffi::{c_char, c_void};

pub type fmi3Instance = *mut c_void;
pub type fmi3InstanceEnvironment = *mut c_void;
pub type fmi3FMUState = *mut c_void;
pub type fmi3ValueReference = u32;
pub type fmi3Float64 = f64;
pub type fmi3Int32 = i32;
/// C `bool`: one byte. Kept as `u8`, so that a foreign caller's byte other than 0 or 1 is
/// read as true instead of being undefined behaviour.
pub type fmi3Boolean = u8;
pub type fmi3String = *const c_char;
pub type fmi3Byte = u8;
/// `fmi3Status` is a C enum (`int`); the values are those of `fmi2Status` without `Pending`.
pub type fmi3Status = std::ffi::c_int;

pub const fmi3True: fmi3Boolean = 1;
pub const fmi3False: fmi3Boolean = 0;

pub const fmi3OK: fmi3Status = 0;
pub const fmi3Warning: fmi3Status = 1;
pub const fmi3Discard: fmi3Status = 2;
pub const fmi3Error: fmi3Status = 3;
pub const fmi3Fatal: fmi3Status = 4;

/// The importer's logger: the message is plain text (not a format string).
pub type fmi3LogMessageCallback =
    Option<unsafe extern "C" fn(fmi3InstanceEnvironment, fmi3Status, fmi3String, fmi3String)>;
/// Not called by this workspace's FMUs (no intermediate update); its type for the signature.
pub type fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        fmi3InstanceEnvironment,
        fmi3Float64,
        fmi3Boolean,
        fmi3Boolean,
        fmi3Boolean,
        fmi3Boolean,
        *mut fmi3Boolean,
        *mut fmi3Float64,
    ),
>;

// Function pointer types of the functions the importer calls (public for tests that call an FMU
// binary directly).
pub type fmi3GetVersionTYPE = unsafe extern "C" fn() -> *const c_char;
pub type fmi3SetDebugLoggingTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3Boolean, usize, *const fmi3String) -> fmi3Status;
pub type fmi3InstantiateCoSimulationTYPE = unsafe extern "C" fn(
    fmi3String,
    fmi3String,
    fmi3String,
    fmi3Boolean,
    fmi3Boolean,
    fmi3Boolean,
    fmi3Boolean,
    *const fmi3ValueReference,
    usize,
    fmi3InstanceEnvironment,
    fmi3LogMessageCallback,
    fmi3IntermediateUpdateCallback,
) -> fmi3Instance;
pub type fmi3FreeInstanceTYPE = unsafe extern "C" fn(fmi3Instance);
pub type fmi3EnterInitializationModeTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3Boolean, fmi3Float64, fmi3Float64, fmi3Boolean, fmi3Float64) -> fmi3Status;
pub type fmi3InstanceOnlyTYPE = unsafe extern "C" fn(fmi3Instance) -> fmi3Status;
pub type fmi3GetTYPE<T> =
    unsafe extern "C" fn(fmi3Instance, *const fmi3ValueReference, usize, *mut T, usize) -> fmi3Status;
pub type fmi3SetTYPE<T> =
    unsafe extern "C" fn(fmi3Instance, *const fmi3ValueReference, usize, *const T, usize) -> fmi3Status;
pub type fmi3GetFMUStateTYPE = unsafe extern "C" fn(fmi3Instance, *mut fmi3FMUState) -> fmi3Status;
pub type fmi3SetFMUStateTYPE = unsafe extern "C" fn(fmi3Instance, fmi3FMUState) -> fmi3Status;
pub type fmi3SerializedFMUStateSizeTYPE = unsafe extern "C" fn(fmi3Instance, fmi3FMUState, *mut usize) -> fmi3Status;
pub type fmi3SerializeFMUStateTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3FMUState, *mut fmi3Byte, usize) -> fmi3Status;
pub type fmi3DeserializeFMUStateTYPE =
    unsafe extern "C" fn(fmi3Instance, *const fmi3Byte, usize, *mut fmi3FMUState) -> fmi3Status;
pub type fmi3GetDirectionalDerivativeTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *const fmi3ValueReference,
    usize,
    *const fmi3ValueReference,
    usize,
    *const fmi3Float64,
    usize,
    *mut fmi3Float64,
    usize,
) -> fmi3Status;
pub type fmi3DoStepTYPE = unsafe extern "C" fn(
    fmi3Instance,
    fmi3Float64,
    fmi3Float64,
    fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Float64,
) -> fmi3Status;

pub type fmi3InstantiateModelExchangeTYPE = unsafe extern "C" fn(
    fmi3String,
    fmi3String,
    fmi3String,
    fmi3Boolean,
    fmi3Boolean,
    fmi3InstanceEnvironment,
    fmi3LogMessageCallback,
) -> fmi3Instance;
/// `fmi3UpdateDiscreteStates(instance, &discreteStatesNeedUpdate, &terminateSimulation,
/// &nominalsOfContinuousStatesChanged, &valuesOfContinuousStatesChanged, &nextEventTimeDefined,
/// &nextEventTime)`.
pub type fmi3UpdateDiscreteStatesTYPE = unsafe extern "C" fn(
    fmi3Instance,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Boolean,
    *mut fmi3Float64,
) -> fmi3Status;
pub type fmi3CompletedIntegratorStepTYPE =
    unsafe extern "C" fn(fmi3Instance, fmi3Boolean, *mut fmi3Boolean, *mut fmi3Boolean) -> fmi3Status;
pub type fmi3SetTimeTYPE = unsafe extern "C" fn(fmi3Instance, fmi3Float64) -> fmi3Status;
pub type fmi3SetContinuousStatesTYPE = unsafe extern "C" fn(fmi3Instance, *const fmi3Float64, usize) -> fmi3Status;
/// `fmi3GetContinuousStateDerivatives`, `fmi3GetEventIndicators`, `fmi3GetContinuousStates`,
/// `fmi3GetNominalsOfContinuousStates`.
pub type fmi3GetRealArrayTYPE = unsafe extern "C" fn(fmi3Instance, *mut fmi3Float64, usize) -> fmi3Status;
/// `fmi3GetNumberOfEventIndicators`, `fmi3GetNumberOfContinuousStates`.
pub type fmi3GetCountTYPE = unsafe extern "C" fn(fmi3Instance, *mut usize) -> fmi3Status;

/// The standard's spelling of a status, e.g. `fmi3Discard`.
pub fn status_name(status: fmi3Status) -> String {
    match status {
        fmi3OK => "fmi3OK".into(),
        fmi3Warning => "fmi3Warning".into(),
        fmi3Discard => "fmi3Discard".into(),
        fmi3Error => "fmi3Error".into(),
        fmi3Fatal => "fmi3Fatal".into(),
        other => format!("invalid status {other}"),
    }
}
