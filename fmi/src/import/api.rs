//! The functions of an FMI 2.0 binary (and this workspace's extension), resolved by name: those
//! both interfaces share, and those of the interface the FMU is loaded as.

use std::path::Path;

use libloading::Library;

use super::Interface;
use crate::ffi::*;

/// A table of functions resolved from a library by name.
pub(super) trait Table: Sized {
    /// # Safety
    /// Each symbol of the table that `lib` exports has the standard's signature, and the
    /// pointers are used only while `lib` is loaded.
    unsafe fn resolve(lib: &Library) -> Result<Self, String>;
}

/// Declares a [`Table`]: each field a function, resolved by the symbol named after it.
macro_rules! table {
    ($(#[$doc:meta])* $name:ident { $($field:ident: $ty:ty = $sym:literal,)* }) => {
        $(#[$doc])*
        pub(super) struct $name {
            $(pub(super) $field: $ty,)*
        }

        impl super::api::Table for $name {
            unsafe fn resolve(lib: &Library) -> Result<$name, String> {
                $(
                    // SAFETY: the caller's promise on the symbol's type and the library's life.
                    let $field = *unsafe { lib.get::<$ty>($sym) }
                        .map_err(|e| format!("the binary does not export `{}`: {}", $sym, super::host::reason(&e)))?;
                )*
                Ok($name { $($field,)* })
            }
        }
    };
}
pub(super) use table;

table!(
    /// The functions both interfaces share.
    Common {
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
        get_real: fmi2GetTYPE<fmi2Real> = "fmi2GetReal",
        get_integer: fmi2GetTYPE<fmi2Integer> = "fmi2GetInteger",
        get_boolean: fmi2GetTYPE<fmi2Boolean> = "fmi2GetBoolean",
        get_string: fmi2GetTYPE<fmi2String> = "fmi2GetString",
        set_real: fmi2SetTYPE<fmi2Real> = "fmi2SetReal",
        set_integer: fmi2SetTYPE<fmi2Integer> = "fmi2SetInteger",
        set_boolean: fmi2SetTYPE<fmi2Boolean> = "fmi2SetBoolean",
        set_string: fmi2SetTYPE<fmi2String> = "fmi2SetString",
        get_fmu_state: fmi2GetFMUstateTYPE = "fmi2GetFMUstate",
        set_fmu_state: fmi2SetFMUstateTYPE = "fmi2SetFMUstate",
        free_fmu_state: fmi2FreeFMUstateTYPE = "fmi2FreeFMUstate",
        serialized_fmu_state_size: fmi2SerializedFMUstateSizeTYPE = "fmi2SerializedFMUstateSize",
        serialize_fmu_state: fmi2SerializeFMUstateTYPE = "fmi2SerializeFMUstate",
        deserialize_fmu_state: fmi2DeSerializeFMUstateTYPE = "fmi2DeSerializeFMUstate",
        get_directional_derivative: fmi2GetDirectionalDerivativeTYPE = "fmi2GetDirectionalDerivative",
    }
);

table!(
    /// The functions of Co-Simulation.
    Cs {
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
);

table!(
    /// The functions of Model Exchange.
    Me {
        enter_event_mode: fmi2ComponentOnlyTYPE = "fmi2EnterEventMode",
        new_discrete_states: fmi2NewDiscreteStatesTYPE = "fmi2NewDiscreteStates",
        enter_continuous_time_mode: fmi2ComponentOnlyTYPE = "fmi2EnterContinuousTimeMode",
        completed_integrator_step: fmi2CompletedIntegratorStepTYPE = "fmi2CompletedIntegratorStep",
        set_time: fmi2SetTimeTYPE = "fmi2SetTime",
        set_continuous_states: fmi2SetContinuousStatesTYPE = "fmi2SetContinuousStates",
        get_derivatives: fmi2GetRealArrayTYPE = "fmi2GetDerivatives",
        get_event_indicators: fmi2GetRealArrayTYPE = "fmi2GetEventIndicators",
        get_continuous_states: fmi2GetRealArrayTYPE = "fmi2GetContinuousStates",
        get_nominals_of_continuous_states: fmi2GetRealArrayTYPE = "fmi2GetNominalsOfContinuousStates",
    }
);

/// The FMI 2.0 functions, and the extension `feedsimGetStepMapDerivative` (with the signature of
/// `fmi2GetDirectionalDerivative`) if the binary exports it.
pub(super) type Api = Loaded<Common, Cs, Me, fmi2GetDirectionalDerivativeTYPE>;

/// The resolved functions of a binary, of either version: the tables `C` (common), `Cs`, `Me`
/// and the extension's function `X`. They stay valid while `_lib` is loaded: a `Loaded` is
/// dropped (and the library unloaded) only with the last handle to its FMU, which every instance
/// holds.
pub(super) struct Loaded<C, Cs, Me, X> {
    pub(super) common: C,
    /// The interface's own functions: exactly one is `Some`.
    pub(super) cs: Option<Cs>,
    pub(super) me: Option<Me>,
    /// This workspace's extension, if the binary exports it.
    pub(super) step_map_derivative: Option<X>,
    _lib: Library,
}

impl<C, Cs, Me, X> std::ops::Deref for Loaded<C, Cs, Me, X> {
    type Target = C;
    fn deref(&self) -> &C {
        &self.common
    }
}

impl<C: Table, Cs: Table, Me: Table, X: Copy> Loaded<C, Cs, Me, X> {
    /// # Safety
    /// `path` is a binary of the tables' FMI version and of the interface for this platform:
    /// loading runs its initializers, and each symbol must have the standard's signature
    /// (`extension`, the name of this workspace's extension, that of `X`), which nothing in the
    /// file can prove.
    pub(super) unsafe fn load(path: &Path, interface: Interface, extension: &[u8]) -> Result<Self, String> {
        // SAFETY: running the initializers of an FMU binary is what the caller accepts.
        let lib = unsafe { super::host::load(path) }?;
        // SAFETY: the caller's promise; the tables are kept beside `lib` in the same `Loaded`.
        let common = unsafe { C::resolve(&lib) }?;
        let (cs, me) = match interface {
            // SAFETY: as above.
            Interface::CoSimulation => (Some(unsafe { Cs::resolve(&lib) }?), None),
            // SAFETY: as above.
            Interface::ModelExchange => (None, Some(unsafe { Me::resolve(&lib) }?)),
        };
        // SAFETY: as above; the caller's promise on the extension's type.
        let step_map_derivative = unsafe { lib.get::<X>(extension) }.ok().map(|f| *f);
        Ok(Loaded { common, cs, me, step_map_derivative, _lib: lib })
    }
}
