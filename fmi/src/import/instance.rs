//! One instance of an imported FMU: the safe API over its C functions.

use std::ffi::{CStr, CString, c_char, c_int};
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

use super::api::Api;
use super::log::{LogMessage, LogSink};
use super::v3::Calls3;
use super::{Binary, Capability, Error, Fmu};
use crate::description::{Causality, VarType};
use crate::ffi::*;

/// A saved FMU state, owned by the instance that made it (freed with it).
#[derive(Debug, PartialEq, Eq)]
pub struct FmuState {
    id: u64,
}

/// One FMU instance of either FMI version. Freed (`fmi2FreeInstance`, `fmi3FreeInstance`) on drop. `Send`: an instance may move between
/// threads, but it is not shared (`&mut self` for every call).
///
/// The invariants every call into the FMU relies on: `component` is what `fmi2Instantiate`
/// returned (non-null) and is freed only on drop; `fmu` keeps the binary, so every function
/// pointer, loaded; `sink` and `_callbacks` are boxed, so the addresses the FMU was given stay
/// valid until the instance is freed; every raw state in `states` was made by this component
/// and is freed exactly once.
pub struct Instance {
    pub(super) fmu: Fmu,
    pub(super) component: fmi2Component,
    pub(super) name: String,
    pub(super) sink: Box<LogSink>,
    /// FMI 2.0: the callbacks the component was given.
    pub(super) _callbacks: Option<Box<fmi2CallbackFunctions>>,
    pub(super) states: Vec<(u64, fmi2FMUstate)>,
    /// FMI 3.0: what the calls keep (plans, buffers, the step's end).
    pub(super) v3: Option<Box<Calls3>>,
}

// SAFETY: FMI 2.0 instances carry no thread affinity (the standard asks only that one instance
// is not called from two threads at once), and `&mut self` on every call makes `Instance` used
// by one thread at a time; `LogSink` is Sync (a Mutex).
unsafe impl Send for Instance {}

impl fmt::Debug for Instance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Instance({} of {})", self.name, self.fmu.name())
    }
}

/// Calls function `$f` of the binary's version (the state functions of FMI 2.0 and 3.0 take the
/// same C types), with the standard's name of that version: `(status, name)`.
macro_rules! either {
    ($self:ident . $f:ident ( $($arg:expr),* ), $n2:literal, $n3:literal) => {
        match &$self.fmu.inner.api {
            Binary::V2(a) => ((a.$f)($($arg),*), $n2),
            Binary::V3(a) => ((a.$f)($($arg),*), $n3),
        }
    };
}

fn same_len(what: &str, a: usize, b: usize) -> Result<(), Error> {
    if a == b { Ok(()) } else { Err(Error::Usage(format!("{what}: {a} value references but {b} values"))) }
}

impl Instance {
    pub fn fmu(&self) -> &Fmu {
        &self.fmu
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Take all messages logged so far.
    pub fn take_messages(&mut self) -> Vec<LogMessage> {
        self.sink.take()
    }

    pub(super) fn api(&self) -> &Api {
        match &self.fmu.inner.api {
            Binary::V2(api) => api,
            Binary::V3(_) => unreachable!("an FMI 2.0 call on an FMI 3.0 instance"),
        }
    }

    /// The Co-Simulation functions; an instance loaded as Model Exchange has none.
    fn cs(&self) -> Result<&super::api::Cs, Error> {
        self.api().cs.as_ref().ok_or_else(|| self.wrong_interface())
    }

    /// The error for a call of the other interface than the one loaded.
    pub(super) fn wrong_interface(&self) -> Error {
        Error::Usage(format!(
            "FMU `{}` (instance `{}`) is loaded as {}: that function belongs to the other interface",
            self.fmu.name(),
            self.name,
            self.fmu.interface().name()
        ))
    }

    pub(super) fn check(&self, function: &'static str, status: fmi2Status) -> Result<(), Error> {
        if status == fmi2OK || status == fmi2Warning {
            Ok(())
        } else {
            Err(Error::Call {
                fmu: self.fmu.name().to_owned(),
                instance: self.name.clone(),
                function,
                status,
                messages: self.sink.recent(),
            })
        }
    }

    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<(), Error> {
        let owned: Vec<CString> = categories
            .iter()
            .map(|c| CString::new(*c).map_err(|_| Error::Usage(format!("category `{c}` contains NUL"))))
            .collect::<Result<_, _>>()?;
        let ptrs: Vec<fmi2String> = owned.iter().map(|c| c.as_ptr()).collect();
        if self.v3.is_some() {
            return self.set_debug_logging3(on, &ptrs);
        }
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); the arrays hold
        // `vrs.len()` elements (checked, or built from `vrs`) and outlive the call.
        let s = unsafe { (self.api().set_debug_logging)(self.component, c_int::from(on), ptrs.len(), ptrs.as_ptr()) };
        self.check("fmi2SetDebugLogging", s)
    }

    pub fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Result<(), Error> {
        if self.v3.is_some() {
            self.setup_experiment3(tolerance, start, stop);
            return Ok(());
        }
        // SAFETY: a live component and its loaded function (the invariants of `Instance`).
        let s = unsafe {
            (self.api().setup_experiment)(
                self.component,
                c_int::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start,
                c_int::from(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        };
        self.check("fmi2SetupExperiment", s)
    }

    pub fn enter_initialization_mode(&mut self) -> Result<(), Error> {
        if self.v3.is_some() {
            return self.enter_initialization_mode3();
        }
        self.call_plain(self.api().enter_initialization_mode, "fmi2EnterInitializationMode")
    }

    pub fn exit_initialization_mode(&mut self) -> Result<(), Error> {
        if self.v3.is_some() {
            return self.exit_initialization_mode3();
        }
        self.call_plain(self.api().exit_initialization_mode, "fmi2ExitInitializationMode")
    }

    pub fn terminate(&mut self) -> Result<(), Error> {
        if self.v3.is_some() {
            return self.terminate3();
        }
        self.call_plain(self.api().terminate, "fmi2Terminate")
    }

    pub fn reset(&mut self) -> Result<(), Error> {
        if self.v3.is_some() {
            return self.reset3();
        }
        self.call_plain(self.api().reset, "fmi2Reset")
    }

    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), Error> {
        same_len("get_real", vrs.len(), out.len())?;
        if self.v3.is_some() {
            return self.get_real3(vrs, out);
        }
        self.get2(self.api().get_real, "fmi2GetReal", vrs, out)
    }

    pub fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Result<(), Error> {
        same_len("get_integer", vrs.len(), out.len())?;
        if self.v3.is_some() {
            return self.get_integer3(vrs, out);
        }
        self.get2(self.api().get_integer, "fmi2GetInteger", vrs, out)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [bool]) -> Result<(), Error> {
        same_len("get_boolean", vrs.len(), out.len())?;
        if self.v3.is_some() {
            return self.get_boolean3(vrs, out);
        }
        let mut raw = vec![0 as fmi2Boolean; vrs.len()];
        self.get2(self.api().get_boolean, "fmi2GetBoolean", vrs, &mut raw)?;
        for (o, r) in out.iter_mut().zip(raw) {
            *o = r != fmi2False;
        }
        Ok(())
    }

    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>, Error> {
        if self.v3.is_some() {
            return self.get_string3(vrs);
        }
        let mut raw = vec![std::ptr::null::<c_char>(); vrs.len()];
        self.get2(self.api().get_string, "fmi2GetString", vrs, &mut raw)?;
        // Copy at once: the FMU's strings are valid only until its next call.
        let copy = |p: fmi2String| {
            // SAFETY: fmi2GetString succeeded, so each non-null pointer is a NUL-terminated string
            // of the FMU, valid until its next call (FMI 2.0); it is copied before that.
            if p.is_null() { String::new() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
        };
        Ok(raw.into_iter().map(copy).collect())
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), Error> {
        same_len("set_real", vrs.len(), values.len())?;
        if self.v3.is_some() {
            return self.set_real3(vrs, values);
        }
        self.set2(self.api().set_real, "fmi2SetReal", vrs, values)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), Error> {
        same_len("set_integer", vrs.len(), values.len())?;
        if self.v3.is_some() {
            return self.set_integer3(vrs, values);
        }
        self.set2(self.api().set_integer, "fmi2SetInteger", vrs, values)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), Error> {
        same_len("set_boolean", vrs.len(), values.len())?;
        if self.v3.is_some() {
            return self.set_boolean3(vrs, values);
        }
        let raw: Vec<fmi2Boolean> = values.iter().map(|&b| c_int::from(b)).collect();
        self.set2(self.api().set_boolean, "fmi2SetBoolean", vrs, &raw)
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), Error> {
        same_len("set_string", vrs.len(), values.len())?;
        if self.v3.is_some() {
            return self.set_string3(vrs, values);
        }
        let owned: Vec<CString> = values
            .iter()
            .map(|v| CString::new(*v).map_err(|_| Error::Usage(format!("string `{v}` contains a NUL byte"))))
            .collect::<Result<_, _>>()?;
        let ptrs: Vec<fmi2String> = owned.iter().map(|c| c.as_ptr()).collect();
        self.set2(self.api().set_string, "fmi2SetString", vrs, &ptrs)
    }

    /// An `fmi2Get*` function of C type `T`: the values of `vrs` into `out`.
    fn get2<T>(&self, f: fmi2GetTYPE<T>, function: &'static str, vrs: &[u32], out: &mut [T]) -> Result<(), Error> {
        assert_eq!(vrs.len(), out.len(), "one value per value reference");
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); the
        // arrays hold `vrs.len()` elements (asserted) and outlive the call.
        let s = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        self.check(function, s)
    }

    /// An `fmi2Set*` function of C type `T`: `vrs` set to `values`.
    fn set2<T>(&self, f: fmi2SetTYPE<T>, function: &'static str, vrs: &[u32], values: &[T]) -> Result<(), Error> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        // SAFETY: as in `get2`.
        let s = unsafe { f(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check(function, s)
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint = false)`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Error> {
        if self.v3.is_some() {
            return self.do_step3(t, h);
        }
        // SAFETY: a live component and its loaded function (the invariants of `Instance`).
        let s = unsafe { (self.cs()?.do_step)(self.component, t, h, fmi2False) };
        self.check("fmi2DoStep", s)
    }

    /// `fmi2CancelStep` (only meaningful for asynchronous FMUs).
    pub fn cancel_step(&mut self) -> Result<(), Error> {
        if self.v3.is_some() {
            return Err(Error::Usage("FMI 3.0 has no fmi3CancelStep (no asynchronous steps)".into()));
        }
        self.call_plain(self.cs()?.cancel_step, "fmi2CancelStep")
    }

    /// A function of this FMU that takes only the component.
    fn call_plain(&mut self, f: fmi2ComponentOnlyTYPE, function: &'static str) -> Result<(), Error> {
        // SAFETY: a live component, and `f` one of its loaded functions (the invariants of `Instance`).
        let s = unsafe { f(self.component) };
        self.check(function, s)
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn last_successful_time(&mut self) -> Result<f64, Error> {
        if self.v3.is_some() {
            return Ok(self.last_successful_time3());
        }
        let mut t = f64::NAN;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); the answer goes to a
        // local.
        let s = unsafe { (self.cs()?.get_real_status)(self.component, fmi2LastSuccessfulTime, &mut t) };
        self.check("fmi2GetRealStatus", s)?;
        Ok(t)
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`.
    pub fn terminated(&mut self) -> Result<bool, Error> {
        if self.v3.is_some() {
            return Ok(self.terminated3());
        }
        let mut b = fmi2False;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); the answer goes to a
        // local.
        let s = unsafe { (self.cs()?.get_boolean_status)(self.component, fmi2Terminated, &mut b) };
        self.check("fmi2GetBooleanStatus", s)?;
        Ok(b != fmi2False)
    }

    /// Save the current state (`fmi2GetFMUstate`). Requires [`Capability::GetSetState`].
    pub fn get_state(&mut self) -> Result<FmuState, Error> {
        self.fmu.require(Capability::GetSetState)?;
        let mut raw: fmi2FMUstate = std::ptr::null_mut();
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is null or a state
        // this component made and has not freed (`states`).
        let (s, name) =
            unsafe { either!(self.get_fmu_state(self.component, &mut raw), "fmi2GetFMUstate", "fmi3GetFMUState") };
        self.check(name, s)?;
        Ok(self.adopt(raw))
    }

    fn adopt(&mut self, raw: fmi2FMUstate) -> FmuState {
        // Unique across instances, so a state cannot be used with an instance that did not make it.
        static NEXT_ID: AtomicU64 = AtomicU64::new(1);
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        self.states.push((id, raw));
        FmuState { id }
    }

    fn raw_state(&self, state: &FmuState) -> Result<(usize, fmi2FMUstate), Error> {
        self.states
            .iter()
            .position(|(id, _)| *id == state.id)
            .map(|i| (i, self.states[i].1))
            .ok_or_else(|| Error::Usage(format!("FMU state {} does not belong to instance `{}`", state.id, self.name)))
    }

    /// Overwrite an existing saved state with the current one (no allocation in the FMU).
    pub fn update_state(&mut self, state: &FmuState) -> Result<(), Error> {
        let (i, mut raw) = self.raw_state(state)?;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is null or a state
        // this component made and has not freed (`states`).
        let (s, name) =
            unsafe { either!(self.get_fmu_state(self.component, &mut raw), "fmi2GetFMUstate", "fmi3GetFMUState") };
        self.states[i].1 = raw;
        self.check(name, s)
    }

    /// Restore a saved state (`fmi2SetFMUstate`).
    pub fn set_state(&mut self, state: &FmuState) -> Result<(), Error> {
        let (_, raw) = self.raw_state(state)?;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is a state this
        // component made and has not freed (`states`).
        let (s, name) =
            unsafe { either!(self.set_fmu_state(self.component, raw), "fmi2SetFMUstate", "fmi3SetFMUState") };
        if self.v3.is_some() {
            self.state_restored3();
        }
        self.check(name, s)
    }

    /// Free a saved state now (otherwise it is freed with the instance).
    pub fn free_state(&mut self, state: FmuState) -> Result<(), Error> {
        let (i, mut raw) = self.raw_state(&state)?;
        self.states.swap_remove(i);
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is a state this
        // component made and has not freed (`states`).
        let (s, name) =
            unsafe { either!(self.free_fmu_state(self.component, &mut raw), "fmi2FreeFMUstate", "fmi3FreeFMUState") };
        self.check(name, s)
    }

    /// Serialize a saved state to bytes. Requires [`Capability::SerializeState`].
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>, Error> {
        self.fmu.require(Capability::SerializeState)?;
        let (_, raw) = self.raw_state(state)?;
        let mut size = 0usize;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is a state this
        // component made and has not freed (`states`).
        let (s, name) = unsafe {
            either!(
                self.serialized_fmu_state_size(self.component, raw, &mut size),
                "fmi2SerializedFMUstateSize",
                "fmi3SerializedFMUStateSize"
            )
        };
        self.check(name, s)?;
        let mut bytes = vec![0u8; size];
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `raw` is a live state of
        // this component; `bytes` holds `size` bytes.
        let (s, name) = unsafe {
            either!(
                self.serialize_fmu_state(self.component, raw, bytes.as_mut_ptr().cast(), size),
                "fmi2SerializeFMUstate",
                "fmi3SerializeFMUState"
            )
        };
        self.check(name, s)?;
        Ok(bytes)
    }

    /// A saved state from bytes made by [`Instance::serialize_state`] (of an instance of the same FMU).
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState, Error> {
        self.fmu.require(Capability::SerializeState)?;
        let mut raw: fmi2FMUstate = std::ptr::null_mut();
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); `bytes` holds
        // `bytes.len()` bytes; the new state goes to a local.
        let (s, name) = unsafe {
            either!(
                self.deserialize_fmu_state(self.component, bytes.as_ptr().cast(), bytes.len(), &mut raw),
                "fmi2DeSerializeFMUstate",
                "fmi3DeserializeFMUState"
            )
        };
        self.check(name, s)?;
        Ok(self.adopt(raw))
    }

    /// `out = J · seed` with `J = ∂unknowns/∂knowns`. Requires [`Capability::DirectionalDerivative`].
    pub fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), Error> {
        self.fmu.require(Capability::DirectionalDerivative)?;
        if self.v3.is_some() {
            same_len("directional_derivative", knowns.len(), seed.len())?;
            same_len("directional_derivative", unknowns.len(), out.len())?;
            let f = self.api3().get_directional_derivative;
            return self.derivative3("fmi3GetDirectionalDerivative", f, unknowns, knowns, seed, out);
        }
        let f = self.api().get_directional_derivative;
        self.derivative("fmi2GetDirectionalDerivative", f, unknowns, knowns, seed, out)
    }

    /// The extension `feedsimGetStepMapDerivative`: `out = J · seed` with `J` the derivative of
    /// the last step's map (unknowns after the last `do_step` with respect to the knowns held
    /// during it). Requires [`Capability::StepMapDerivative`].
    pub fn step_map_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), Error> {
        self.fmu.require(Capability::StepMapDerivative)?;
        if self.v3.is_some() {
            same_len("step_map_derivative", knowns.len(), seed.len())?;
            same_len("step_map_derivative", unknowns.len(), out.len())?;
            let f = self.api3().step_map_derivative.ok_or_else(|| self.no_step_map_derivative())?;
            return self.derivative3("feedsim3GetStepMapDerivative", f, unknowns, knowns, seed, out);
        }
        let f = self.api().step_map_derivative.ok_or_else(|| self.no_step_map_derivative())?;
        self.derivative("feedsimGetStepMapDerivative", f, unknowns, knowns, seed, out)
    }

    /// The error for a binary without the step map's derivative (announced by the description).
    fn no_step_map_derivative(&self) -> Error {
        Error::Capability { fmu: self.fmu.name().to_owned(), capability: Capability::StepMapDerivative }
    }

    /// Calls a function with the signature of `fmi2GetDirectionalDerivative` (`name` in errors).
    fn derivative(
        &mut self,
        name: &'static str,
        f: fmi2GetDirectionalDerivativeTYPE,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), Error> {
        same_len(name, knowns.len(), seed.len())?;
        same_len(name, unknowns.len(), out.len())?;
        // SAFETY: a live component and a function of this FMU's loaded library with the signature of
        // fmi2GetDirectionalDerivative (the invariants of `Instance`); every array holds the length
        // passed with it (checked above).
        let s = unsafe {
            f(
                self.component,
                unknowns.as_ptr(),
                unknowns.len(),
                knowns.as_ptr(),
                knowns.len(),
                seed.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        self.check(name, s)
    }

    /// Input derivatives of the given orders at the current communication point.
    /// Requires [`Capability::InterpolateInputs`].
    pub fn set_real_input_derivatives(&mut self, vrs: &[u32], orders: &[i32], values: &[f64]) -> Result<(), Error> {
        self.fmu.require(Capability::InterpolateInputs)?;
        same_len("set_real_input_derivatives", vrs.len(), values.len())?;
        same_len("set_real_input_derivatives (orders)", vrs.len(), orders.len())?;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); every array holds the
        // length passed with it (checked above).
        let s = unsafe {
            (self.cs()?.set_real_input_derivatives)(
                self.component,
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                values.as_ptr(),
            )
        };
        self.check("fmi2SetRealInputDerivatives", s)
    }

    /// Output derivatives. Requires [`Capability::OutputDerivatives`].
    pub fn get_real_output_derivatives(&mut self, vrs: &[u32], orders: &[i32], out: &mut [f64]) -> Result<(), Error> {
        self.fmu.require(Capability::OutputDerivatives)?;
        if self.v3.is_some() {
            return Err(Error::Usage("fmi3GetOutputDerivatives is not supported by this importer".into()));
        }
        same_len("get_real_output_derivatives", vrs.len(), out.len())?;
        same_len("get_real_output_derivatives (orders)", vrs.len(), orders.len())?;
        // SAFETY: a live component and its loaded function (the invariants of `Instance`); every array holds the
        // length passed with it (checked above).
        let s = unsafe {
            (self.cs()?.get_real_output_derivatives)(
                self.component,
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        self.check("fmi2GetRealOutputDerivatives", s)
    }

    /// Value references of all variables with this causality and type, in description order.
    pub fn value_references(&self, causality: Causality, var_type: VarType) -> Vec<u32> {
        self.fmu
            .description()
            .variables
            .iter()
            .filter(|v| v.causality == causality && v.var_type == var_type)
            .map(|v| v.value_reference)
            .collect()
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: a live component and its loaded functions (the invariants of `Instance`); each
        // state was made by this component and is freed once; the component is not used again.
        unsafe {
            for (_, mut raw) in std::mem::take(&mut self.states) {
                let _ = either!(self.free_fmu_state(self.component, &mut raw), "", "");
            }
            match &self.fmu.inner.api {
                Binary::V2(a) => (a.free_instance)(self.component),
                Binary::V3(a) => (a.free_instance)(self.component),
            }
        }
    }
}
