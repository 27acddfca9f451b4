//! The calls of an FMI 3.0 instance: the scalar view's value references gathered into whole
//! variables (arrays) for each call and the values scattered back, with the plan of each set
//! of value references kept for the next call with the same set.

use std::ffi::{CStr, CString, c_char};

use super::api3::Api3;
use super::{Binary, Error, Instance};
use crate::description::VarType;
use crate::fmi3::ffi::*;

/// How one call's scalars map onto the FMI 3.0 variables.
#[derive(Debug)]
struct Plan {
    var_type: VarType,
    /// The view's value references of the call (what the plan is found by).
    scalars: Vec<u32>,
    /// The FMI 3.0 variables they belong to, in order of first appearance.
    vars: Vec<u32>,
    /// Per scalar: its position in the concatenated values of `vars`.
    at: Vec<usize>,
    total: usize,
    /// Some variable is not covered by the call in full (a set must read the rest first).
    partial: bool,
}

/// Plans kept per instance before the cache is emptied.
const PLANS: usize = 64;

/// The values of one call's whole variables, reused.
#[derive(Debug, Default)]
pub(crate) struct Buffers {
    reals: Vec<f64>,
    seeds: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<u8>,
}

/// What an FMI 3.0 instance keeps between calls.
#[derive(Debug, Default)]
pub(crate) struct Calls3 {
    plans: Vec<Plan>,
    buf: Buffers,
    /// `setup_experiment`'s arguments, passed on by `enter_initialization_mode`.
    experiment: (Option<f64>, f64, Option<f64>),
    step_mode: bool,
    /// A value was set in step mode since the last step: FMI 3.0 forbids a get now.
    set_since_step: bool,
    last_successful_time: f64,
    terminated: bool,
}

impl Instance {
    pub(super) fn api3(&self) -> &Api3 {
        match &self.fmu.inner.api {
            Binary::V3(api) => api,
            Binary::V2(_) => unreachable!("an FMI 3.0 call on an FMI 2.0 instance"),
        }
    }

    pub(super) fn calls3(&mut self) -> &mut Calls3 {
        self.v3.as_mut().expect("an FMI 3.0 instance")
    }

    /// The index of the plan for `scalars` of type `t`, made if new.
    fn plan(&mut self, t: VarType, scalars: &[u32]) -> Result<usize, Error> {
        let calls = self.v3.as_mut().expect("an FMI 3.0 instance");
        if let Some(i) = calls.plans.iter().position(|p| p.var_type == t && p.scalars == scalars) {
            return Ok(i);
        }
        let inner = &self.fmu.inner;
        let elements = &inner.v3.as_ref().expect("an FMI 3.0 FMU").elements;
        let mut plan =
            Plan { var_type: t, scalars: scalars.to_vec(), vars: Vec::new(), at: Vec::new(), total: 0, partial: false };
        let mut bases: Vec<usize> = Vec::new();
        for &s in scalars {
            let variable = inner.description.variables.get(s as usize).filter(|v| v.var_type == t);
            let (Some(_), Some(e)) = (variable, elements.get(s as usize)) else {
                return Err(Error::Usage(format!(
                    "FMU `{}`: value reference {s} is no {} variable of its view",
                    inner.description.model_identifier,
                    t.as_str()
                )));
            };
            let k = match plan.vars.iter().position(|&v| v == e.vr) {
                Some(k) => k,
                None => {
                    plan.vars.push(e.vr);
                    bases.push(plan.total);
                    plan.total += e.len;
                    plan.vars.len() - 1
                }
            };
            plan.at.push(bases[k] + e.index);
        }
        let mut covered = plan.at.clone();
        covered.sort_unstable();
        covered.dedup();
        plan.partial = covered.len() != plan.total;
        if calls.plans.len() == PLANS {
            calls.plans.clear();
        }
        calls.plans.push(plan);
        Ok(calls.plans.len() - 1)
    }

    fn check_get3(&self, function: &str) -> Result<(), Error> {
        if self.v3.as_ref().is_some_and(|c| c.set_since_step) {
            return Err(Error::Usage(format!(
                "FMU `{}` (instance `{}`): {function} after a set in step mode without fmi3DoStep in between \
                 (FMI 3.0 forbids it: outputs change only in fmi3DoStep)",
                self.fmu.name(),
                self.name
            )));
        }
        Ok(())
    }

    fn mark_set3(&mut self) {
        let calls = self.calls3();
        calls.set_since_step |= calls.step_mode;
    }

    /// Reads the whole variables of plan `i` into `buffer` with `get`.
    fn read3<T: Copy + Default>(
        &mut self,
        i: usize,
        get: fmi3GetTYPE<T>,
        function: &'static str,
        buffer: impl Fn(&mut Buffers) -> &mut Vec<T>,
    ) -> Result<(), Error> {
        let component = self.component;
        let calls = self.calls3();
        let plan = &calls.plans[i];
        let (vars, total) = (plan.vars.as_ptr(), plan.vars.len());
        let n = plan.total;
        let buf = buffer(&mut calls.buf);
        buf.resize(n, T::default());
        // SAFETY: a live instance and a function of its loaded binary (the invariants of
        // `Instance`); `vars` holds `total` value references (the plan, not changed while the
        // call runs) and the buffer `n` writable values, the number their variables hold.
        let s = unsafe { get(component, vars, total, buf.as_mut_ptr(), n) };
        self.check(function, s)
    }

    /// The values of `vrs` (of type `t`) into `out`, each as `convert` makes it from the C value.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn get3<T: Copy + Default, U>(
        &mut self,
        t: VarType,
        vrs: &[u32],
        out: &mut [U],
        get: fmi3GetTYPE<T>,
        function: &'static str,
        buffer: impl Fn(&mut Buffers) -> &mut Vec<T> + Copy,
        convert: impl Fn(T) -> U,
    ) -> Result<(), Error> {
        self.check_get3(function)?;
        let i = self.plan(t, vrs)?;
        self.read3(i, get, function, buffer)?;
        let calls = self.calls3();
        let buf = buffer(&mut calls.buf);
        for (o, &a) in out.iter_mut().zip(&calls.plans[i].at) {
            *o = convert(buf[a]);
        }
        Ok(())
    }

    /// Sets `vrs` (of type `t`) to `values`, each as `convert` makes the C value of it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn set3<T: Copy + Default, U: Copy>(
        &mut self,
        t: VarType,
        vrs: &[u32],
        values: &[U],
        (get, set): (fmi3GetTYPE<T>, fmi3SetTYPE<T>),
        (get_name, set_name): (&'static str, &'static str),
        buffer: impl Fn(&mut Buffers) -> &mut Vec<T> + Copy,
        convert: impl Fn(U) -> T,
    ) -> Result<(), Error> {
        let i = self.plan(t, vrs)?;
        if self.calls3().plans[i].partial {
            // the elements not set keep their values
            self.read3(i, get, get_name, buffer)?;
        } else {
            let calls = self.calls3();
            buffer(&mut calls.buf).resize(calls.plans[i].total, T::default());
        }
        let component = self.component;
        let calls = self.calls3();
        let plan = &calls.plans[i];
        let buf = buffer(&mut calls.buf);
        for (&a, &x) in plan.at.iter().zip(values) {
            buf[a] = convert(x);
        }
        // SAFETY: a live instance and a function of its loaded binary (the invariants of
        // `Instance`); the plan's variables and the buffer of their values outlive the call.
        let s = unsafe { set(component, plan.vars.as_ptr(), plan.vars.len(), buf.as_ptr(), plan.total) };
        self.check(set_name, s)?;
        self.mark_set3();
        Ok(())
    }

    pub(super) fn get_real3(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), Error> {
        let get = self.api3().get_float64;
        self.get3(VarType::Real, vrs, out, get, "fmi3GetFloat64", |b| &mut b.reals, |x| x)
    }

    pub(super) fn get_integer3(&mut self, vrs: &[u32], out: &mut [i32]) -> Result<(), Error> {
        let get = self.api3().get_int32;
        self.get3(VarType::Integer, vrs, out, get, "fmi3GetInt32", |b| &mut b.integers, |x| x)
    }

    pub(super) fn get_boolean3(&mut self, vrs: &[u32], out: &mut [bool]) -> Result<(), Error> {
        let get = self.api3().get_boolean;
        self.get3(VarType::Boolean, vrs, out, get, "fmi3GetBoolean", |b| &mut b.booleans, |x| x != fmi3False)
    }

    pub(super) fn set_real3(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), Error> {
        let api = self.api3();
        let fns = (api.get_float64, api.set_float64);
        self.set3(VarType::Real, vrs, values, fns, ("fmi3GetFloat64", "fmi3SetFloat64"), |b| &mut b.reals, |x| x)
    }

    pub(super) fn set_integer3(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), Error> {
        let api = self.api3();
        let fns = (api.get_int32, api.set_int32);
        let names = ("fmi3GetInt32", "fmi3SetInt32");
        self.set3(VarType::Integer, vrs, values, fns, names, |b| &mut b.integers, |x| x)
    }

    pub(super) fn set_boolean3(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), Error> {
        let api = self.api3();
        let fns = (api.get_boolean, api.set_boolean);
        let names = ("fmi3GetBoolean", "fmi3SetBoolean");
        self.set3(VarType::Boolean, vrs, values, fns, names, |b| &mut b.booleans, u8::from)
    }

    pub(super) fn get_string3(&mut self, vrs: &[u32]) -> Result<Vec<String>, Error> {
        self.check_get3("fmi3GetString")?;
        let i = self.plan(VarType::String, vrs)?;
        let whole = self.whole_strings(i)?;
        Ok(self.calls3().plans[i].at.iter().map(|&a| whole[a].clone()).collect())
    }

    pub(super) fn set_string3(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), Error> {
        let i = self.plan(VarType::String, vrs)?;
        let mut texts: Vec<String> = if self.calls3().plans[i].partial {
            self.whole_strings(i)?
        } else {
            vec![String::new(); self.calls3().plans[i].total]
        };
        let plan = &self.calls3().plans[i];
        let (vars, at) = (plan.vars.clone(), plan.at.clone());
        for (&a, v) in at.iter().zip(values) {
            (*v).clone_into(&mut texts[a]);
        }
        let owned: Vec<CString> = texts
            .iter()
            .map(|v| CString::new(v.as_str()).map_err(|_| Error::Usage(format!("string `{v}` contains a NUL byte"))))
            .collect::<Result<_, _>>()?;
        let ptrs: Vec<fmi3String> = owned.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`); the
        // arrays and the strings they point to outlive the call.
        let s =
            unsafe { (self.api3().set_string)(self.component, vars.as_ptr(), vars.len(), ptrs.as_ptr(), ptrs.len()) };
        self.check("fmi3SetString", s)?;
        self.mark_set3();
        Ok(())
    }

    /// Every element of plan `i`'s String variables, as they are now.
    fn whole_strings(&mut self, i: usize) -> Result<Vec<String>, Error> {
        let plan = &self.calls3().plans[i];
        let (vars, n) = (plan.vars.clone(), plan.total);
        let mut raw = vec![std::ptr::null::<c_char>(); n];
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`); `vars`
        // and `raw` (the `n` values of those variables) outlive the call.
        let s = unsafe { (self.api3().get_string)(self.component, vars.as_ptr(), vars.len(), raw.as_mut_ptr(), n) };
        self.check("fmi3GetString", s)?;
        // Copy at once: the FMU's strings are valid only until its next call.
        let copy = |p: fmi3String| {
            // SAFETY: fmi3GetString succeeded, so each non-null pointer is a NUL-terminated string
            // of the FMU, valid until its next call (FMI 3.0); it is copied before that.
            if p.is_null() { String::new() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
        };
        Ok(raw.into_iter().map(copy).collect())
    }

    pub(super) fn setup_experiment3(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) {
        self.calls3().experiment = (tolerance, start, stop);
    }

    pub(super) fn enter_initialization_mode3(&mut self) -> Result<(), Error> {
        let (tolerance, start, stop) = self.calls3().experiment;
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`).
        let s = unsafe {
            (self.api3().enter_initialization_mode)(
                self.component,
                u8::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start,
                u8::from(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        };
        self.calls3().last_successful_time = start;
        self.check("fmi3EnterInitializationMode", s)
    }

    pub(super) fn exit_initialization_mode3(&mut self) -> Result<(), Error> {
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`).
        let s = unsafe { (self.api3().exit_initialization_mode)(self.component) };
        self.check("fmi3ExitInitializationMode", s)?;
        // Model Exchange has no steps: values are read after values are set at any time
        self.calls3().step_mode = self.fmu.interface() == super::Interface::CoSimulation;
        Ok(())
    }

    pub(super) fn plain3(&mut self, f: fmi3InstanceOnlyTYPE, function: &'static str) -> Result<(), Error> {
        // SAFETY: a live instance, and `f` one of its loaded functions (the invariants of `Instance`).
        let s = unsafe { f(self.component) };
        self.check(function, s)
    }

    pub(super) fn terminate3(&mut self) -> Result<(), Error> {
        let f = self.api3().terminate;
        self.calls3().step_mode = false;
        self.plain3(f, "fmi3Terminate")
    }

    pub(super) fn reset3(&mut self) -> Result<(), Error> {
        let f = self.api3().reset;
        let calls = self.calls3();
        (calls.step_mode, calls.set_since_step, calls.terminated) = (false, false, false);
        self.plain3(f, "fmi3Reset")
    }

    pub(super) fn set_debug_logging3(&mut self, on: bool, categories: &[fmi3String]) -> Result<(), Error> {
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`); the
        // array of NUL-terminated strings outlives the call.
        let s = unsafe {
            (self.api3().set_debug_logging)(self.component, u8::from(on), categories.len(), categories.as_ptr())
        };
        self.check("fmi3SetDebugLogging", s)
    }

    /// `fmi3DoStep`; the FMU's end (`terminateSimulation`, an early return) is [`Error::Ended`].
    pub(super) fn do_step3(&mut self, t: f64, h: f64) -> Result<(), Error> {
        let (mut event, mut terminate, mut early, mut last) = (fmi3False, fmi3False, fmi3False, t);
        let do_step = self.api3().cs.as_ref().ok_or_else(|| self.wrong_interface())?.do_step;
        // SAFETY: a live instance and its loaded function (the invariants of `Instance`); the
        // out-parameters are locals.
        let s = unsafe { do_step(self.component, t, h, fmi3False, &mut event, &mut terminate, &mut early, &mut last) };
        let calls = self.calls3();
        calls.set_since_step = false;
        calls.last_successful_time = if s == fmi3Discard || !last.is_finite() { t } else { last };
        self.check("fmi3DoStep", s)?;
        if terminate != fmi3False || early != fmi3False {
            let terminated = terminate != fmi3False;
            self.calls3().terminated = terminated;
            return Err(Error::Ended {
                fmu: self.fmu.name().to_owned(),
                instance: self.name.clone(),
                time: self.calls3().last_successful_time,
                terminated,
            });
        }
        Ok(())
    }

    pub(super) fn last_successful_time3(&self) -> f64 {
        self.v3.as_ref().map_or(f64::NAN, |c| c.last_successful_time)
    }

    pub(super) fn terminated3(&self) -> bool {
        self.v3.as_ref().is_some_and(|c| c.terminated)
    }

    /// After `fmi3SetFMUState`: values may be read again.
    pub(super) fn state_restored3(&mut self) {
        self.calls3().set_since_step = false;
    }

    /// `out = J · seed` through a function with the signature of `fmi3GetDirectionalDerivative`:
    /// the seeds spread over whole known variables (zero elsewhere), the requested elements of
    /// the whole unknown variables picked out.
    pub(super) fn derivative3(
        &mut self,
        name: &'static str,
        f: fmi3GetDirectionalDerivativeTYPE,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), Error> {
        let (iu, ik) = (self.plan(VarType::Real, unknowns)?, self.plan(VarType::Real, knowns)?);
        let component = self.component;
        let calls = self.calls3();
        let (pu, pk) = (&calls.plans[iu], &calls.plans[ik]);
        let b = &mut calls.buf;
        b.seeds.clear();
        b.seeds.resize(pk.total, 0.0);
        for (&a, &x) in pk.at.iter().zip(seed) {
            b.seeds[a] += x;
        }
        b.reals.clear();
        b.reals.resize(pu.total, 0.0);
        // SAFETY: a live instance and a function of its loaded binary with the signature of
        // fmi3GetDirectionalDerivative (the invariants of `Instance`); every array holds the
        // length passed with it.
        let s = unsafe {
            f(
                component,
                pu.vars.as_ptr(),
                pu.vars.len(),
                pk.vars.as_ptr(),
                pk.vars.len(),
                b.seeds.as_ptr(),
                pk.total,
                b.reals.as_mut_ptr(),
                pu.total,
            )
        };
        for (o, &a) in out.iter_mut().zip(&pu.at) {
            *o = b.reals[a];
        }
        self.check(name, s)
    }
}
