//! The functions of an FMI 3.0 binary this importer calls (and this workspace's extension),
//! resolved by name: those both interfaces share, and those of the interface the FMU is loaded as.

use std::path::Path;

use libloading::Library;

use super::Interface;
use super::api::table;
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

/// The resolved functions, valid while `_lib` is loaded (an `Api3` is dropped, and the library
/// unloaded, only with the last handle to its FMU, which every instance holds).
pub(super) struct Api3 {
    pub(super) common: Common3,
    /// The interface's own functions: exactly one is `Some`.
    pub(super) cs: Option<Cs3>,
    pub(super) me: Option<Me3>,
    /// This workspace's extension `feedsim3GetStepMapDerivative`, if the binary exports it.
    pub(super) step_map_derivative: Option<fmi3GetDirectionalDerivativeTYPE>,
    _lib: Library,
}

impl std::ops::Deref for Api3 {
    type Target = Common3;
    fn deref(&self) -> &Common3 {
        &self.common
    }
}

impl Api3 {
    /// # Safety
    /// `path` is an FMI 3.0 binary of the interface for this platform: loading runs its
    /// initializers, and each symbol must have the standard's signature
    /// (`feedsim3GetStepMapDerivative` that of `fmi3GetDirectionalDerivative`), which nothing in
    /// the file can prove.
    pub(super) unsafe fn load(path: &Path, interface: Interface) -> Result<Api3, String> {
        // SAFETY: running the initializers of an FMU binary is what the caller accepts.
        let lib = unsafe { Library::new(path) }.map_err(|e| format!("cannot load the binary: {e}"))?;
        // SAFETY: the caller's promise; the tables are kept beside `lib` in the same `Api3`.
        let common = unsafe { Common3::resolve(&lib) }?;
        let (cs, me) = match interface {
            // SAFETY: as above.
            Interface::CoSimulation => (Some(unsafe { Cs3::resolve(&lib) }?), None),
            // SAFETY: as above.
            Interface::ModelExchange => (None, Some(unsafe { Me3::resolve(&lib) }?)),
        };
        let step_map_derivative =
            // SAFETY: as above; the extension has the signature of fmi3GetDirectionalDerivative.
            unsafe { lib.get::<fmi3GetDirectionalDerivativeTYPE>(b"feedsim3GetStepMapDerivative") }.ok().map(|f| *f);
        Ok(Api3 { common, cs, me, step_map_derivative, _lib: lib })
    }
}
