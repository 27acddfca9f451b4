//! The bodies of the Model Exchange functions, shared by the FMI 2.0 and FMI 3.0 exports (each
//! passes its function's name): the modes of the event iteration, time, continuous states,
//! derivatives and event indicators. Not for direct use.
//!
//! Contract of every `unsafe fn` here: that of [`super::exported`] (`c` an instance of this
//! layer for the same `M`, arrays of the lengths passed with them), or of `fmi3` likewise.

use super::exported::{ALL_BUT_FATAL, GETTABLE, call, finite, slice, slice_mut};
use super::instance::{Instance, Phase};
use super::{DiscreteUpdate, Model};
use crate::ffi::*;
use Phase::{ContinuousTime, EventMode};

/// The instance's Model Exchange part, or why the call does not apply.
fn me<M: Model>(inst: &Instance<M>) -> Result<&super::instance::MeInstance, String> {
    inst.me.as_ref().ok_or_else(|| "the instance is not of Model Exchange".to_owned())
}

/// Enter event mode (from continuous-time mode, or again at the same event).
///
/// # Safety
/// As the module's contract.
pub unsafe fn enter_event_mode<M: Model>(c: fmi2Component, func: &'static str) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        // every phase but the fatal one: a Co-Simulation instance is told why before the phase
        call::<M>(c, func, ALL_BUT_FATAL, |inst| {
            if inst.me.is_none() && inst.v3.is_some() {
                return Err("this FMU has no event mode in Co-Simulation (hasEventMode = false)".into());
            }
            me(inst)?;
            if !matches!(inst.phase, EventMode | ContinuousTime) {
                return Err(format!("not allowed in state `{}`", inst.phase.name()));
            }
            inst.phase = EventMode;
            Ok(fmi2OK)
        })
    }
}

/// Enter continuous-time mode (after the event iteration).
///
/// # Safety
/// As the module's contract.
pub unsafe fn enter_continuous_time_mode<M: Model>(c: fmi2Component, func: &'static str) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, &[EventMode], |inst| {
            me(inst)?;
            inst.phase = ContinuousTime;
            Ok(fmi2OK)
        })
    }
}

/// An accepted integrator step: no step event, no end.
///
/// # Safety
/// As the module's contract; the two pointers are writable.
pub unsafe fn completed_integrator_step<M: Model, B: From<bool>>(
    c: fmi2Component,
    func: &'static str,
    enter_event_mode: *mut B,
    terminate: *mut B,
) -> fmi2Status {
    // SAFETY: `c` and the pointers as the contract says.
    unsafe {
        call::<M>(c, func, &[ContinuousTime], |inst| {
            me(inst)?;
            slice_mut(enter_event_mode, 1, "enterEventMode")?[0] = B::from(false);
            slice_mut(terminate, 1, "terminateSimulation")?[0] = B::from(false);
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract.
pub unsafe fn set_time<M: Model>(c: fmi2Component, func: &'static str, t: f64) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, &[EventMode, ContinuousTime], |inst| {
            me(inst)?;
            if let Some(why) = finite(t) {
                return Err(format!("time = {why}"));
            }
            inst.model.set_time(t).map_err(|e| super::instance::error_chain(&*e))?;
            inst.time = t;
            Ok(fmi2OK)
        })
    }
}

/// # Safety
/// As the module's contract; `x` holds `n` values.
pub unsafe fn set_continuous_states<M: Model>(
    c: fmi2Component,
    func: &'static str,
    x: *const f64,
    n: usize,
) -> fmi2Status {
    // SAFETY: `c` and the array as the contract says.
    unsafe {
        call::<M>(c, func, &[ContinuousTime], |inst| {
            let declared = me(inst)?.states.len();
            let x = slice(x, n, "x")?;
            if n != declared {
                return Err(format!("{n} continuous states given, the model has {declared}"));
            }
            if let Some((k, v)) = x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(format!("continuous state {k} = {v} at t = {}: not a finite number", inst.time));
            }
            inst.model.set_continuous_states(x).map_err(|e| super::instance::error_chain(&*e))?;
            Ok(fmi2OK)
        })
    }
}

/// Which Reals of the model an array call reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    States,
    Derivatives,
}

/// The continuous states or their derivatives into `x` (`n` values). A non-finite value is the
/// model's error, reported naming the variable and the time.
///
/// # Safety
/// As the module's contract; `x` holds `n` writable values.
pub unsafe fn get_reals<M: Model>(
    c: fmi2Component,
    func: &'static str,
    which: Which,
    x: *mut f64,
    n: usize,
) -> fmi2Status {
    // SAFETY: `c` and the array as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            let m = me(inst)?;
            let vrs = if which == Which::States { &m.states } else { &m.derivatives };
            if n != vrs.len() {
                return Err(format!("{n} values asked for, the model has {} continuous states", vrs.len()));
            }
            let out = slice_mut(x, n, "x")?;
            // the value references live in the instance, which the model call borrows too
            let vrs = std::mem::take(if which == Which::States {
                &mut inst.me.as_mut().expect("me").states
            } else {
                &mut inst.me.as_mut().expect("me").derivatives
            });
            let result = inst.model.get_reals(&vrs, out);
            let bad = out.iter().position(|v| !v.is_finite());
            let vr = |k: usize| vrs[k];
            let message = match (result, bad) {
                (Err((k, e)), _) => Some(format!("value reference {}: {}", vr(k), super::instance::error_chain(&*e))),
                (Ok(()), Some(k)) => Some(format!(
                    "{} = {} at t = {}: not a finite number",
                    inst.info.lookup(crate::VarType::Real, vr(k)).map_or("?", |v| v.var.name.as_str()),
                    out[k],
                    inst.time
                )),
                (Ok(()), None) => None,
            };
            let m = inst.me.as_mut().expect("me");
            *(if which == Which::States { &mut m.states } else { &mut m.derivatives }) = vrs;
            message.map_or(Ok(fmi2OK), Err)
        })
    }
}

/// # Safety
/// As the module's contract; `z` holds `n` writable values.
pub unsafe fn event_indicators<M: Model>(c: fmi2Component, func: &'static str, z: *mut f64, n: usize) -> fmi2Status {
    // SAFETY: `c` and the array as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            let declared = me(inst)?.event_indicators;
            if n != declared {
                return Err(format!("{n} event indicators asked for, the model has {declared}"));
            }
            let z = slice_mut(z, n, "eventIndicators")?;
            inst.model.event_indicators(z).map_err(|e| super::instance::error_chain(&*e))?;
            if let Some(k) = z.iter().position(|v| !v.is_finite()) {
                return Err(format!("event indicator {k} = {} at t = {}: not a finite number", z[k], inst.time));
            }
            Ok(fmi2OK)
        })
    }
}

/// Nominal values of the states: 1 (the model gives none).
///
/// # Safety
/// As the module's contract; `x` holds `n` writable values.
pub unsafe fn nominals<M: Model>(c: fmi2Component, func: &'static str, x: *mut f64, n: usize) -> fmi2Status {
    // SAFETY: `c` and the array as the contract says.
    unsafe {
        call::<M>(c, func, GETTABLE, |inst| {
            let declared = me(inst)?.states.len();
            if n != declared {
                return Err(format!("{n} nominals asked for, the model has {declared} continuous states"));
            }
            slice_mut(x, n, "x")?.fill(1.0);
            Ok(fmi2OK)
        })
    }
}

/// One update of the discrete states in event mode; `report` writes the answer the version's way.
///
/// # Safety
/// As the module's contract.
pub unsafe fn update_discrete_states<M: Model>(
    c: fmi2Component,
    func: &'static str,
    report: impl FnOnce(&DiscreteUpdate) -> Result<(), String>,
) -> fmi2Status {
    // SAFETY: `c` as the contract says.
    unsafe {
        call::<M>(c, func, &[EventMode], |inst| {
            me(inst)?;
            let update = inst.model.update_discrete_states(inst.time).map_err(|e| super::instance::error_chain(&*e))?;
            if let Some(t) = update.next_event_time
                && !(t.is_finite() && t >= inst.time)
            {
                return Err(format!("the model's next time event {t} is not at or after t = {}", inst.time));
            }
            if let Some(why) = &update.terminate {
                inst.terminated = true;
                inst.log(fmi2OK, &format!("{func}: the model ends the simulation at t = {}: {why}", inst.time));
            }
            report(&update)?;
            Ok(fmi2OK)
        })
    }
}

/// The number of continuous states the model reports (FMI 3.0).
///
/// # Safety
/// As the module's contract; `n` is writable.
pub unsafe fn number_of_states<M: Model>(c: fmi2Component, func: &'static str, n: *mut usize) -> fmi2Status {
    // SAFETY: `c` and `n` as the contract says.
    unsafe {
        call::<M>(c, func, super::exported::ALL_BUT_FATAL, |inst| {
            let declared = inst.me.as_ref().map_or(0, |m| m.states.len());
            slice_mut(n, 1, "nContinuousStates")?[0] = inst.model.reported_state_count(declared);
            Ok(fmi2OK)
        })
    }
}

/// The number of event indicators (FMI 3.0).
///
/// # Safety
/// As the module's contract; `n` is writable.
pub unsafe fn number_of_event_indicators<M: Model>(c: fmi2Component, func: &'static str, n: *mut usize) -> fmi2Status {
    // SAFETY: `c` and `n` as the contract says.
    unsafe {
        call::<M>(c, func, super::exported::ALL_BUT_FATAL, |inst| {
            slice_mut(n, 1, "nEventIndicators")?[0] = inst.me.as_ref().map_or(0, |m| m.event_indicators);
            Ok(fmi2OK)
        })
    }
}
