//! The 34 functions of an FMU binary (and this workspace's extension), resolved by name.

use std::path::Path;

use libloading::Library;

use crate::ffi::*;

macro_rules! api_table {
    ($($field:ident: $ty:ty = $sym:literal,)*) => {
        /// The resolved functions. They stay valid while `_lib` is loaded: an `Api` is dropped
        /// (and the library unloaded) only with the last handle to its FMU, which every
        /// instance holds.
        pub(super) struct Api {
            $(pub(super) $field: $ty,)*
            /// This workspace's extension, if the binary exports it.
            pub(super) step_map_derivative: Option<fmi2GetDirectionalDerivativeTYPE>,
            _lib: Library,
        }

        impl Api {
            /// # Safety
            /// `path` is an FMI 2.0 Co-Simulation binary for this platform: loading runs its
            /// initializers, and each symbol of the table must have the standard's signature
            /// (`feedsimGetStepMapDerivative` that of `fmi2GetDirectionalDerivative`), which
            /// nothing in the file can prove.
            pub(super) unsafe fn load(path: &Path) -> Result<Api, String> {
                // SAFETY: running the initializers of an FMU binary is what the caller accepts.
                let lib = unsafe { Library::new(path) }.map_err(|e| format!("cannot load the binary: {e}"))?;
                $(
                    // SAFETY: the symbol has the standard's type (the caller's promise), and the
                    // pointer is kept beside `lib` in the same `Api`.
                    let $field = *unsafe { lib.get::<$ty>($sym) }
                        .map_err(|e| format!("the binary does not export `{}`: {e}", $sym))?;
                )*
                let step_map_derivative =
                    // SAFETY: as above; the extension has the signature of fmi2GetDirectionalDerivative.
                    unsafe { lib.get::<fmi2GetDirectionalDerivativeTYPE>(b"feedsimGetStepMapDerivative") }.ok().map(|f| *f);
                Ok(Api { $($field,)* step_map_derivative, _lib: lib })
            }
        }
    };
}

api_table! {
    get_types_platform: fmi2GetTypesPlatformTYPE = "fmi2GetTypesPlatform",
    get_version: fmi2GetVersionTYPE = "fmi2GetVersion",
    set_debug_logging: fmi2SetDebugLoggingTYPE = "fmi2SetDebugLogging",
    instantiate: fmi2InstantiateTYPE = "fmi2Instantiate",
    free_instance: fmi2FreeInstanceTYPE = "fmi2FreeInstance",
    setup_experiment: fmi2SetupExperimentTYPE = "fmi2SetupExperiment",
    enter_initialization_mode: fmi2ComponentOnlyTYPE = "fmi2EnterInitializationMode",
    exit_initialization_mode: fmi2ComponentOnlyTYPE = "fmi2ExitInitializationMode",
    terminate: fmi2ComponentOnlyTYPE = "fmi2Terminate",
    reset: fmi2ComponentOnlyTYPE = "fmi2Reset",
    get_real: fmi2GetRealTYPE = "fmi2GetReal",
    get_integer: fmi2GetIntegerTYPE = "fmi2GetInteger",
    get_boolean: fmi2GetBooleanTYPE = "fmi2GetBoolean",
    get_string: fmi2GetStringTYPE = "fmi2GetString",
    set_real: fmi2SetRealTYPE = "fmi2SetReal",
    set_integer: fmi2SetIntegerTYPE = "fmi2SetInteger",
    set_boolean: fmi2SetBooleanTYPE = "fmi2SetBoolean",
    set_string: fmi2SetStringTYPE = "fmi2SetString",
    get_fmu_state: fmi2GetFMUstateTYPE = "fmi2GetFMUstate",
    set_fmu_state: fmi2SetFMUstateTYPE = "fmi2SetFMUstate",
    free_fmu_state: fmi2FreeFMUstateTYPE = "fmi2FreeFMUstate",
    serialized_fmu_state_size: fmi2SerializedFMUstateSizeTYPE = "fmi2SerializedFMUstateSize",
    serialize_fmu_state: fmi2SerializeFMUstateTYPE = "fmi2SerializeFMUstate",
    deserialize_fmu_state: fmi2DeSerializeFMUstateTYPE = "fmi2DeSerializeFMUstate",
    get_directional_derivative: fmi2GetDirectionalDerivativeTYPE = "fmi2GetDirectionalDerivative",
    set_real_input_derivatives: fmi2SetRealInputDerivativesTYPE = "fmi2SetRealInputDerivatives",
    get_real_output_derivatives: fmi2GetRealOutputDerivativesTYPE = "fmi2GetRealOutputDerivatives",
    do_step: fmi2DoStepTYPE = "fmi2DoStep",
    cancel_step: fmi2ComponentOnlyTYPE = "fmi2CancelStep",
    // Not called (no asynchronous steps), resolved so that a binary without them is refused at
    // load, as fmpy and OMSimulator refuse it.
    _get_status: fmi2GetStatusTYPE = "fmi2GetStatus",
    get_real_status: fmi2GetRealStatusTYPE = "fmi2GetRealStatus",
    _get_integer_status: fmi2GetIntegerStatusTYPE = "fmi2GetIntegerStatus",
    get_boolean_status: fmi2GetBooleanStatusTYPE = "fmi2GetBooleanStatus",
    _get_string_status: fmi2GetStringStatusTYPE = "fmi2GetStringStatus",
}
