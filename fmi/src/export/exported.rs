//! The functions the [`export_fmu!`](crate::export_fmu) macro forwards to, one per C function
//! of the same name. Not for direct use.
//!
//! Contract of every `unsafe fn` here, the importer's duty under FMI 2.0: `c` is null or a
//! component this layer returned from `fmi2Instantiate` for the same `M` and not yet freed, and
//! no other call uses it (or its FMU states) at the same time; every array pointer is null or
//! points to as many aligned, initialized elements (writable for outputs) as the length passed
//! with it; every string is null or NUL-terminated. Each function runs its work inside
//! `catch_unwind`, so no panic reaches the importer.

use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

use super::instance::{Instance, Logger, Msg, Phase, describe, error_chain, log_to, panic_text};
use super::state::{Snapshot, free_snapshot, from_serialized, serialized, serialized_len, snapshot_mut};
use super::{Derivative, Model, ModelError, Seeds, StepOutcome};
use crate::description::{Causality, DescriptionError, ModelInfo, VarType};
use crate::ffi::*;
use Phase::*;

pub(crate) const ALL_BUT_FATAL: &[Phase] =
    &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated, Error, EventMode, ContinuousTime];
pub(crate) const GETTABLE: &[Phase] =
    &[InitializationMode, StepMode, StepFailed, Terminated, Error, EventMode, ContinuousTime];
pub(crate) const SETTABLE: &[Phase] = &[Instantiated, InitializationMode, StepMode, EventMode, ContinuousTime];
pub(crate) const STATE_OK: &[Phase] =
    &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated, EventMode, ContinuousTime];
/// Where the `fmi2Get*Status` functions may be called.
const STATUS_OK: &[Phase] = &[StepMode, StepFailed, Terminated, Error];
/// Freeing a saved state touches no model data: allowed even after a fatal error.
pub(crate) const ANY: &[Phase] =
    &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated, Error, Fatal, EventMode, ContinuousTime];

/// Relative tolerance for matching the importer's communication point with the instance's time.
pub(crate) const TIME_RTOL: f64 = 1e-9;

/// Runs `f`, containing a panic: its payload (dropped inside a guard too, as a payload's own
/// destructor may panic) is passed to `on_panic` as text.
pub(crate) fn contain<T>(f: impl FnOnce() -> T, on_panic: impl FnOnce(String) -> T) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(v) => v,
        Err(payload) => {
            let text = catch_unwind(AssertUnwindSafe(move || panic_text(&*payload)));
            on_panic(text.unwrap_or_else(|p| {
                std::mem::forget(p);
                "a panic whose payload panicked when read".into()
            }))
        }
    }
}

/// Runs `body` on the instance `c` if the call is allowed in its phase (see
/// [`Instance::run`]); a panic makes the instance fatal and is logged.
///
/// # Safety
/// `c` as in the module's contract.
pub(crate) unsafe fn call<M: Model>(
    c: fmi2Component,
    func: &'static str,
    allowed: &[Phase],
    body: impl FnOnce(&mut Instance<M>) -> Result<fmi2Status, String>,
) -> fmi2Status {
    if c.is_null() {
        return fmi2Error;
    }
    let inst = c.cast::<Instance<M>>();
    contain(
        // SAFETY: `c` is a live `Instance<M>` that this call alone uses (the contract).
        || unsafe { &mut *inst }.run(func, allowed, body),
        |panic| {
            contain(
                || {
                    // SAFETY: as above; the reference the panicking closure held is gone.
                    let inst = unsafe { &mut *inst };
                    inst.phase = Fatal;
                    inst.log(fmi2Fatal, &format!("{func}: internal error (panic): {panic}"));
                },
                drop,
            );
            fmi2Fatal
        },
    )
}

/// A slice from an importer's pointer and length; null is an error unless the length is 0.
///
/// # Safety
/// A non-null `ptr` points to `n` aligned, initialized elements that nothing changes during `'a`.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        Ok(&[])
    } else if ptr.is_null() {
        Err(format!("`{what}` is a null pointer (length {n})"))
    } else {
        // SAFETY: non-null, and the caller promises `n` valid elements for `'a`.
        Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
    }
}

/// # Safety
/// A non-null `ptr` points to `n` aligned, writable elements that nothing else accesses during `'a`.
pub(crate) unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], String> {
    if n == 0 {
        Ok(&mut [])
    } else if ptr.is_null() {
        Err(format!("`{what}` is a null pointer (length {n})"))
    } else {
        // SAFETY: non-null, and the caller promises `n` writable elements used by no one else.
        Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
    }
}

/// `*out = value`, or an error if `out` is null.
///
/// # Safety
/// A non-null `out` is aligned and writable.
pub(crate) unsafe fn write<T>(out: *mut T, value: T, what: &str) -> Result<(), String> {
    // SAFETY: the caller's contract, for one element.
    let out = unsafe { slice_mut(out, 1, what) }?;
    out[0] = value;
    Ok(())
}

/// A C string of the importer, copied (lossily) into Rust; `None` for null.
///
/// # Safety
/// A non-null `s` is NUL-terminated and unchanged during the call.
pub(crate) unsafe fn string(s: *const c_char) -> Option<String> {
    // SAFETY: the caller's contract.
    (!s.is_null()).then(|| unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

pub fn types_platform() -> *const c_char {
    c"default".as_ptr()
}

pub fn version() -> *const c_char {
    c"2.0".as_ptr()
}

/// Where the macro keeps a model's validated description for the life of the process (built
/// by the first `fmi2Instantiate`, inside its panic guard; a panic leaves it unset).
pub type InfoCell = std::sync::OnceLock<Result<ModelInfo, DescriptionError>>;

pub(crate) fn model_info<M: Model>() -> Result<ModelInfo, DescriptionError> {
    ModelInfo::new(M::description().map_err(|e| DescriptionError(error_chain(&*e)))?)
}

/// # Safety
/// Strings and `functions` as in the module's contract (`functions` copied, so the importer may
/// free it afterwards).
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate<M: Model>(
    info: &'static InfoCell,
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    guid: fmi2String,
    resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    if functions.is_null() {
        return std::ptr::null_mut();
    }
    // SAFETY: non-null, and a valid callback struct by the contract.
    let cb = unsafe { *functions };
    // SAFETY: a non-null instance name is NUL-terminated (the contract).
    let name = contain(|| unsafe { string(instance_name) }, |_| None);
    let name_c = CString::new(name.clone().unwrap_or_else(|| "(unnamed)".into())).unwrap_or_default();
    let result = contain(
        || -> Result<fmi2Component, String> {
            let info = info.get_or_init(model_info::<M>).as_ref().map_err(|e| e.to_string())?;
            if name.is_none() {
                return Err("instanceName is a null pointer".into());
            }
            let (cs, me) = (info.description.co_simulation, info.description.model_exchange.is_some());
            let me = match fmu_type {
                t if t == fmi2CoSimulation && cs => false,
                t if t == fmi2ModelExchange && me => true,
                _ => {
                    let offered = match (me, cs) {
                        (true, true) => "Model Exchange (0) and Co-Simulation (1)",
                        (true, false) => "Model Exchange (0) only",
                        _ => "Co-Simulation (1) only",
                    };
                    return Err(format!("fmuType = {fmu_type}: this FMU supports {offered}"));
                }
            };
            // SAFETY: non-null strings are NUL-terminated (the contract).
            let [guid, location] = [guid, resource_location].map(|s| unsafe { string(s) });
            let guid = guid.ok_or("fmuGUID is a null pointer")?;
            if guid != info.description.guid {
                return Err(format!(
                    "fmuGUID `{guid}` does not match this binary's `{}` (modelDescription.xml from another build?)",
                    info.description.guid
                ));
            }
            let resources = crate::uri::resource_dir(location.as_deref().unwrap_or(""))?;
            let model = M::instantiate(resources.as_deref()).msg()?;
            let logger = Logger::Fmi2(cb.logger, cb.componentEnvironment);
            let mut inst = Instance::new(info, name_c.clone(), resources, logger, None, logging_on != fmi2False, model);
            inst.me = if me { super::instance::MeInstance::of(info) } else { None };
            Ok(Box::into_raw(Box::new(inst)).cast())
        },
        |panic| Err(format!("internal error (panic): {panic}")),
    );
    result.unwrap_or_else(|msg| {
        let message = format!("fmi2Instantiate: {msg}");
        let logger = Logger::Fmi2(cb.logger, cb.componentEnvironment);
        contain(|| log_to(logger, &name_c, fmi2Error, "logError", &message), drop);
        std::ptr::null_mut()
    })
}

/// # Safety
/// `c` as in the module's contract; it is invalid afterwards.
pub unsafe fn free_instance<M: Model>(c: fmi2Component) {
    if !c.is_null() {
        // SAFETY: `c` came from `Box::into_raw` in `instantiate::<M>` and is not used again (the
        // contract). A panicking destructor is contained; the memory is then leaked.
        contain(|| drop(unsafe { Box::from_raw(c.cast::<Instance<M>>()) }), drop);
    }
}

/// # Safety
/// As the module's contract; `categories` holds `n` strings.
pub unsafe fn set_debug_logging<M: Model>(
    func: &'static str,
    c: fmi2Component,
    logging_on: fmi2Boolean,
    n: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    // SAFETY: `c`, the array and its strings as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            let on = logging_on != fmi2False;
            let cats = slice(categories, n, "categories")?;
            if cats.is_empty() {
                (inst.log_errors, inst.log_warnings, inst.log_info) = (on, on, on);
            }
            for &cat in cats {
                match string(cat).ok_or("a category is a null pointer")?.as_str() {
                    "logAll" => (inst.log_errors, inst.log_warnings, inst.log_info) = (on, on, on),
                    "logError" => inst.log_errors = on,
                    "logWarning" => inst.log_warnings = on,
                    "logInfo" => inst.log_info = on,
                    other => {
                        return Err(format!(
                            "unknown log category `{other}` (known: logError, logWarning, logInfo, logAll)"
                        ));
                    }
                }
            }
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn setup_experiment<M: Model>(
    c: fmi2Component,
    _tolerance_defined: fmi2Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: fmi2Boolean,
    stop_time: f64,
) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, "fmi2SetupExperiment", &[Instantiated], |inst| {
            if !start_time.is_finite() {
                return Err(format!("startTime = {start_time} is not finite"));
            }
            let stop = (stop_time_defined != fmi2False).then_some(stop_time);
            if let Some(s) = stop
                && !(s.is_finite() && s >= start_time)
            {
                return Err(format!("stopTime = {s} must be finite and ≥ startTime = {start_time}"));
            }
            (inst.start_time, inst.stop_time, inst.time) = (start_time, stop, start_time);
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn enter_initialization_mode<M: Model>(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, "fmi2EnterInitializationMode", &[Instantiated], |inst| {
            inst.phase = InitializationMode;
            inst.log(fmi2OK, "entered initialization mode");
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn exit_initialization_mode<M: Model>(func: &'static str, c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, &[InitializationMode], |inst| {
            inst.model.exit_initialization(inst.start_time).msg()?;
            let next = if inst.me.is_some() { EventMode } else { StepMode };
            (inst.phase, inst.time) = (next, inst.start_time);
            inst.log(fmi2OK, &format!("entered {} at t = {}", next.name(), inst.time));
            match inst.model.initialization_warning() {
                Some(warning) => {
                    inst.log(fmi2Warning, &format!("{func}: {warning}"));
                    Ok(fmi2Warning)
                }
                None => Ok(fmi2OK),
            }
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn terminate<M: Model>(func: &'static str, c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, &[StepMode, StepFailed, EventMode, ContinuousTime], |inst| {
            inst.phase = Terminated;
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn reset<M: Model>(func: &'static str, c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            inst.model = M::instantiate(inst.resources.as_deref()).msg()?;
            (inst.phase, inst.time, inst.start_time, inst.stop_time, inst.terminated) =
                (Instantiated, 0.0, 0.0, None, false);
            Ok(fmi2OK)
        })
    }
}

/// Shared body of `fmi2Get{Real,Integer,Boolean}`; `invalid` refuses a value the model
/// should never report (a non-finite Real).
///
/// # Safety
/// As the module's contract; `vr` and `value` hold `n` elements.
#[allow(clippy::too_many_arguments)]
unsafe fn get<M: Model, T>(
    c: fmi2Component,
    func: &'static str,
    t: VarType,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *mut T,
    read: impl Fn(&mut M, u32) -> Result<T, ModelError>,
    invalid: impl Fn(&T) -> Option<String>,
) -> fmi2Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
            for (&r, o) in vrs.iter().zip(out.iter_mut()) {
                let v = inst.find(t, r)?;
                let x = read(&mut inst.model, r).msg().map_err(|e| format!("{}: {e}", describe(v)))?;
                if let Some(why) = invalid(&x) {
                    return Err(format!("{} = {why} at t = {}", describe(v), inst.time));
                }
                *o = x;
            }
            Ok(fmi2OK)
        })
    }
}

/// Shared body of `fmi2Set*`: every value is checked before the first one is applied.
///
/// # Safety
/// As the module's contract; `vr` and `value` hold `n` elements.
#[allow(clippy::too_many_arguments)]
unsafe fn set<M: Model, T: Copy>(
    c: fmi2Component,
    func: &'static str,
    t: VarType,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const T,
    invalid: impl Fn(&crate::Variable, T) -> Option<String>,
    write: impl Fn(&mut M, u32, T) -> Result<(), ModelError>,
) -> fmi2Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, func, SETTABLE, |inst| {
            let (vrs, vals) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
            let phase = inst.phase.set_phase();
            for (&r, &x) in vrs.iter().zip(vals) {
                let v = inst.find(t, r)?;
                if !v.settable_in(phase) {
                    return Err(format!("{} cannot be set in state `{}`", describe(v), inst.phase.name()));
                }
                if let Some(why) = invalid(&v.var, x) {
                    return Err(format!("{} = {why}", describe(v)));
                }
            }
            for (&r, &x) in vrs.iter().zip(vals) {
                if let Err(e) = write(&mut inst.model, r, x).msg() {
                    return Err(format!("{}: {e}", describe(inst.find(t, r)?)));
                }
            }
            Ok(fmi2OK)
        })
    }
}

#[inline]
pub(crate) fn finite(x: f64) -> Option<String> {
    (!x.is_finite()).then(|| format!("{x}: not a finite number"))
}

/// # Safety
/// As the module's contract; `vr` and `value` hold `n` elements.
pub unsafe fn get_real<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut f64) -> fmi2Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, "fmi2GetReal", GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
            for &r in vrs {
                inst.find(VarType::Real, r)?;
            }
            if let Err((k, e)) = inst.model.get_reals(vrs, out) {
                let v = inst.find(VarType::Real, vrs[k])?;
                return Err(format!("{}: {}", describe(v), error_chain(&*e)));
            }
            for (&r, x) in vrs.iter().zip(out.iter()) {
                if let Some(why) = finite(*x) {
                    return Err(format!("{} = {why} at t = {}", describe(inst.find(VarType::Real, r)?), inst.time));
                }
            }
            Ok(fmi2OK)
        })
    }
}
/// # Safety
/// As [`get_real`].
pub unsafe fn get_integer<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut i32) -> fmi2Status {
    // SAFETY: the contract is get's.
    unsafe { get::<M, i32>(c, "fmi2GetInteger", VarType::Integer, vr, n, value, |m, r| m.get_integer(r), |_| None) }
}
/// # Safety
/// As [`get_real`].
pub unsafe fn get_boolean<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut i32) -> fmi2Status {
    let read = |m: &mut M, r| m.get_boolean(r).map(i32::from);
    // SAFETY: the contract is get's.
    unsafe { get::<M, i32>(c, "fmi2GetBoolean", VarType::Boolean, vr, n, value, read, |_| None) }
}
/// # Safety
/// As [`get_real`]. The returned strings stay valid until the next `fmi2GetString`.
pub unsafe fn get_string<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut fmi2String) -> fmi2Status {
    // SAFETY: `c` and the two arrays as the contract says.
    unsafe {
        call::<M>(c, "fmi2GetString", GETTABLE, |inst| {
            let (vrs, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
            inst.strings.clear();
            for &r in vrs {
                let v = inst.find(VarType::String, r)?;
                let s = inst.model.get_string(r).msg().map_err(|e| format!("{}: {e}", describe(v)))?;
                inst.strings.push(CString::new(s.replace('\0', "")).unwrap_or_default());
            }
            for (o, s) in out.iter_mut().zip(&inst.strings) {
                *o = s.as_ptr();
            }
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract; `vr` and `value` hold `n` elements.
pub unsafe fn set_real<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const f64) -> fmi2Status {
    let invalid = |v: &crate::Variable, x| finite(x).or_else(|| v.outside_range(x));
    // SAFETY: the contract is set's.
    unsafe { set::<M, f64>(c, "fmi2SetReal", VarType::Real, vr, n, value, invalid, |m, r, x| m.set_real(r, x)) }
}
/// # Safety
/// As [`set_real`].
pub unsafe fn set_integer<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const i32) -> fmi2Status {
    let write = |m: &mut M, r, x| m.set_integer(r, x);
    // SAFETY: the contract is set's.
    unsafe { set::<M, i32>(c, "fmi2SetInteger", VarType::Integer, vr, n, value, |_, _| None, write) }
}
/// # Safety
/// As [`set_real`].
pub unsafe fn set_boolean<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const i32) -> fmi2Status {
    let write = |m: &mut M, r, x| m.set_boolean(r, x != fmi2False);
    // SAFETY: the contract is set's.
    unsafe { set::<M, i32>(c, "fmi2SetBoolean", VarType::Boolean, vr, n, value, |_, _| None, write) }
}
/// # Safety
/// As [`set_real`]; each string is null or NUL-terminated (copied, the caller keeps ownership).
pub unsafe fn set_string<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const fmi2String) -> fmi2Status {
    // SAFETY: a non-null string is NUL-terminated and unchanged during the call (the contract).
    let text = |p: fmi2String| (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_str());
    let invalid = |_: &crate::Variable, p: fmi2String| match text(p) {
        None => Some("a null pointer".to_owned()),
        Some(Err(_)) => Some("a string that is not UTF-8".to_owned()),
        Some(Ok(_)) => None,
    };
    let write = |m: &mut M, r, p| match text(p) {
        Some(Ok(s)) => m.set_string(r, s),
        _ => Err("not a UTF-8 string".into()),
    };
    // SAFETY: the contract is set's.
    unsafe { set::<M, fmi2String>(c, "fmi2SetString", VarType::String, vr, n, value, invalid, write) }
}

/// # Safety
/// As the module's contract; `state` is writable and holds null or a state of this instance's FMU.
pub unsafe fn get_fmu_state<M: Model>(func: &'static str, c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c`, `state` and the state it holds as the contract says.
    unsafe {
        call::<M>(c, func, STATE_OK, |inst| {
            let state = slice_mut(state, 1, "FMUstate")?;
            if state[0].is_null() {
                let mut snap = Snapshot::of_bytes(Vec::new());
                inst.save_snapshot(&mut snap)?;
                state[0] = snap.into_raw();
            } else {
                // Overwrite in place: a rollback loop allocates nothing after the first step.
                inst.save_snapshot(snapshot_mut(state[0])?)?;
            }
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract; `state` is null or a state of this instance's FMU.
pub unsafe fn set_fmu_state<M: Model>(func: &'static str, c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c` and `state` as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            inst.restore_snapshot(snapshot_mut(state)?)?;
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As [`get_fmu_state`]; the state is freed and `*state` null afterwards.
pub unsafe fn free_fmu_state<M: Model>(func: &'static str, c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c`, `state` and the state it holds as the contract says.
    unsafe {
        call::<M>(c, func, ANY, |_| {
            if state.is_null() || (*state).is_null() {
                return Ok(fmi2OK);
            }
            free_snapshot(*state)?;
            *state = std::ptr::null_mut();
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As [`set_fmu_state`]; `size` is writable.
pub unsafe fn serialized_fmu_state_size<M: Model>(
    func: &'static str,
    c: fmi2Component,
    state: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    // SAFETY: `c`, `state` and `size` as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            write(size, serialized_len(inst.snapshot_bytes(snapshot_mut(state)?)?), "size")?;
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As [`set_fmu_state`]; `bytes` holds `size` writable bytes.
pub unsafe fn serialize_fmu_state<M: Model>(
    func: &'static str,
    c: fmi2Component,
    state: fmi2FMUstate,
    bytes: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    // SAFETY: `c`, `state` and the buffer as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            let state_bytes = inst.snapshot_bytes(snapshot_mut(state)?)?;
            let needed = serialized_len(state_bytes);
            if size < needed {
                return Err(format!("buffer of {size} bytes is smaller than the state ({needed} bytes)"));
            }
            let out = slice_mut(bytes.cast::<u8>(), size, "serializedState")?;
            serialized(state_bytes, &mut out[..needed]);
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As [`get_fmu_state`]; `bytes` holds `size` readable bytes.
pub unsafe fn deserialize_fmu_state<M: Model>(
    func: &'static str,
    c: fmi2Component,
    bytes: *const fmi2Byte,
    size: usize,
    state: *mut fmi2FMUstate,
) -> fmi2Status {
    // SAFETY: `c`, the buffer, `state` and the state it holds as the contract says.
    unsafe {
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            let data = from_serialized(slice(bytes.cast::<u8>(), size, "serializedState")?)?;
            let state = slice_mut(state, 1, "FMUstate")?;
            inst.check_state(data)?;
            if state[0].is_null() {
                state[0] = Snapshot::of_bytes(data.to_vec()).into_raw();
            } else {
                snapshot_mut(state[0])?.set_bytes(data);
            }
            Ok(fmi2OK)
        })
    }
}

/// `fmi2GetDirectionalDerivative` ([`Derivative::Instant`]) and the extension
/// `feedsimGetStepMapDerivative` ([`Derivative::StepMap`], the same signature): checks,
/// parameter seeds dropped, result checked.
///
/// # Safety
/// As the module's contract; the arrays hold the numbers of elements passed with them.
#[allow(clippy::too_many_arguments)]
pub unsafe fn derivative<M: Model>(
    c: fmi2Component,
    kind: Derivative,
    v_unknown: *const u32,
    n_unknown: usize,
    v_known: *const u32,
    n_known: usize,
    dv_known: *const f64,
    dv_unknown: *mut f64,
) -> fmi2Status {
    let func = match kind {
        Derivative::Instant => "fmi2GetDirectionalDerivative",
        Derivative::StepMap => "feedsimGetStepMapDerivative",
    };
    // SAFETY: `c` and the four arrays as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            provided(inst, kind, "providesDirectionalDerivative")?;
            let unknowns = slice(v_unknown, n_unknown, "vUnknown_ref")?;
            let knowns = slice(v_known, n_known, "vKnown_ref")?;
            let seed = slice(dv_known, n_known, "dvKnown")?;
            let out = slice_mut(dv_unknown, n_unknown, "dvUnknown")?;
            derivative_checked(inst, kind, unknowns, knowns, seed, out).map(|()| fmi2OK)
        })
    }
}

/// Refuses a derivative the description does not announce (`attribute`: the version's name of
/// the capability flag).
pub(crate) fn provided<M: Model>(inst: &Instance<M>, kind: Derivative, attribute: &str) -> Result<(), String> {
    let flags = inst.info.description.flags;
    match kind {
        Derivative::Instant if !flags.provides_directional_derivative => {
            Err(format!("not provided by this FMU ({attribute} = false)"))
        }
        Derivative::StepMap if !flags.provides_step_map_derivative => {
            Err("not provided by this FMU (no StepMapDerivative annotation)".into())
        }
        _ => Ok(()),
    }
}

/// The checks around a model's derivative: unknowns and knowns of the right causality, finite
/// seeds (parameters with a zero seed dropped, in the instance's reused buffers), a finite result.
pub(crate) fn derivative_checked<M: Model>(
    inst: &mut Instance<M>,
    kind: Derivative,
    unknowns: &[u32],
    knowns: &[u32],
    seed: &[f64],
    out: &mut [f64],
) -> Result<(), String> {
    inst.scratch_knowns.clear();
    inst.scratch_seed.clear();
    for &r in unknowns {
        let v = inst.find(VarType::Real, r)?;
        if !matches!(v.var.causality, Causality::Output | Causality::Local | Causality::CalculatedParameter) {
            return Err(format!("{} cannot be an unknown (only outputs and locals)", describe(v)));
        }
    }
    for (&r, &x) in knowns.iter().zip(seed) {
        let v = inst.find(VarType::Real, r)?;
        let is_param = v.var.causality == Causality::Parameter;
        if v.var.causality != Causality::Input && !is_param {
            return Err(format!("{} cannot be a known (only inputs and parameters)", describe(v)));
        }
        if let Some(why) = finite(x) {
            return Err(format!("seed for {} = {why}", describe(v)));
        }
        // A zero seed on a parameter contributes nothing (importers such as OMSimulator pass
        // whole dependency lists).
        if !(is_param && x == 0.0) {
            inst.scratch_knowns.push(r);
            inst.scratch_seed.push(x);
        }
    }
    let at = Seeds { unknowns, knowns: &inst.scratch_knowns, seed: &inst.scratch_seed };
    inst.model.derivative(kind, at, out).msg()?;
    if let Some(i) = out.iter().position(|x| !x.is_finite()) {
        let v = inst.find(VarType::Real, unknowns[i])?;
        return Err(format!("the derivative of {} is {} at t = {}", describe(v), out[i], inst.time));
    }
    Ok(())
}

/// # Safety
/// As the module's contract; the arrays hold `n` elements.
pub unsafe fn set_real_input_derivatives<M: Model>(
    c: fmi2Component,
    vr: *const u32,
    n: usize,
    order: *const i32,
    value: *const f64,
) -> fmi2Status {
    // SAFETY: `c` and the three arrays as the contract says.
    unsafe {
        call::<M>(c, "fmi2SetRealInputDerivatives", SETTABLE, |inst| {
            if !inst.info.description.flags.can_interpolate_inputs {
                return Err("not supported by this FMU (canInterpolateInputs = false)".into());
            }
            let (vrs, orders, vals) = (slice(vr, n, "vr")?, slice(order, n, "order")?, slice(value, n, "value")?);
            for ((&r, &o), &x) in vrs.iter().zip(orders).zip(vals) {
                let v = inst.find(VarType::Real, r)?;
                if v.var.causality != Causality::Input {
                    return Err(format!("{} is not an input", describe(v)));
                }
                if o != 1 {
                    return Err(format!(
                        "order {o} for {}: only first-order input derivatives are supported",
                        describe(v)
                    ));
                }
                if let Some(why) = finite(x) {
                    return Err(format!("derivative of {} = {why}", describe(v)));
                }
            }
            for (&r, &x) in vrs.iter().zip(vals) {
                inst.model.set_real_input_derivative(r, x).msg()?;
            }
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn get_real_output_derivatives<M: Model>(
    c: fmi2Component,
    _vr: *const u32,
    _n: usize,
    _order: *const i32,
    _value: *mut f64,
) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, "fmi2GetRealOutputDerivatives", &[StepMode, Terminated, Error], |_| {
            Err("not supported (maxOutputDerivativeOrder = 0)".into())
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn do_step<M: Model>(c: fmi2Component, t: f64, h: f64, _no_prior: fmi2Boolean) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe { call::<M>(c, "fmi2DoStep", &[StepMode], |inst| step("fmi2DoStep", inst, t, h)) }
}

pub(crate) fn step<M: Model>(func: &str, inst: &mut Instance<M>, t: f64, h: f64) -> Result<fmi2Status, String> {
    if !(t.is_finite() && h.is_finite() && h > 0.0) {
        return Err(format!("currentCommunicationPoint = {t}, communicationStepSize = {h}: need finite t and h > 0"));
    }
    let tol = TIME_RTOL * inst.time.abs().max(t.abs()).max(h);
    if (t - inst.time).abs() > tol {
        return Err(format!(
            "currentCommunicationPoint = {t} but the instance is at t = {} (difference {:e})",
            inst.time,
            t - inst.time
        ));
    }
    if let Some(stop) = inst.stop_time
        && t + h > stop + TIME_RTOL * stop.abs().max(h)
    {
        return Err(format!("step to {} goes past stopTime = {stop}", t + h));
    }
    let outcome = inst.model.do_step(t, h).msg().map_err(|e| format!("step from t = {t} with h = {h}: {e}"))?;
    match outcome {
        StepOutcome::Complete => {
            inst.time = t + h;
            Ok(fmi2OK)
        }
        StepOutcome::Terminated { time, reason } => {
            if !(time.is_finite() && time >= t - tol && time <= t + h + tol) {
                return Err(format!("the model stopped at t = {time}, outside the step [{t}, {}]", t + h));
            }
            (inst.time, inst.terminated, inst.phase) = (time, true, StepFailed);
            inst.log(fmi2Discard, &format!("{func}: the model stopped at t = {time}: {reason}"));
            Ok(fmi2Discard)
        }
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn cancel_step<M: Model>(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, "fmi2CancelStep", ALL_BUT_FATAL, |_| {
            Err("no step is in progress (fmi2DoStep never returns fmi2Pending)".into())
        })
    }
}

/// Shared body of the `fmi2Get*Status` functions.
///
/// # Safety
/// As the module's contract; `value` is writable.
unsafe fn status<M: Model, T>(
    c: fmi2Component,
    func: &'static str,
    kind: fmi2StatusKind,
    value: *mut T,
    answer: impl Fn(&Instance<M>, fmi2StatusKind) -> Option<T>,
) -> fmi2Status {
    // SAFETY: `c` and `value` as the contract says.
    unsafe {
        call::<M>(c, func, STATUS_OK, |inst| match answer(inst, kind) {
            Some(v) => write(value, v, "value").map(|()| fmi2OK),
            None => {
                inst.log(fmi2Discard, &format!("{func}: status kind {kind} is not available (no asynchronous steps)"));
                Ok(fmi2Discard)
            }
        })
    }
}

/// # Safety
/// As the module's contract; `value` is writable.
pub unsafe fn get_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Status) -> fmi2Status {
    // SAFETY: the contract is status's.
    unsafe { status::<M, fmi2Status>(c, "fmi2GetStatus", s, value, |_, _| None) }
}
/// # Safety
/// As [`get_status`].
pub unsafe fn get_real_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut f64) -> fmi2Status {
    let answer = |inst: &Instance<M>, k| (k == fmi2LastSuccessfulTime).then_some(inst.time);
    // SAFETY: the contract is status's.
    unsafe { status::<M, f64>(c, "fmi2GetRealStatus", s, value, answer) }
}
/// # Safety
/// As [`get_status`].
pub unsafe fn get_integer_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut i32) -> fmi2Status {
    // SAFETY: the contract is status's.
    unsafe { status::<M, i32>(c, "fmi2GetIntegerStatus", s, value, |_, _| None) }
}
/// # Safety
/// As [`get_status`].
pub unsafe fn get_boolean_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut i32) -> fmi2Status {
    let answer =
        |inst: &Instance<M>, k| (k == fmi2Terminated).then_some(if inst.terminated { fmi2True } else { fmi2False });
    // SAFETY: the contract is status's.
    unsafe { status::<M, i32>(c, "fmi2GetBooleanStatus", s, value, answer) }
}
/// # Safety
/// As [`get_status`].
pub unsafe fn get_string_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2String) -> fmi2Status {
    // SAFETY: the contract is status's.
    unsafe { status::<M, fmi2String>(c, "fmi2GetStringStatus", s, value, |_, _| None) }
}
