//! The functions of an FMI 3.0 binary this importer calls (and this workspace's extension),
//! resolved by name: those both interfaces share, and those of the interface the FMU is loaded as.

use libloading::Library;

use super::api::{Loaded, table};
use crate::fmi3::ffi::*;

table!(
    /// The functions both interfaces share.
    Common3 {
        get_version: fmi3GetVersionTYPE = "fmi3GetVersion",
        set_debug_logging: fmi3SetDebugLoggingTYPE = "fmi3SetDebugLogging",
        free_instance: fmi3FreeInstanceTYPE = "fmi3FreeInstance",
        enter_initialization_mode: fmi3EnterInitializationModeTYPE = "fmi3EnterInitializationMode",
        exit_initialization_mode: fmi3InstanceOnlyTYPE = "fmi3ExitInitializationMode",
        terminate: fmi3InstanceOnlyTYPE = "fmi3Terminate",
        reset: fmi3InstanceOnlyTYPE = "fmi3Reset",
        get_float64: fmi3GetTYPE<f64> = "fmi3GetFloat64",
        get_int32: fmi3GetTYPE<i32> = "fmi3GetInt32",
        get_boolean: fmi3GetTYPE<fmi3Boolean> = "fmi3GetBoolean",
        get_string: fmi3GetTYPE<fmi3String> = "fmi3GetString",
        set_float64: fmi3SetTYPE<f64> = "fmi3SetFloat64",
        set_int32: fmi3SetTYPE<i32> = "fmi3SetInt32",
        set_boolean: fmi3SetTYPE<fmi3Boolean> = "fmi3SetBoolean",
        set_string: fmi3SetTYPE<fmi3String> = "fmi3SetString",
        get_fmu_state: fmi3GetFMUStateTYPE = "fmi3GetFMUState",
        set_fmu_state: fmi3SetFMUStateTYPE = "fmi3SetFMUState",
        free_fmu_state: fmi3GetFMUStateTYPE = "fmi3FreeFMUState",
        serialized_fmu_state_size: fmi3SerializedFMUStateSizeTYPE = "fmi3SerializedFMUStateSize",
        serialize_fmu_state: fmi3SerializeFMUStateTYPE = "fmi3SerializeFMUState",
        deserialize_fmu_state: fmi3DeserializeFMUStateTYPE = "fmi3DeserializeFMUState",
        get_directional_derivative: fmi3GetDirectionalDerivativeTYPE = "fmi3GetDirectionalDerivative",
    }
);

table!(
    /// The functions of Co-Simulation.
    Cs3 {
        instantiate: fmi3InstantiateCoSimulationTYPE = "fmi3InstantiateCoSimulation",
        do_step: fmi3DoStepTYPE = "fmi3DoStep",
    }
);

table!(
    /// The functions of Model Exchange.
    Me3 {
        instantiate: fmi3InstantiateModelExchangeTYPE = "fmi3InstantiateModelExchange",
        enter_event_mode: fmi3InstanceOnlyTYPE = "fmi3EnterEventMode",
        update_discrete_states: fmi3UpdateDiscreteStatesTYPE = "fmi3UpdateDiscreteStates",
        enter_continuous_time_mode: fmi3InstanceOnlyTYPE = "fmi3EnterContinuousTimeMode",
        completed_integrator_step: fmi3CompletedIntegratorStepTYPE = "fmi3CompletedIntegratorStep",
        set_time: fmi3SetTimeTYPE = "fmi3SetTime",
        set_continuous_states: fmi3SetContinuousStatesTYPE = "fmi3SetContinuousStates",
        get_derivatives: fmi3GetRealArrayTYPE = "fmi3GetContinuousStateDerivatives",
        get_event_indicators: fmi3GetRealArrayTYPE = "fmi3GetEventIndicators",
        get_continuous_states: fmi3GetRealArrayTYPE = "fmi3GetContinuousStates",
        get_nominals_of_continuous_states: fmi3GetRealArrayTYPE = "fmi3GetNominalsOfContinuousStates",
        get_number_of_event_indicators: fmi3GetCountTYPE = "fmi3GetNumberOfEventIndicators",
        get_number_of_continuous_states: fmi3GetCountTYPE = "fmi3GetNumberOfContinuousStates",
    }
);

/// The FMI 3.0 functions, and the extension `feedsim3GetStepMapDerivative` (with the signature
/// of `fmi3GetDirectionalDerivative`) if the binary exports it.
pub(super) type Api3 = Loaded<Common3, Cs3, Me3, fmi3GetDirectionalDerivativeTYPE>;
