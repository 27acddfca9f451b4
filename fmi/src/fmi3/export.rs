//! The functions the [`export_fmu3!`](crate::export_fmu3) macro forwards to, one per C function
//! of FMI 3.0, over the same [`Model`] and the same instance, state machine and saved states as
//! the FMI 2.0 export. Not for direct use.
//!
//! What differs from FMI 2.0: value references address whole variables (an array's elements
//! are passed together, `nValues` counting them); the independent variable `time` can be read;
//! `fmi3DoStep` reports the model's end through `terminateSimulation` (and `earlyReturn` where
//! the importer allowed it) with `fmi3OK`; there are no input derivatives; every function the
//! standard declares exists, those of other interface types and of capabilities this FMU does
//! not declare return `fmi3Error` with a message saying so.
//!
//! Contract of every `unsafe fn` here, the importer's duty under FMI 3.0: `c` is null or an
//! instance this layer returned from `fmi3InstantiateCoSimulation` for the same `M` and not yet
//! freed, and no other call uses it (or its FMU states) at the same time; every array pointer is
//! null or points to as many aligned, initialized elements (writable for outputs) as the length
//! passed with it; every string is null or NUL-terminated.

use std::ffi::{CStr, CString, c_char, c_int};
use std::path::PathBuf;
use std::sync::OnceLock;

use super::ffi::*;
use super::layout::{Layout3, TIME_VR, Var3};
use crate::description::{DescriptionError, ModelInfo, VarType};
use crate::export::exported::{
    ALL_BUT_FATAL, GETTABLE, SETTABLE, TIME_RTOL, call, contain, derivative_checked, finite, model_info, provided,
    slice, slice_mut, step, string, write,
};
use crate::export::instance::{Instance, Logger, Msg, Phase, V3, describe, log_to};
use crate::export::{Derivative, Model};
use crate::ffi::{fmi2Discard, fmi2Error, fmi2OK, fmi2Status};

/// Where the macro keeps a model's validated description and FMI 3.0 layout for the life of
/// the process (built by the first instantiation, inside its panic guard).
pub type InfoCell3 = OnceLock<Result<(ModelInfo, Layout3), DescriptionError>>;

fn info3<M: Model>() -> Result<(ModelInfo, Layout3), DescriptionError> {
    let info = model_info::<M>()?;
    let layout = Layout3::new(&info.description)?;
    Ok((info, layout))
}

/// The value the model's element list holds for `time` (no model value reference is this large).
const TIME_SCALAR: u32 = u32::MAX;

pub fn version() -> *const c_char {
    c"3.0".as_ptr()
}

/// FMI 3.0 resource paths are native absolute paths (with a trailing separator).
fn resource_path(path: Option<&str>) -> Result<Option<PathBuf>, String> {
    match path.map(str::trim) {
        None | Some("") => Ok(None),
        Some(p) if p.starts_with('/') => Ok(Some(PathBuf::from(p))),
        Some(p) => Err(format!("resourcePath `{p}` is not an absolute path")),
    }
}

/// Which interface an instance is made for: `fmi3InstantiateCoSimulation` (with its flags) or
/// `fmi3InstantiateModelExchange`.
#[derive(Clone, Copy)]
pub enum Instance3 {
    CoSimulation { event_mode_used: fmi3Boolean, early_return_allowed: fmi3Boolean },
    ModelExchange,
}

/// # Safety
/// Strings as in the module's contract; `log` callable with `env` while the instance lives.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate<M: Model>(
    cell: &'static InfoCell3,
    interface: Instance3,
    instance_name: fmi3String,
    token: fmi3String,
    resource_path_text: fmi3String,
    logging_on: fmi3Boolean,
    env: fmi3InstanceEnvironment,
    log: fmi3LogMessageCallback,
) -> fmi3Instance {
    let func = match interface {
        Instance3::CoSimulation { .. } => "fmi3InstantiateCoSimulation",
        Instance3::ModelExchange => "fmi3InstantiateModelExchange",
    };
    let (event_mode_used, early_return_allowed) = match interface {
        Instance3::CoSimulation { event_mode_used, early_return_allowed } => (event_mode_used, early_return_allowed),
        Instance3::ModelExchange => (fmi3False, fmi3False),
    };
    let me = matches!(interface, Instance3::ModelExchange);
    let logger = Logger::Fmi3(log, env);
    // SAFETY: a non-null instance name is NUL-terminated (the contract).
    let name = contain(|| unsafe { string(instance_name) }, |_| None);
    let name_c = CString::new(name.clone().unwrap_or_else(|| "(unnamed)".into())).unwrap_or_default();
    let result = contain(
        || -> Result<fmi3Instance, String> {
            let (info, layout) = cell.get_or_init(info3::<M>).as_ref().map_err(|e| e.to_string())?;
            if name.is_none() {
                return Err("instanceName is a null pointer".into());
            }
            if me && info.description.model_exchange.is_none() {
                return Err("this FMU implements Co-Simulation only (no <ModelExchange>)".into());
            }
            if !me && !info.description.co_simulation {
                return Err("this FMU implements Model Exchange only (no <CoSimulation>)".into());
            }
            if event_mode_used != fmi3False {
                return Err("eventModeUsed = true, but this FMU has no event mode (hasEventMode = false)".into());
            }
            // SAFETY: non-null strings are NUL-terminated (the contract).
            let [token, location] = [token, resource_path_text].map(|s| unsafe { string(s) });
            let token = token.ok_or("instantiationToken is a null pointer")?;
            if token != info.description.guid {
                return Err(format!(
                    "instantiationToken `{token}` does not match this binary's `{}` (modelDescription.xml from another build?)",
                    info.description.guid
                ));
            }
            let resources = resource_path(location.as_deref())?;
            let model = M::instantiate(resources.as_deref()).msg()?;
            let v3 = V3 {
                layout,
                early_return_allowed: early_return_allowed != fmi3False,
                scalars: Vec::new(),
                knowns: Vec::new(),
                reals: Vec::new(),
            };
            let mut inst =
                Instance::new(info, name_c.clone(), resources, logger, Some(v3), logging_on != fmi3False, model);
            inst.me = if me { crate::export::instance::MeInstance::of(info) } else { None };
            Ok(Box::into_raw(Box::new(inst)).cast())
        },
        |panic| Err(format!("internal error (panic): {panic}")),
    );
    result.unwrap_or_else(|msg| {
        let message = format!("{func}: {msg}");
        contain(|| log_to(logger, &name_c, fmi2Error, "logError", &message), drop);
        std::ptr::null_mut()
    })
}

/// `fmi3InstantiateModelExchange` and `fmi3InstantiateScheduledExecution`: logged and refused.
pub fn instantiate_other(func: &str, env: fmi3InstanceEnvironment, log: fmi3LogMessageCallback) -> fmi3Instance {
    let message = format!("{func}: this FMU implements Co-Simulation only (fmi3InstantiateCoSimulation)");
    contain(|| log_to(Logger::Fmi3(log, env), c"", fmi2Error, "logError", &message), drop);
    std::ptr::null_mut()
}

/// # Safety
/// As the module's contract; `categories` holds `n` strings.
pub unsafe fn set_debug_logging<M: Model>(
    c: fmi3Instance,
    logging_on: fmi3Boolean,
    n: usize,
    categories: *const fmi3String,
) -> fmi3Status {
    let on = c_int::from(logging_on != fmi3False);
    // SAFETY: the same contract.
    unsafe { crate::export::exported::set_debug_logging::<M>("fmi3SetDebugLogging", c, on, n, categories) }
}

/// # Safety
/// As the module's contract.
pub unsafe fn enter_initialization_mode<M: Model>(
    c: fmi3Instance,
    _tolerance_defined: fmi3Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: fmi3Boolean,
    stop_time: f64,
) -> fmi3Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, "fmi3EnterInitializationMode", &[Phase::Instantiated], |inst| {
            if !start_time.is_finite() {
                return Err(format!("startTime = {start_time} is not finite"));
            }
            let stop = (stop_time_defined != fmi3False).then_some(stop_time);
            if let Some(s) = stop
                && !(s.is_finite() && s >= start_time)
            {
                return Err(format!("stopTime = {s} must be finite and ≥ startTime = {start_time}"));
            }
            (inst.start_time, inst.stop_time, inst.time) = (start_time, stop, start_time);
            inst.phase = Phase::InitializationMode;
            inst.log(fmi2OK, "entered initialization mode");
            Ok(fmi2OK)
        })
    }
}

/// A function this FMU does not provide: `fmi3Error`, with why in the log.
///
/// # Safety
/// `c` as the module's contract.
pub unsafe fn unsupported<M: Model>(c: fmi3Instance, func: &'static str, why: &'static str) -> fmi3Status {
    // SAFETY: `c` as the contract says.
    unsafe { call::<M>(c, func, ALL_BUT_FATAL, |_| Err(why.to_owned())) }
}

/// `fmi3Get`/`fmi3Set` of a type this FMU has no variables of: fine for no value references,
/// else an error naming the first.
///
/// # Safety
/// As the module's contract; `vrs` holds `n` elements.
pub unsafe fn no_variables<M: Model>(c: fmi3Instance, func: &'static str, vrs: *const u32, n: usize) -> fmi3Status {
    // SAFETY: `c` and the array as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |_| match slice(vrs, n, "valueReferences")?.first() {
            None => Ok(fmi2OK),
            Some(vr) => Err(format!("unknown value reference {vr} (this FMU has no variables of this type)")),
        })
    }
}

/// The FMI 3.0 variable `vr` of type `t`, or an error naming both.
fn var3(layout: &'static Layout3, t: VarType, vr: u32) -> Result<&'static Var3, String> {
    let name = match t {
        VarType::Real => "Float64",
        VarType::Integer => "Int32",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    };
    layout
        .get(vr)
        .filter(|v| v.var_type == t)
        .ok_or_else(|| format!("unknown value reference {vr} (no {name} variable has it)"))
}

/// The elements of `vrs` as the model's value references into `out` ([`TIME_SCALAR`] for
/// `time`), checking that they are `n_values` in all.
fn expand(
    layout: &'static Layout3,
    t: VarType,
    vrs: &[u32],
    n_values: usize,
    out: &mut Vec<u32>,
) -> Result<(), String> {
    out.clear();
    for &vr in vrs {
        let v = var3(layout, t, vr)?;
        if v.is_time() {
            out.push(TIME_SCALAR);
        } else {
            out.extend_from_slice(&v.elements);
        }
    }
    if out.len() != n_values {
        return Err(format!("nValues = {n_values}, but the {} value references hold {} values", vrs.len(), out.len()));
    }
    Ok(())
}

/// `body` on the scalars `vrs` (of type `t`, holding `n_values` values) stand for, expanded into
/// the instance's reused buffer.
fn on_scalars<M: Model>(
    inst: &mut Instance<M>,
    t: VarType,
    vrs: &[u32],
    n_values: usize,
    body: impl FnOnce(&mut Instance<M>, &[u32]) -> Result<fmi2Status, String>,
) -> Result<fmi2Status, String> {
    let mut scalars = std::mem::take(&mut v3_of(inst)?.scalars);
    let result = expand(v3_of(inst)?.layout, t, vrs, n_values, &mut scalars).and_then(|()| body(inst, &scalars));
    v3_of(inst)?.scalars = scalars;
    result
}

/// The instance's FMI 3.0 part.
fn v3_of<M: Model>(inst: &mut Instance<M>) -> Result<&mut V3, String> {
    inst.v3.as_mut().ok_or_else(|| "an FMI 2.0 instance called through FMI 3.0".to_owned())
}

/// # Safety
/// As the module's contract; `vr` holds `n` and `value` `n_values` elements.
pub unsafe fn get_float64<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *mut f64,
    n_values: usize,
) -> fmi3Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, "fmi3GetFloat64", GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "valueReferences")?, slice_mut(value, n_values, "values")?);
            let (time, info) = (inst.time, inst.info);
            let v3 = inst.v3.as_mut().ok_or("an FMI 2.0 instance called through FMI 3.0")?;
            expand(v3.layout, VarType::Real, vrs, n_values, &mut v3.scalars)?;
            // the model's values in one call (time left out), then in place
            v3.knowns.clear();
            v3.knowns.extend(v3.scalars.iter().copied().filter(|&s| s != TIME_SCALAR));
            v3.reals.resize(v3.knowns.len(), 0.0);
            if let Err((k, e)) = inst.model.get_reals(&v3.knowns, &mut v3.reals) {
                let v = info.lookup(VarType::Real, v3.knowns[k]).ok_or("unknown element")?;
                return Err(format!("{}: {}", describe(v), crate::export::instance::error_chain(&*e)));
            }
            let mut from_model = v3.reals.iter();
            for (&s, o) in v3.scalars.iter().zip(out.iter_mut()) {
                *o = if s == TIME_SCALAR { time } else { *from_model.next().ok_or("element count")? };
                if let Some(why) = finite(*o) {
                    let v = info.lookup(VarType::Real, s).ok_or("unknown element")?;
                    return Err(format!("{} = {why} at t = {time}", describe(v)));
                }
            }
            Ok(fmi2OK)
        })
    }
}

/// Shared body of `fmi3Get{Int32,Boolean}`: one model call per element.
///
/// # Safety
/// As the module's contract; `vr` holds `n` and `value` `n_values` elements.
#[allow(clippy::too_many_arguments)]
unsafe fn get_each<M: Model, T>(
    c: fmi3Instance,
    func: &'static str,
    t: VarType,
    vr: *const u32,
    n: usize,
    value: *mut T,
    n_values: usize,
    read: impl Fn(&mut M, u32) -> Result<T, crate::export::ModelError>,
) -> fmi3Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "valueReferences")?, slice_mut(value, n_values, "values")?);
            let info = inst.info;
            on_scalars(inst, t, vrs, n_values, |inst, scalars| {
                for (&s, o) in scalars.iter().zip(out.iter_mut()) {
                    let v = info.lookup(t, s).ok_or("unknown element")?;
                    *o = read(&mut inst.model, s).msg().map_err(|e| format!("{}: {e}", describe(v)))?;
                }
                Ok(fmi2OK)
            })
        })
    }
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn get_int32<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *mut i32,
    n_values: usize,
) -> fmi3Status {
    // SAFETY: the contract is get_each's.
    unsafe { get_each::<M, i32>(c, "fmi3GetInt32", VarType::Integer, vr, n, value, n_values, |m, r| m.get_integer(r)) }
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn get_boolean<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *mut fmi3Boolean,
    n_values: usize,
) -> fmi3Status {
    let read = |m: &mut M, r| m.get_boolean(r).map(u8::from);
    // SAFETY: the contract is get_each's.
    unsafe { get_each::<M, u8>(c, "fmi3GetBoolean", VarType::Boolean, vr, n, value, n_values, read) }
}

/// # Safety
/// As [`get_float64`]. The strings stay valid until the next `fmi3GetString`.
pub unsafe fn get_string<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *mut fmi3String,
    n_values: usize,
) -> fmi3Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, "fmi3GetString", GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "valueReferences")?, slice_mut(value, n_values, "values")?);
            let info = inst.info;
            on_scalars(inst, VarType::String, vrs, n_values, |inst, scalars| {
                inst.strings.clear();
                for &s in scalars {
                    let v = info.lookup(VarType::String, s).ok_or("unknown element")?;
                    let text = inst.model.get_string(s).msg().map_err(|e| format!("{}: {e}", describe(v)))?;
                    inst.strings.push(CString::new(text.replace('\0', "")).unwrap_or_default());
                }
                for (o, s) in out.iter_mut().zip(&inst.strings) {
                    *o = s.as_ptr();
                }
                Ok(fmi2OK)
            })
        })
    }
}

/// Shared body of `fmi3Set*`: every value is checked before the first one is applied.
///
/// # Safety
/// As the module's contract; `vr` holds `n` and `value` `n_values` elements.
#[allow(clippy::too_many_arguments)]
unsafe fn set_each<M: Model, T: Copy>(
    c: fmi3Instance,
    func: &'static str,
    t: VarType,
    vr: *const u32,
    n: usize,
    value: *const T,
    n_values: usize,
    invalid: impl Fn(&crate::Variable, T) -> Option<String>,
    apply: impl Fn(&mut M, u32, T) -> Result<(), crate::export::ModelError>,
) -> fmi3Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, func, SETTABLE, |inst| {
            let (vrs, vals) = (slice(vr, n, "valueReferences")?, slice(value, n_values, "values")?);
            let (info, phase, phase_name) = (inst.info, inst.phase.set_phase(), inst.phase.name());
            on_scalars(inst, t, vrs, n_values, |inst, scalars| {
                for (&s, &x) in scalars.iter().zip(vals) {
                    if s == TIME_SCALAR {
                        return Err("`time` (independent) cannot be set".into());
                    }
                    let v = info.lookup(t, s).ok_or("unknown element")?;
                    if !v.settable_in(phase) {
                        return Err(format!("{} cannot be set in state `{phase_name}`", describe(v)));
                    }
                    if let Some(why) = invalid(&v.var, x) {
                        return Err(format!("{} = {why}", describe(v)));
                    }
                }
                for (&s, &x) in scalars.iter().zip(vals) {
                    let v = info.lookup(t, s).ok_or("unknown element")?;
                    apply(&mut inst.model, s, x).msg().map_err(|e| format!("{}: {e}", describe(v)))?;
                }
                Ok(fmi2OK)
            })
        })
    }
}

/// # Safety
/// As [`set_each`].
pub unsafe fn set_float64<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *const f64,
    n_values: usize,
) -> fmi3Status {
    let invalid = |v: &crate::Variable, x| finite(x).or_else(|| v.outside_range(x));
    // SAFETY: the contract is set_each's.
    unsafe {
        set_each::<M, f64>(c, "fmi3SetFloat64", VarType::Real, vr, n, value, n_values, invalid, |m, r, x| {
            m.set_real(r, x)
        })
    }
}

/// # Safety
/// As [`set_each`].
pub unsafe fn set_int32<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *const i32,
    n_values: usize,
) -> fmi3Status {
    let apply = |m: &mut M, r, x| m.set_integer(r, x);
    // SAFETY: the contract is set_each's.
    unsafe { set_each::<M, i32>(c, "fmi3SetInt32", VarType::Integer, vr, n, value, n_values, |_, _| None, apply) }
}

/// # Safety
/// As [`set_each`].
pub unsafe fn set_boolean<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *const fmi3Boolean,
    n_values: usize,
) -> fmi3Status {
    let apply = |m: &mut M, r, x: u8| m.set_boolean(r, x != fmi3False);
    // SAFETY: the contract is set_each's.
    unsafe { set_each::<M, u8>(c, "fmi3SetBoolean", VarType::Boolean, vr, n, value, n_values, |_, _| None, apply) }
}

/// # Safety
/// As [`set_each`]; each string is null or NUL-terminated (copied, the caller keeps ownership).
pub unsafe fn set_string<M: Model>(
    c: fmi3Instance,
    vr: *const u32,
    n: usize,
    value: *const fmi3String,
    n_values: usize,
) -> fmi3Status {
    // SAFETY: a non-null string is NUL-terminated and unchanged during the call (the contract).
    let text = |p: fmi3String| (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_str());
    let invalid = |_: &crate::Variable, p: fmi3String| match text(p) {
        None => Some("a null pointer".to_owned()),
        Some(Err(_)) => Some("a string that is not UTF-8".to_owned()),
        Some(Ok(_)) => None,
    };
    let apply = |m: &mut M, r, p| match text(p) {
        Some(Ok(s)) => m.set_string(r, s),
        _ => Err("not a UTF-8 string".into()),
    };
    // SAFETY: the contract is set_each's.
    unsafe { set_each::<M, fmi3String>(c, "fmi3SetString", VarType::String, vr, n, value, n_values, invalid, apply) }
}

/// `fmi3GetDirectionalDerivative` ([`Derivative::Instant`]) and the extension
/// `feedsim3GetStepMapDerivative` ([`Derivative::StepMap`], the same signature): the variables
/// expanded to their elements, then the checks of the FMI 2.0 export.
///
/// # Safety
/// As the module's contract; the arrays hold the numbers of elements passed with them.
#[allow(clippy::too_many_arguments)]
pub unsafe fn derivative<M: Model>(
    c: fmi3Instance,
    kind: Derivative,
    unknowns: *const u32,
    n_unknowns: usize,
    knowns: *const u32,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> fmi3Status {
    let func = match kind {
        Derivative::Instant => "fmi3GetDirectionalDerivative",
        Derivative::StepMap => "feedsim3GetStepMapDerivative",
    };
    // SAFETY: `c` and the four arrays as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            provided(inst, kind, "providesDirectionalDerivatives")?;
            let u = slice(unknowns, n_unknowns, "unknowns")?;
            let k = slice(knowns, n_knowns, "knowns")?;
            let seed = slice(seed, n_seed, "seed")?;
            let out = slice_mut(sensitivity, n_sensitivity, "sensitivity")?;
            let v3 = v3_of(inst)?;
            let (mut us, mut ks) = (std::mem::take(&mut v3.scalars), std::mem::take(&mut v3.knowns));
            let layout = v3.layout;
            let result = expand(layout, VarType::Real, u, n_sensitivity, &mut us)
                .and_then(|()| expand(layout, VarType::Real, k, n_seed, &mut ks))
                .and_then(|()| {
                    if us.contains(&TIME_SCALAR) || ks.contains(&TIME_SCALAR) {
                        return Err(format!("`time` (value reference {TIME_VR}) has no derivatives here"));
                    }
                    derivative_checked(inst, kind, &us, &ks, seed, out).map(|()| fmi2OK)
                });
            let v3 = v3_of(inst)?;
            (v3.scalars, v3.knowns) = (us, ks);
            result
        })
    }
}

/// # Safety
/// As the module's contract; the four out-parameters are writable.
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<M: Model>(
    c: fmi3Instance,
    t: f64,
    h: f64,
    _no_prior: fmi3Boolean,
    event_handling_needed: *mut fmi3Boolean,
    terminate_simulation: *mut fmi3Boolean,
    early_return: *mut fmi3Boolean,
    last_successful_time: *mut f64,
) -> fmi3Status {
    // SAFETY: `c` and the out-parameters as the contract says.
    unsafe {
        call::<M>(c, "fmi3DoStep", &[Phase::StepMode], |inst| {
            let status = step("fmi3DoStep", inst, t, h)?;
            let ended = status == fmi2Discard;
            let early = ended && inst.time < t + h - TIME_RTOL * (t + h).abs().max(h);
            if ended {
                // the model's end is no failure in FMI 3.0: reported through terminateSimulation
                inst.phase = Phase::StepFailed;
            }
            let allowed = inst.v3.as_ref().is_some_and(|v| v.early_return_allowed);
            write(event_handling_needed, fmi3False, "eventHandlingNeeded")?;
            write(terminate_simulation, u8::from(ended), "terminateSimulation")?;
            write(early_return, u8::from(early && allowed), "earlyReturn")?;
            write(last_successful_time, inst.time, "lastSuccessfulTime")?;
            Ok(fmi2OK)
        })
    }
}
