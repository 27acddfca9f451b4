//! The functions of an FMI 3.0 Co-Simulation binary this importer calls (and this workspace's
//! extension), resolved by name.

use std::path::Path;

use libloading::Library;

use crate::fmi3::ffi::*;

macro_rules! api3_table {
    ($($field:ident: $ty:ty = $sym:literal,)*) => {
        /// The resolved functions, valid while `_lib` is loaded (an `Api3` is dropped, and the
        /// library unloaded, only with the last handle to its FMU, which every instance holds).
        pub(super) struct Api3 {
            $(pub(super) $field: $ty,)*
            /// This workspace's extension `feedsim3GetStepMapDerivative`, if the binary exports it.
            pub(super) step_map_derivative: Option<fmi3GetDirectionalDerivativeTYPE>,
            _lib: Library,
        }

        impl Api3 {
            /// # Safety
            /// `path` is an FMI 3.0 binary for this platform: loading runs its initializers, and
            /// each symbol of the table must have the standard's signature
            /// (`feedsim3GetStepMapDerivative` that of `fmi3GetDirectionalDerivative`), which
            /// nothing in the file can prove.
            pub(super) unsafe fn load(path: &Path) -> Result<Api3, String> {
                // SAFETY: running the initializers of an FMU binary is what the caller accepts.
                let lib = unsafe { Library::new(path) }.map_err(|e| format!("cannot load the binary: {e}"))?;
                $(
                    // SAFETY: the symbol has the standard's type (the caller's promise), and the
                    // pointer is kept beside `lib` in the same `Api3`.
                    let $field = *unsafe { lib.get::<$ty>($sym) }
                        .map_err(|e| format!("the binary does not export `{}`: {e}", $sym))?;
                )*
                let step_map_derivative =
                    // SAFETY: as above; the extension has the signature of fmi3GetDirectionalDerivative.
                    unsafe { lib.get::<fmi3GetDirectionalDerivativeTYPE>(b"feedsim3GetStepMapDerivative") }.ok().map(|f| *f);
                Ok(Api3 { $($field,)* step_map_derivative, _lib: lib })
            }
        }
    };
}

api3_table! {
    get_version: fmi3GetVersionTYPE = "fmi3GetVersion",
    set_debug_logging: fmi3SetDebugLoggingTYPE = "fmi3SetDebugLogging",
    instantiate: fmi3InstantiateCoSimulationTYPE = "fmi3InstantiateCoSimulation",
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
    do_step: fmi3DoStepTYPE = "fmi3DoStep",
}
