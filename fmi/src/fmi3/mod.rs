//! FMI 3.0 Co-Simulation over the same [`Model`](crate::export::Model) as the FMI 2.0 export:
//! a model exported by [`export_fmu!`](crate::export_fmu) is exported as FMI 3.0 too by
//! [`export_fmu3!`](crate::export_fmu3) in the same shared library (the two versions' symbols
//! differ), and `master package` writes both archives. The importer
//! ([`crate::import`]) loads FMUs of either version.
//!
//! * [`layout`]: the model's scalar variables grouped into FMI 3.0 variables (arrays), value
//!   references unique across types;
//! * [`xml`]: FMI 3.0 `modelDescription.xml`, written and read (into the importer's scalar view);
//! * [`export`]: the C functions' bodies; [`ffi`]: the C types.

pub mod export;
pub mod ffi;
pub mod layout;
pub mod xml;

use crate::description::{ModelDescription, ModelInfo};
use crate::package::PackageError;

/// The platform folder of FMI 3.0 binaries this build produces.
pub(crate) const PLATFORM: &str = "x86_64-linux";

/// Where the importer's view of an FMU's FMI 3.0 description differs from what the model
/// declares (value references and descriptions aside, which FMI 3.0 gives per array), or `None`.
/// An output's dependencies may be wider in the view: FMI 3.0 lists them per array.
pub fn view_differs(declared: &ModelDescription, view: &ModelDescription) -> Option<String> {
    let read: Vec<_> = view.variables.iter().filter(|v| v.causality != crate::Causality::Independent).collect();
    if read.len() != declared.variables.len() {
        return Some(format!("{} variables read back, {} declared", read.len(), declared.variables.len()));
    }
    let covers = |wide: &Option<Vec<String>>, narrow: &Option<Vec<String>>| match (wide, narrow) {
        (None, _) => true,
        (Some(_), None) => false,
        (Some(w), Some(n)) => n.iter().all(|x| w.contains(x)),
    };
    for (r, d) in read.iter().zip(&declared.variables) {
        let same = (&r.name, r.var_type, r.causality, r.variability, r.initial, &r.start, &r.unit, r.min, r.max)
            == (&d.name, d.var_type, d.causality, d.variability, d.initial, &d.start, &d.unit, d.min, d.max);
        if !same || !covers(&r.depends_on, &d.depends_on) || !covers(&r.initial_depends_on, &d.initial_depends_on) {
            return Some(format!("variable `{}` reads back different", d.name));
        }
    }
    let flags = (
        view.flags.can_get_and_set_fmu_state,
        view.flags.can_serialize_fmu_state,
        view.flags.provides_directional_derivative,
        view.flags.provides_step_map_derivative,
    );
    let declared_flags = (
        declared.flags.can_get_and_set_fmu_state,
        declared.flags.can_serialize_fmu_state,
        declared.flags.provides_directional_derivative,
        declared.flags.provides_step_map_derivative,
    );
    if flags != declared_flags
        || (&view.model_identifier, &view.guid, &view.units)
            != (&declared.model_identifier, &declared.guid, &declared.units)
    {
        return Some("the identity, capabilities or units read back different".into());
    }
    None
}

/// The FMI 3.0 `modelDescription.xml` of a description, validated, and only if the importer
/// reads it back as the model declares it.
pub fn checked_xml3(description: &ModelDescription) -> Result<String, PackageError> {
    let identifier = description.model_identifier.clone();
    let invalid = |source| PackageError::Description { identifier: identifier.clone(), source };
    let declared = ModelInfo::new(description.clone()).map_err(invalid)?.description;
    let layout = layout::Layout3::new(&declared).map_err(invalid)?;
    let text = xml::model_description_xml3(&declared, &layout);
    let round_trip = |why: String| PackageError::RoundTrip { identifier: identifier.clone(), why };
    let read = xml::parse_model_description3(&text).map_err(|e| round_trip(e.to_string()))?;
    match view_differs(&declared, &read.view) {
        None => Ok(text),
        Some(why) => Err(round_trip(why)),
    }
}

/// Exports a [`Model`](crate::export::Model) as the C functions of an FMI 3.0 Co-Simulation
/// FMU (every function `fmi3Functions.h` declares) and the extension
/// `feedsim3GetStepMapDerivative`. Invoke once, in a `cdylib` crate, beside
/// [`export_fmu!`](crate::export_fmu): `fmi::export_fmu3!(my_crate::MyModel);`.
///
/// Every function forwards to the layer; its safety contract is the importer's duty under
/// FMI 3.0 (an instance from `fmi3InstantiateCoSimulation` of this binary and not yet freed,
/// used by one thread at a time; arrays of the lengths passed with them; NUL-terminated strings).
#[macro_export]
macro_rules! export_fmu3 {
    ($model:ty) => {
        const _: () = {
            use $crate::fmi3::export as e3;
            use $crate::export::exported as e;
            use $crate::fmi3::ffi::*;
            use ::std::ffi::{c_char, c_int};
            type M = $model;
            type I = fmi3Instance;
            type VR = *const fmi3ValueReference;
            static INFO: e3::InfoCell3 = e3::InfoCell3::new();

            #[unsafe(no_mangle)]
            pub extern "C" fn fmi3GetVersion() -> *const c_char {
                e3::version()
            }
            $crate::exports! { "3.0", "fmi::export_fmu3!";
                fn fmi3SetDebugLogging(c: I, on: fmi3Boolean, n: usize, cats: *const fmi3String) -> fmi3Status {
                    e3::set_debug_logging::<M>(c, on, n, cats)
                }
                fn fmi3InstantiateModelExchange(
                    name: fmi3String, token: fmi3String, resources: fmi3String, _visible: fmi3Boolean,
                    logging_on: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback,
                ) -> I {
                    let interface = e3::Instance3::ModelExchange;
                    e3::instantiate::<M>(&INFO, interface, name, token, resources, logging_on, env, log)
                }
                fn fmi3InstantiateCoSimulation(
                    name: fmi3String, token: fmi3String, resources: fmi3String, _visible: fmi3Boolean,
                    logging_on: fmi3Boolean, event_mode_used: fmi3Boolean, early_return_allowed: fmi3Boolean,
                    _required: VR, _n_required: usize, env: fmi3InstanceEnvironment,
                    log: fmi3LogMessageCallback, _intermediate: fmi3IntermediateUpdateCallback,
                ) -> I {
                    let interface = e3::Instance3::CoSimulation { event_mode_used, early_return_allowed };
                    e3::instantiate::<M>(&INFO, interface, name, token, resources, logging_on, env, log)
                }
                fn fmi3FreeInstance(c: I) {
                    e::free_instance::<M>(c)
                }
                fn fmi3EnterInitializationMode(
                    c: I, tol_defined: fmi3Boolean, tol: f64, start: f64, stop_defined: fmi3Boolean, stop: f64,
                ) -> fmi3Status {
                    e3::enter_initialization_mode::<M>(c, tol_defined, tol, start, stop_defined, stop)
                }
                fn fmi3ExitInitializationMode(c: I) -> fmi3Status {
                    e::exit_initialization_mode::<M>("fmi3ExitInitializationMode", c)
                }
                fn fmi3Terminate(c: I) -> fmi3Status {
                    e::terminate::<M>("fmi3Terminate", c)
                }
                fn fmi3Reset(c: I) -> fmi3Status {
                    e::reset::<M>("fmi3Reset", c)
                }
                fn fmi3GetBinary(
                    c: I, vr: VR, n: usize, _sizes: *mut usize, _v: *mut *const u8, _nv: usize,
                ) -> fmi3Status {
                    e3::no_variables::<M>(c, "fmi3GetBinary", vr, n)
                }
                fn fmi3SetBinary(
                    c: I, vr: VR, n: usize, _sizes: *const usize, _v: *const *const u8, _nv: usize,
                ) -> fmi3Status {
                    e3::no_variables::<M>(c, "fmi3SetBinary", vr, n)
                }
                fn fmi3GetClock(c: I, vr: VR, n: usize, _v: *mut fmi3Boolean) -> fmi3Status {
                    e3::no_variables::<M>(c, "fmi3GetClock", vr, n)
                }
                fn fmi3SetClock(c: I, vr: VR, n: usize, _v: *const fmi3Boolean) -> fmi3Status {
                    e3::no_variables::<M>(c, "fmi3SetClock", vr, n)
                }
                fn fmi3GetFMUState(c: I, s: *mut fmi3FMUState) -> fmi3Status {
                    e::get_fmu_state::<M>("fmi3GetFMUState", c, s)
                }
                fn fmi3SetFMUState(c: I, s: fmi3FMUState) -> fmi3Status {
                    e::set_fmu_state::<M>("fmi3SetFMUState", c, s)
                }
                fn fmi3FreeFMUState(c: I, s: *mut fmi3FMUState) -> fmi3Status {
                    e::free_fmu_state::<M>("fmi3FreeFMUState", c, s)
                }
                fn fmi3SerializedFMUStateSize(c: I, s: fmi3FMUState, size: *mut usize) -> fmi3Status {
                    e::serialized_fmu_state_size::<M>("fmi3SerializedFMUStateSize", c, s, size)
                }
                fn fmi3SerializeFMUState(c: I, s: fmi3FMUState, bytes: *mut fmi3Byte, size: usize) -> fmi3Status {
                    e::serialize_fmu_state::<M>("fmi3SerializeFMUState", c, s, bytes.cast(), size)
                }
                fn fmi3DeserializeFMUState(
                    c: I, bytes: *const fmi3Byte, size: usize, s: *mut fmi3FMUState,
                ) -> fmi3Status {
                    e::deserialize_fmu_state::<M>("fmi3DeserializeFMUState", c, bytes.cast(), size, s)
                }
                fn fmi3GetDirectionalDerivative(
                    c: I, u: VR, nu: usize, k: VR, nk: usize, seed: *const f64, ns: usize, out: *mut f64, no: usize,
                ) -> fmi3Status {
                    e3::derivative::<M>(c, $crate::export::Derivative::Instant, u, nu, k, nk, seed, ns, out, no)
                }
                /// The opt-in extension of this workspace (the step map's derivative, see
                /// `fmi::export::Derivative::StepMap`) with the signature of
                /// fmi3GetDirectionalDerivative; exported always, announced in modelDescription.xml
                /// only when the model provides it.
                fn feedsim3GetStepMapDerivative(
                    c: I, u: VR, nu: usize, k: VR, nk: usize, seed: *const f64, ns: usize, out: *mut f64, no: usize,
                ) -> fmi3Status {
                    e3::derivative::<M>(c, $crate::export::Derivative::StepMap, u, nu, k, nk, seed, ns, out, no)
                }
                fn fmi3DoStep(
                    c: I, t: f64, h: f64, no_prior: fmi3Boolean, event: *mut fmi3Boolean, terminate: *mut fmi3Boolean,
                    early: *mut fmi3Boolean, last: *mut f64,
                ) -> fmi3Status {
                    e3::do_step::<M>(c, t, h, no_prior, event, terminate, early, last)
                }
                fn fmi3EnterEventMode(c: I) -> fmi3Status {
                    $crate::export::me::enter_event_mode::<M>(c, "fmi3EnterEventMode")
                }
                fn fmi3EnterContinuousTimeMode(c: I) -> fmi3Status {
                    $crate::export::me::enter_continuous_time_mode::<M>(c, "fmi3EnterContinuousTimeMode")
                }
                fn fmi3CompletedIntegratorStep(
                    c: I, _no_prior: fmi3Boolean, event: *mut fmi3Boolean, terminate: *mut fmi3Boolean,
                ) -> fmi3Status {
                    $crate::export::me::completed_integrator_step::<M, fmi3Boolean>(
                        c, "fmi3CompletedIntegratorStep", event, terminate,
                    )
                }
                fn fmi3SetTime(c: I, t: f64) -> fmi3Status {
                    $crate::export::me::set_time::<M>(c, "fmi3SetTime", t)
                }
                fn fmi3SetContinuousStates(c: I, x: *const f64, n: usize) -> fmi3Status {
                    $crate::export::me::set_continuous_states::<M>(c, "fmi3SetContinuousStates", x, n)
                }
                fn fmi3GetContinuousStateDerivatives(c: I, x: *mut f64, n: usize) -> fmi3Status {
                    let which = $crate::export::me::Which::Derivatives;
                    $crate::export::me::get_reals::<M>(c, "fmi3GetContinuousStateDerivatives", which, x, n)
                }
                fn fmi3GetEventIndicators(c: I, z: *mut f64, n: usize) -> fmi3Status {
                    $crate::export::me::event_indicators::<M>(c, "fmi3GetEventIndicators", z, n)
                }
                fn fmi3GetContinuousStates(c: I, x: *mut f64, n: usize) -> fmi3Status {
                    let which = $crate::export::me::Which::States;
                    $crate::export::me::get_reals::<M>(c, "fmi3GetContinuousStates", which, x, n)
                }
                fn fmi3GetNominalsOfContinuousStates(c: I, x: *mut f64, n: usize) -> fmi3Status {
                    $crate::export::me::nominals::<M>(c, "fmi3GetNominalsOfContinuousStates", x, n)
                }
                fn fmi3GetNumberOfEventIndicators(c: I, n: *mut usize) -> fmi3Status {
                    $crate::export::me::number_of_event_indicators::<M>(c, "fmi3GetNumberOfEventIndicators", n)
                }
                fn fmi3GetNumberOfContinuousStates(c: I, n: *mut usize) -> fmi3Status {
                    $crate::export::me::number_of_states::<M>(c, "fmi3GetNumberOfContinuousStates", n)
                }
            }
            #[unsafe(no_mangle)]
            pub extern "C" fn fmi3InstantiateScheduledExecution(
                _name: fmi3String, _token: fmi3String, _resources: fmi3String, _visible: fmi3Boolean,
                _logging_on: fmi3Boolean, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback,
                _clock_update: *const ::std::ffi::c_void, _lock: *const ::std::ffi::c_void,
                _unlock: *const ::std::ffi::c_void,
            ) -> I {
                e3::instantiate_other("fmi3InstantiateScheduledExecution", env, log)
            }
            $crate::fmi3_values! {
                fmi3GetFloat64(*mut f64) => get_float64, fmi3GetInt32(*mut i32) => get_int32,
                fmi3GetBoolean(*mut fmi3Boolean) => get_boolean, fmi3GetString(*mut fmi3String) => get_string,
                fmi3SetFloat64(*const f64) => set_float64, fmi3SetInt32(*const i32) => set_int32,
                fmi3SetBoolean(*const fmi3Boolean) => set_boolean, fmi3SetString(*const fmi3String) => set_string,
            }
            $crate::fmi3_no_variables! {
                fmi3GetFloat32(*mut f32), fmi3GetInt8(*mut i8), fmi3GetUInt8(*mut u8), fmi3GetInt16(*mut i16),
                fmi3GetUInt16(*mut u16), fmi3GetUInt32(*mut u32), fmi3GetInt64(*mut i64), fmi3GetUInt64(*mut u64),
                fmi3SetFloat32(*const f32), fmi3SetInt8(*const i8), fmi3SetUInt8(*const u8), fmi3SetInt16(*const i16),
                fmi3SetUInt16(*const u16), fmi3SetUInt32(*const u32), fmi3SetInt64(*const i64), fmi3SetUInt64(*const u64),
            }
            /// # Safety
            /// The importer's obligations under FMI 3.0 (see [`fmi::export_fmu3!`]).
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
                c: I, again: *mut fmi3Boolean, terminate: *mut fmi3Boolean, nominals: *mut fmi3Boolean,
                values: *mut fmi3Boolean, next_defined: *mut fmi3Boolean, next: *mut f64,
            ) -> fmi3Status {
                let report = |u: &$crate::export::DiscreteUpdate| -> Result<(), String> {
                    let outs = [again, terminate, nominals, values, next_defined];
                    if outs.iter().any(|p| p.is_null()) || next.is_null() {
                        return Err("an output argument is a null pointer".into());
                    }
                    let flags = [u.again, u.terminate.is_some(), false, u.states_changed, u.next_event_time.is_some()];
                    for (p, f) in outs.into_iter().zip(flags) {
                        // SAFETY: non-null and writable (the importer's obligation).
                        unsafe { p.write(u8::from(f)) };
                    }
                    // SAFETY: as above.
                    unsafe { next.write(u.next_event_time.unwrap_or(0.0)) };
                    Ok(())
                };
                // SAFETY: the importer's FMI 3.0 obligations (see the macro) are the callee's contract.
                unsafe { $crate::export::me::update_discrete_states::<M>(c, "fmi3UpdateDiscreteStates", report) }
            }
            $crate::fmi3_unsupported! {
                "this FMU has no event mode in Co-Simulation (hasEventMode = false)" => {
                    fmi3EnterStepMode(), fmi3EvaluateDiscreteStates(),
                }
                "per-element dependencies are not provided (providesPerElementDependencies = false)" => {
                    fmi3GetNumberOfVariableDependencies(_vr: fmi3ValueReference, _n: *mut usize),
                    fmi3GetVariableDependencies(_vr: fmi3ValueReference, _ei: *mut usize, _vrs: *mut fmi3ValueReference,
                        _eis: *mut usize, _kinds: *mut c_int, _n: usize),
                }
                "adjoint derivatives are not provided (providesAdjointDerivatives = false)" => {
                    fmi3GetAdjointDerivative(_u: VR, _nu: usize, _k: VR, _nk: usize, _s: *const f64, _ns: usize,
                        _o: *mut f64, _no: usize),
                }
                "this FMU has no structural parameters (no configuration mode)" => {
                    fmi3EnterConfigurationMode(), fmi3ExitConfigurationMode(),
                }
                "this FMU has no clocks" => {
                    fmi3GetIntervalDecimal(_vr: VR, _n: usize, _i: *mut f64, _q: *mut c_int),
                    fmi3GetIntervalFraction(_vr: VR, _n: usize, _counters: *mut u64, _r: *mut u64, _q: *mut c_int),
                    fmi3GetShiftDecimal(_vr: VR, _n: usize, _s: *mut f64),
                    fmi3GetShiftFraction(_vr: VR, _n: usize, _counters: *mut u64, _r: *mut u64),
                    fmi3SetIntervalDecimal(_vr: VR, _n: usize, _i: *const f64),
                    fmi3SetIntervalFraction(_vr: VR, _n: usize, _counters: *const u64, _r: *const u64),
                    fmi3SetShiftDecimal(_vr: VR, _n: usize, _s: *const f64),
                    fmi3SetShiftFraction(_vr: VR, _n: usize, _counters: *const u64, _r: *const u64),
                }
                "output derivatives are not provided (maxOutputDerivativeOrder = 0)" => {
                    fmi3GetOutputDerivatives(_vr: VR, _n: usize, _o: *const i32, _v: *mut f64, _nv: usize),
                }
                "this FMU implements Co-Simulation only (no Scheduled Execution)" => {
                    fmi3ActivateModelPartition(_clock: fmi3ValueReference, _t: f64),
                }
            }
        };
    };
}

/// Inside [`export_fmu3!`]: `fmi3Get`/`fmi3Set` of the types the FMU has variables of, each
/// forwarded to the layer's function of its type.
#[doc(hidden)]
#[macro_export]
macro_rules! fmi3_values {
    ($($name:ident($values:ty) => $f:ident),* $(,)?) => {
        $crate::exports! { "3.0", "fmi::export_fmu3!"; $(
            fn $name(c: I, vr: VR, n: usize, v: $values, nv: usize) -> fmi3Status {
                e3::$f::<M>(c, vr, n, v, nv)
            }
        )* }
    };
}

/// Inside [`export_fmu3!`]: `fmi3Get`/`fmi3Set` of types the FMU has no variables of.
#[doc(hidden)]
#[macro_export]
macro_rules! fmi3_no_variables {
    ($($name:ident($values:ty)),* $(,)?) => {
        $crate::exports! { "3.0", "fmi::export_fmu3!"; $(
            fn $name(c: I, vr: VR, n: usize, _v: $values, _nv: usize) -> fmi3Status {
                e3::no_variables::<M>(c, stringify!($name), vr, n)
            }
        )* }
    };
}

/// Inside [`export_fmu3!`]: functions of interface types and capabilities the FMU does not
/// have, each returning `fmi3Error` with the reason.
#[doc(hidden)]
#[macro_export]
macro_rules! fmi3_unsupported {
    ($($why:literal => { $($name:ident($($arg:ident: $ty:ty),* $(,)?)),* $(,)? })*) => {
        $crate::exports! { "3.0", "fmi::export_fmu3!"; $($(
            fn $name(c: I, $($arg: $ty),*) -> fmi3Status {
                e3::unsupported::<M>(c, stringify!($name), $why)
            }
        )*)* }
    };
}
