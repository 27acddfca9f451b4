//! Exporting a Rust model as an FMI 2.0 Co-Simulation FMU.
//!
//! A model implements [`Model`] (physics only); `fmi::export_fmu!(MyModel);` in a cdylib crate
//! exports the 34 `fmi2*` functions. The layer owns everything the standard asks of an FMU: the
//! state machine, value-reference/causality/NaN checks, logging, panic containment, FMU states
//! and their serialization, and communication-time bookkeeping.
//!
//! No panic crosses the C ABI: every exported function runs its work inside `catch_unwind`
//! (a panic makes the instance fatal and is logged), so the cdylib must be built with
//! `panic = "unwind"` (Cargo's default). An allocation failure aborts regardless: a model
//! refuses what would not fit before allocating it.

#[doc(hidden)]
pub mod exported;
pub(crate) mod instance;
#[doc(hidden)]
pub mod me;
mod state;

use std::path::Path;

pub use state::Reals;

/// A file shipped in the FMU's `resources/` directory.
#[derive(Clone, Debug, PartialEq)]
pub struct Resource {
    /// Path below `resources/`, `/`-separated (e.g. `lt50m_C.toml`).
    pub name: String,
    pub bytes: Vec<u8>,
}

impl Resource {
    /// Text files given as (name, text), e.g. the scenes a model ships.
    pub fn texts(files: &[(&str, &str)]) -> Vec<Resource> {
        files.iter().map(|(n, t)| Resource { name: (*n).to_owned(), bytes: t.as_bytes().to_vec() }).collect()
    }
}

/// What a model's callbacks return on failure: any error (a `thiserror` enum of the model, or
/// a plain message through `.into()`); the layer logs it with its source chain, the function
/// and the variable.
pub type ModelError = Box<dyn std::error::Error + Send + Sync>;

/// How a step ended.
#[derive(Clone, Debug, PartialEq)]
pub enum StepOutcome {
    /// The model reached `t + h`.
    Complete,
    /// The model stopped at `time` (≤ `t + h`) and cannot go on (it has reached its end, e.g. a
    /// counter that has counted down): `fmi2DoStep` returns `fmi2Discard`,
    /// `fmi2GetBooleanStatus(fmi2Terminated)` answers true and
    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)` answers `time`; the getters show the state
    /// at `time`.
    Terminated { time: f64, reason: String },
}

/// What an update of a Model Exchange model's discrete states at an event did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DiscreteUpdate {
    /// Another update is needed at the same instant.
    pub again: bool,
    /// The model ends the simulation, and why.
    pub terminate: Option<String>,
    /// The continuous states jumped.
    pub states_changed: bool,
    /// The next time event.
    pub next_event_time: Option<f64>,
}

/// Which derivative [`Model::derivative`] is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Derivative {
    /// `fmi2GetDirectionalDerivative` as FMI 2.0 defines it: at the current instant — what
    /// `fmi2GetReal` of the unknowns would do if the knowns were changed by `fmi2SetReal` now,
    /// without a step (only with `provides_directional_derivative`).
    Instant,
    /// The extension `feedsimGetStepMapDerivative`: of the step map, the unknowns after the last
    /// `do_step` with respect to the input values held during it (only with
    /// `provides_step_map_derivative`).
    StepMap,
}

/// The arguments of a derivative call: `out[i] = Σ_j ∂unknowns[i]/∂knowns[j] · seed[j]`.
/// Unknowns are Real outputs/locals/calculated parameters, knowns Real inputs or parameters;
/// parameters with a zero seed are removed by the layer.
#[derive(Clone, Copy, Debug)]
pub struct Seeds<'a> {
    pub unknowns: &'a [u32],
    pub knowns: &'a [u32],
    pub seed: &'a [f64],
}

/// What a model implements. The layer has already checked the value reference (it exists and has
/// the right type), the causality/variability against the current state, and that Reals are
/// finite; the model only does physics and its own range checks. The layer adds the function and
/// variable names to the errors.
pub trait Model: Sized + Send + 'static {
    /// The model's part of a saved FMU state: everything `do_step` and the getters read, so that
    /// a rollback is bit for bit. One type both ways: the layer serializes it (postcard), so save
    /// and restore cannot disagree. `'a` borrows from the model when saving and from the
    /// serialized bytes when restoring (e.g. `&'a str`, `Cow<'a, [f64]>`).
    type State<'a>: serde::Serialize + serde::Deserialize<'a>
    where
        Self: 'a;

    /// Static description; `modelDescription.xml` is generated from it.
    fn description() -> Result<crate::description::ModelDescription, ModelError>;

    /// Files for the FMU's `resources/` directory (e.g. the default scene).
    fn resources() -> Vec<Resource> {
        Vec::new()
    }

    /// A new instance with every variable at its start value. `resources`: the unpacked
    /// `resources/` directory, `None` if the importer gave no location.
    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError>;

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError>;
    /// `&mut`: outputs may be computed lazily. Must work in initialization mode (calculated
    /// outputs from the current parameters and inputs). A non-finite value is reported by the
    /// layer as an error naming the variable and the time.
    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError>;
    /// The Reals `vrs` (value references the layer has checked) into `out`, for one
    /// `fmi2GetReal`: by default one [`Model::get_real`] each. A model whose outputs come from
    /// one computation overrides it to make that once. An error names the position of the
    /// variable it concerns.
    fn get_reals(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), (usize, ModelError)> {
        for (k, (&vr, o)) in vrs.iter().zip(out.iter_mut()).enumerate() {
            *o = self.get_real(vr).map_err(|e| (k, e))?;
        }
        Ok(())
    }
    fn set_integer(&mut self, _vr: u32, _value: i32) -> Result<(), ModelError> {
        Err("the model has no settable Integer variables".into())
    }
    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Err("the model has no Integer variables".into())
    }
    fn set_boolean(&mut self, _vr: u32, _value: bool) -> Result<(), ModelError> {
        Err("the model has no settable Boolean variables".into())
    }
    fn get_boolean(&mut self, _vr: u32) -> Result<bool, ModelError> {
        Err("the model has no Boolean variables".into())
    }
    /// The string is the importer's copy; keep it (e.g. a scene path, relative to `resources/`).
    fn set_string(&mut self, _vr: u32, _value: &str) -> Result<(), ModelError> {
        Err("the model has no settable String variables".into())
    }
    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Err("the model has no String variables".into())
    }

    /// Leaving initialization mode: fixed parameters are final from here on, and the state must
    /// be consistent with the inputs held now.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError>;

    /// Asked right after a successful [`Model::exit_initialization`]: what the importer gave that
    /// is probably not what it meant (e.g. inputs left at start values that do not fit the chosen
    /// parameters). The layer logs it under `logWarning` and `fmi2ExitInitializationMode` returns
    /// `fmi2Warning`; the run goes on.
    fn initialization_warning(&mut self) -> Option<String> {
        None
    }

    /// Advance from `t` to `t + h` with the inputs currently set (and their derivatives, if the
    /// model interpolates inputs). `t` is the importer's communication point, already checked
    /// against the instance's own time.
    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError>;

    /// First-order derivative of a Real input at the current communication point (only with
    /// `can_interpolate_inputs`; the layer rejects other orders). Convention of this workspace:
    /// the input is `u(t) + u̇ (τ − t)` during the next `do_step` only; the model clears `u̇`
    /// after that step, so a master that wants extrapolation sets it before every step.
    fn set_real_input_derivative(&mut self, _vr: u32, _value: f64) -> Result<(), ModelError> {
        Err("input derivatives are not supported".into())
    }

    /// Directional derivatives (see [`Derivative`] for which); called only for what the
    /// description's flags announce.
    fn derivative(&mut self, _kind: Derivative, _at: Seeds<'_>, _out: &mut [f64]) -> Result<(), ModelError> {
        Err("directional derivatives are not provided".into())
    }

    /// Model Exchange (a model whose description has `model_exchange`): sets the continuous
    /// states, in the order of `ModelExchange::states` (the layer has checked their number and
    /// that they are finite). Their values and the derivatives are read through
    /// [`Model::get_real`] of the states' and derivatives' value references.
    fn set_continuous_states(&mut self, _x: &[f64]) -> Result<(), ModelError> {
        Err("the model has no Model Exchange interface".into())
    }

    /// Model Exchange: the time the continuous states and inputs belong to.
    fn set_time(&mut self, _t: f64) -> Result<(), ModelError> {
        Ok(())
    }

    /// Model Exchange: the event indicators now (as many as the description declares).
    fn event_indicators(&mut self, _z: &mut [f64]) -> Result<(), ModelError> {
        Err("the model has no event indicators".into())
    }

    /// Model Exchange: the discrete states updated at an event at `t` (after initialization, a
    /// time event, a state event or a step event).
    fn update_discrete_states(&mut self, _t: f64) -> Result<DiscreteUpdate, ModelError> {
        Ok(DiscreteUpdate::default())
    }

    /// Model Exchange in FMI 3.0: the number of continuous states the model reports now, given
    /// the declared one (which a model that keeps to the standard answers).
    fn reported_state_count(&self, declared: usize) -> usize {
        declared
    }

    /// The complete model state now (see [`Model::State`]).
    fn save(&mut self) -> Result<Self::State<'_>, ModelError>;
    /// Restore a state made by [`Model::save`] of this model (possibly by another instance).
    fn restore(&mut self, state: Self::State<'_>) -> Result<(), ModelError>;

    /// A state for `fmi2GetFMUstate` kept in memory rather than as the bytes of [`Model::save`]:
    /// into `saved` (what this model put there at the last save into the same FMU state, to
    /// reuse), returning `true`; the default keeps the bytes (`false`). Worth it where a state
    /// holds large parts that rarely change, which the saved states can then share instead of
    /// copying. The layer writes the bytes only when an importer serializes the state (by
    /// restoring it, saving it and restoring the instance's own state).
    fn save_in_memory(&mut self, _saved: &mut Option<Box<dyn std::any::Any + Send>>) -> Result<bool, ModelError> {
        Ok(false)
    }

    /// Restores a state kept by [`Model::save_in_memory`] of this model.
    fn restore_in_memory(&mut self, _saved: &(dyn std::any::Any + Send)) -> Result<(), ModelError> {
        Err("this model keeps no state in memory".into())
    }

    /// In process: [`Derivative::Instant`] with the arguments of `fmi2GetDirectionalDerivative`.
    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.derivative(Derivative::Instant, Seeds { unknowns, knowns, seed }, out)
    }

    /// In process: [`Derivative::StepMap`] with the arguments of `fmi2GetDirectionalDerivative`.
    fn step_map_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.derivative(Derivative::StepMap, Seeds { unknowns, knowns, seed }, out)
    }

    /// In process: appends the model's state to `out` in the bytes the FMU's saved states hold.
    fn save_state(&mut self, out: &mut Vec<u8>) -> Result<(), ModelError> {
        Ok(state::append(&self.save()?, out)?)
    }

    /// In process: restores a state from the bytes [`Model::save_state`] wrote, refusing
    /// anything else (truncated, padded, of another model).
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError> {
        let state = state::decode_all::<Self::State<'_>>(bytes)?;
        self.restore(state)
    }
}

/// The log categories every exported FMU declares (name, description).
pub(crate) const LOG_CATEGORIES: [(&str, &str); 4] = [
    (
        "logError",
        "Errors: calls in the wrong state, unknown value references, invalid values, model failures; and why a step was discarded",
    ),
    (
        "logWarning",
        "Warnings: the run goes on, but what the importer gave is probably not what it meant (e.g. inputs left at start values that do not fit the chosen scene)",
    ),
    ("logInfo", "Informational messages: instantiation, mode changes"),
    ("logAll", "All of the above"),
];

/// Inside [`export_fmu!`] and [`export_fmu3!`](crate::export_fmu3): each function exported under
/// its name as an `unsafe extern "C"` function whose safety contract is the importer's duty under
/// FMI `$version` (as the export macro `$see` says), its body the layer's function it calls.
#[doc(hidden)]
#[macro_export]
macro_rules! exports {
    ($version:literal, $see:literal; $(
        $(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? { $($body:tt)* }
    )*) => {$(
        $(#[$doc])*
        /// # Safety
        #[doc = concat!("The importer's obligations under FMI ", $version, " (see [`", $see, "`]).")]
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name($($arg: $ty),*) $(-> $ret)? {
            // SAFETY: the importer's obligations (see the export macro) are the callee's contract.
            unsafe { $($body)* }
        }
    )*};
}

/// Inside [`export_fmu!`]: `fmi2Get*`/`fmi2Set*` of each type, forwarded to the layer's function
/// of that type.
#[doc(hidden)]
#[macro_export]
macro_rules! fmi2_values {
    ($($name:ident($values:ty) => $f:ident),* $(,)?) => {
        $crate::exports! { "2.0", "fmi::export_fmu!"; $(
            fn $name(c: fmi2Component, vr: *const u32, n: usize, v: $values) -> fmi2Status {
                e::$f::<M>(c, vr, n, v)
            }
        )* }
    };
}

/// Exports a [`Model`] as the 34 `fmi2*` C functions of an FMI 2.0 Co-Simulation FMU, and the
/// extension `feedsimGetStepMapDerivative`. Invoke once, in a `cdylib` crate:
/// `fmi::export_fmu!(my_crate::MyModel);`.
///
/// Every function forwards to the layer; its safety contract is the importer's duty under
/// FMI 2.0 (a component from `fmi2Instantiate` of this binary and not yet freed, used by one
/// thread at a time; arrays of the lengths passed with them; NUL-terminated strings).
#[macro_export]
macro_rules! export_fmu {
    ($model:ty) => {
        const _: () = {
            use $crate::export::exported as e;
            use $crate::ffi::*;
            type M = $model;
            static INFO: e::InfoCell = e::InfoCell::new();

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::ffi::c_char {
                e::types_platform()
            }
            #[unsafe(no_mangle)]
            pub extern "C" fn fmi2GetVersion() -> *const ::std::ffi::c_char {
                e::version()
            }
            $crate::exports! { "2.0", "fmi::export_fmu!";
                fn fmi2SetDebugLogging(
                    c: fmi2Component, on: fmi2Boolean, n: usize, cats: *const fmi2String,
                ) -> fmi2Status {
                    e::set_debug_logging::<M>("fmi2SetDebugLogging", c, on, n, cats)
                }
                fn fmi2Instantiate(
                    name: fmi2String, kind: fmi2Type, guid: fmi2String, resources: fmi2String,
                    functions: *const fmi2CallbackFunctions, visible: fmi2Boolean, logging_on: fmi2Boolean,
                ) -> fmi2Component {
                    e::instantiate::<M>(&INFO, name, kind, guid, resources, functions, visible, logging_on)
                }
                fn fmi2FreeInstance(c: fmi2Component) {
                    e::free_instance::<M>(c)
                }
                fn fmi2SetupExperiment(
                    c: fmi2Component, tol_defined: fmi2Boolean, tol: f64, start: f64, stop_defined: fmi2Boolean,
                    stop: f64,
                ) -> fmi2Status {
                    e::setup_experiment::<M>(c, tol_defined, tol, start, stop_defined, stop)
                }
                fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
                    e::enter_initialization_mode::<M>(c)
                }
                fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
                    e::exit_initialization_mode::<M>("fmi2ExitInitializationMode", c)
                }
                fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
                    e::terminate::<M>("fmi2Terminate", c)
                }
                fn fmi2Reset(c: fmi2Component) -> fmi2Status {
                    e::reset::<M>("fmi2Reset", c)
                }
                fn fmi2GetFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
                    e::get_fmu_state::<M>("fmi2GetFMUstate", c, s)
                }
                fn fmi2SetFMUstate(c: fmi2Component, s: fmi2FMUstate) -> fmi2Status {
                    e::set_fmu_state::<M>("fmi2SetFMUstate", c, s)
                }
                fn fmi2FreeFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
                    e::free_fmu_state::<M>("fmi2FreeFMUstate", c, s)
                }
                fn fmi2SerializedFMUstateSize(c: fmi2Component, s: fmi2FMUstate, size: *mut usize) -> fmi2Status {
                    e::serialized_fmu_state_size::<M>("fmi2SerializedFMUstateSize", c, s, size)
                }
                fn fmi2SerializeFMUstate(
                    c: fmi2Component, s: fmi2FMUstate, bytes: *mut fmi2Byte, size: usize,
                ) -> fmi2Status {
                    e::serialize_fmu_state::<M>("fmi2SerializeFMUstate", c, s, bytes, size)
                }
                fn fmi2DeSerializeFMUstate(
                    c: fmi2Component, bytes: *const fmi2Byte, size: usize, s: *mut fmi2FMUstate,
                ) -> fmi2Status {
                    e::deserialize_fmu_state::<M>("fmi2DeSerializeFMUstate", c, bytes, size, s)
                }
                fn fmi2GetDirectionalDerivative(
                    c: fmi2Component, vu: *const u32, nu: usize, vk: *const u32, nk: usize, dvk: *const f64,
                    dvu: *mut f64,
                ) -> fmi2Status {
                    e::derivative::<M>(c, $crate::export::Derivative::Instant, vu, nu, vk, nk, dvk, dvu)
                }
                /// The opt-in extension of this workspace (see `fmi::export::Derivative::StepMap`);
                /// exported always, announced in modelDescription.xml only when the model provides it.
                fn feedsimGetStepMapDerivative(
                    c: fmi2Component, vu: *const u32, nu: usize, vk: *const u32, nk: usize, dvk: *const f64,
                    dvu: *mut f64,
                ) -> fmi2Status {
                    e::derivative::<M>(c, $crate::export::Derivative::StepMap, vu, nu, vk, nk, dvk, dvu)
                }
                fn fmi2SetRealInputDerivatives(
                    c: fmi2Component, vr: *const u32, n: usize, order: *const i32, v: *const f64,
                ) -> fmi2Status {
                    e::set_real_input_derivatives::<M>(c, vr, n, order, v)
                }
                fn fmi2GetRealOutputDerivatives(
                    c: fmi2Component, vr: *const u32, n: usize, order: *const i32, v: *mut f64,
                ) -> fmi2Status {
                    e::get_real_output_derivatives::<M>(c, vr, n, order, v)
                }
                fn fmi2DoStep(c: fmi2Component, t: f64, h: f64, no_prior: fmi2Boolean) -> fmi2Status {
                    e::do_step::<M>(c, t, h, no_prior)
                }
                fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
                    e::cancel_step::<M>(c)
                }
                fn fmi2GetStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2Status) -> fmi2Status {
                    e::get_status::<M>(c, s, v)
                }
                fn fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut f64) -> fmi2Status {
                    e::get_real_status::<M>(c, s, v)
                }
                fn fmi2GetIntegerStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut i32) -> fmi2Status {
                    e::get_integer_status::<M>(c, s, v)
                }
                fn fmi2GetBooleanStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut i32) -> fmi2Status {
                    e::get_boolean_status::<M>(c, s, v)
                }
                fn fmi2GetStringStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut fmi2String) -> fmi2Status {
                    e::get_string_status::<M>(c, s, v)
                }
                // Model Exchange (refused unless the description offers it and the instance is of it)
                fn fmi2EnterEventMode(c: fmi2Component) -> fmi2Status {
                    $crate::export::me::enter_event_mode::<M>(c, "fmi2EnterEventMode")
                }
                fn fmi2EnterContinuousTimeMode(c: fmi2Component) -> fmi2Status {
                    $crate::export::me::enter_continuous_time_mode::<M>(c, "fmi2EnterContinuousTimeMode")
                }
                fn fmi2CompletedIntegratorStep(
                    c: fmi2Component, _no_prior: fmi2Boolean, enter_event_mode: *mut fmi2Boolean,
                    terminate: *mut fmi2Boolean,
                ) -> fmi2Status {
                    let (name, event) = ("fmi2CompletedIntegratorStep", enter_event_mode);
                    $crate::export::me::completed_integrator_step::<M, fmi2Boolean>(c, name, event, terminate)
                }
                fn fmi2SetTime(c: fmi2Component, t: f64) -> fmi2Status {
                    $crate::export::me::set_time::<M>(c, "fmi2SetTime", t)
                }
                fn fmi2SetContinuousStates(c: fmi2Component, x: *const f64, n: usize) -> fmi2Status {
                    $crate::export::me::set_continuous_states::<M>(c, "fmi2SetContinuousStates", x, n)
                }
                fn fmi2GetDerivatives(c: fmi2Component, x: *mut f64, n: usize) -> fmi2Status {
                    let which = $crate::export::me::Which::Derivatives;
                    $crate::export::me::get_reals::<M>(c, "fmi2GetDerivatives", which, x, n)
                }
                fn fmi2GetEventIndicators(c: fmi2Component, z: *mut f64, n: usize) -> fmi2Status {
                    $crate::export::me::event_indicators::<M>(c, "fmi2GetEventIndicators", z, n)
                }
                fn fmi2GetContinuousStates(c: fmi2Component, x: *mut f64, n: usize) -> fmi2Status {
                    let which = $crate::export::me::Which::States;
                    $crate::export::me::get_reals::<M>(c, "fmi2GetContinuousStates", which, x, n)
                }
                fn fmi2GetNominalsOfContinuousStates(c: fmi2Component, x: *mut f64, n: usize) -> fmi2Status {
                    $crate::export::me::nominals::<M>(c, "fmi2GetNominalsOfContinuousStates", x, n)
                }
            }
            $crate::fmi2_values! {
                fmi2GetReal(*mut f64) => get_real, fmi2GetInteger(*mut i32) => get_integer,
                fmi2GetBoolean(*mut i32) => get_boolean, fmi2GetString(*mut fmi2String) => get_string,
                fmi2SetReal(*const f64) => set_real, fmi2SetInteger(*const i32) => set_integer,
                fmi2SetBoolean(*const i32) => set_boolean, fmi2SetString(*const fmi2String) => set_string,
            }
            // Not in `exports!`: the closure holds an unsafe block of its own.
            /// # Safety
            /// The importer's obligations under FMI 2.0 (see [`fmi::export_fmu!`]).
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(c: fmi2Component, info: *mut fmi2EventInfo) -> fmi2Status {
                let report = |u: &$crate::export::DiscreteUpdate| -> Result<(), String> {
                    if info.is_null() {
                        return Err("`fmi2eventInfo` is a null pointer".into());
                    }
                    let flag = |b: bool| if b { fmi2True } else { fmi2False };
                    let out = fmi2EventInfo {
                        newDiscreteStatesNeeded: flag(u.again),
                        terminateSimulation: flag(u.terminate.is_some()),
                        nominalsOfContinuousStatesChanged: fmi2False,
                        valuesOfContinuousStatesChanged: flag(u.states_changed),
                        nextEventTimeDefined: flag(u.next_event_time.is_some()),
                        nextEventTime: u.next_event_time.unwrap_or(0.0),
                    };
                    // SAFETY: non-null and writable (the importer's obligation).
                    unsafe { info.write(out) };
                    Ok(())
                };
                // SAFETY: the importer's FMI 2.0 obligations (see the macro) are the callee's contract.
                unsafe { $crate::export::me::update_discrete_states::<M>(c, "fmi2NewDiscreteStates", report) }
            }
        };
    };
}

#[cfg(test)]
mod tests;
