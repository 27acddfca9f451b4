//! The export layer called through its C entry points in-process, with a toy model:
//! state machine, checks, logging, panics, FMU states.

use std::ffi::{CString, c_char};
use std::path::Path;

use super::entry as e;
use super::*;
use crate::description::{Capabilities, Variable};
use crate::import::{LogMessage, LogSink};

/// `y = 2 u + s`, `s += u h` per step; panics when asked to step with `u = 13`.
struct Toy {
    u: f64,
    s: f64,
    p: f64,
    q: f64,
}

const GUID: &str = "{toy}";

impl Model for Toy {
    fn description() -> Result<ModelDescription, ModelError> {
        Ok(ModelDescription {
            model_name: "toy".into(),
            model_identifier: "toy".into(),
            guid: GUID.into(),
            description: String::new(),
            version: "1".into(),
            capabilities: Capabilities {
                provides_directional_derivative: true,
                can_interpolate_inputs: false,
                provides_step_map_derivative: false,
            },
            default_experiment: None,
            extra_units: vec![],
            variables: vec![
                Variable::real_input("u", 0, 0.0, ""),
                Variable::real_output("y", 1, "").depends_on(&["u"]),
                Variable::parameter("p", 2, 1.0, false),
                Variable::parameter("q", 3, 1.0, true),
            ],
        })
    }
    fn instantiate(_: Option<&Path>) -> Result<Self, ModelError> {
        Ok(Toy { u: 0.0, s: 0.0, p: 1.0, q: 1.0 })
    }
    fn set_real(&mut self, vr: u32, v: f64) -> Result<(), ModelError> {
        match vr {
            0 => self.u = v,
            2 => self.p = v,
            3 if v < 0.0 => return Err(format!("{v}: must not be negative").into()),
            3 => self.q = v,
            _ => unreachable!(),
        }
        Ok(())
    }
    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        // p = 7 makes the output NaN: the layer must refuse to report it.
        let y = if self.p == 7.0 { f64::NAN } else { 2.0 * self.u + self.s };
        Ok([self.u, y, self.p, self.q][vr as usize])
    }
    fn exit_initialization(&mut self, _: f64) -> Result<(), ModelError> {
        Ok(())
    }
    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        assert!(self.u != 13.0, "unlucky input 13 and 100% sure");
        // u = 99: the model ends half-way through the step.
        if self.u == 99.0 {
            self.s += self.u * 0.5 * h;
            return Ok(StepOutcome::Terminated { time: t + 0.5 * h, reason: "the end".into() });
        }
        self.s += self.u * h;
        Ok(StepOutcome::Complete)
    }
    fn directional_derivative(
        &mut self,
        _: &[u32],
        _: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        out[0] = 2.0 * seed.iter().sum::<f64>();
        Ok(())
    }
    fn save_state(&self, out: &mut Vec<u8>) -> Result<(), ModelError> {
        crate::state_bytes::StateWriter::new(out).f64(self.u).f64(self.s).f64(self.p).f64(self.q);
        Ok(())
    }
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError> {
        let mut r = crate::state_bytes::StateReader::new(bytes);
        (self.u, self.s, self.p, self.q) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?);
        Ok(r.finish()?)
    }
}

fn info() -> &'static e::InfoCell {
    static INFO: e::InfoCell = e::InfoCell::new();
    &INFO
}

/// An instance with its log sink.
struct Harness {
    c: fmi2Component,
    sink: Box<LogSink>,
}

impl Harness {
    fn new() -> Harness {
        Self::with(GUID, c"file:///tmp")
    }

    fn with(guid: &str, location: &CStr) -> Harness {
        let sink = LogSink::new();
        let cb = sink.callbacks();
        let guid = CString::new(guid).unwrap();
        let c = unsafe {
            e::instantiate::<Toy>(
                info(),
                c"toy1".as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                location.as_ptr(),
                &cb,
                0,
                0,
            )
        };
        Harness { c, sink }
    }

    fn inst(&self) -> &Instance<Toy> {
        unsafe { &*self.c.cast::<Instance<Toy>>() }
    }

    fn messages(&self) -> Vec<LogMessage> {
        self.sink.take()
    }

    /// The single error message logged since the last call.
    fn error(&self) -> String {
        let m: Vec<_> = self.messages().into_iter().filter(|m| m.status >= fmi2Error).collect();
        assert_eq!(m.len(), 1, "expected one error message, got {m:?}");
        assert_eq!(m[0].category, "logError");
        m[0].text.clone()
    }

    fn init(&self) {
        unsafe {
            assert_eq!(e::setup_experiment::<Toy>(self.c, 0, 0.0, 0.0, 0, 0.0), fmi2OK);
            assert_eq!(e::enter_initialization_mode::<Toy>(self.c), fmi2OK);
            assert_eq!(e::exit_initialization_mode::<Toy>(self.c), fmi2OK);
        }
    }

    fn set(&self, vr: u32, v: f64) -> fmi2Status {
        unsafe { e::set_real::<Toy>(self.c, &vr, 1, &v) }
    }

    fn get(&self, vr: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(unsafe { e::get_real::<Toy>(self.c, &vr, 1, &mut v) }, fmi2OK, "{:?}", self.messages());
        v
    }

    fn step(&self, t: f64, h: f64) -> fmi2Status {
        unsafe { e::do_step::<Toy>(self.c, t, h, 0) }
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        unsafe { e::free_instance::<Toy>(self.c) };
    }
}

#[test]
fn platform_and_version() {
    assert_eq!(unsafe { CStr::from_ptr(e::types_platform()) }, c"default");
    assert_eq!(unsafe { CStr::from_ptr(e::version()) }, c"2.0");
}

#[test]
fn normal_life_cycle() {
    let h = Harness::new();
    assert!(!h.c.is_null());
    assert_eq!(h.set(0, 1.5), fmi2OK, "inputs are settable when instantiated");
    assert_eq!(h.set(2, 4.0), fmi2OK);
    unsafe { assert_eq!(e::enter_initialization_mode::<Toy>(h.c), fmi2OK) };
    assert_eq!(h.get(1), 3.0, "calculated outputs are readable in initialization mode");
    assert_eq!(h.set(2, 5.0), fmi2OK, "fixed parameters are settable in initialization mode");
    unsafe { assert_eq!(e::exit_initialization_mode::<Toy>(h.c), fmi2OK) };
    assert_eq!(h.inst().phase(), StepMode);
    assert_eq!(h.step(0.0, 0.1), fmi2OK);
    assert_eq!(h.set(3, 2.0), fmi2OK, "tunable parameters are settable in step mode");
    assert_eq!(h.get(1), 3.15);
    unsafe { assert_eq!(e::terminate::<Toy>(h.c), fmi2OK) };
    assert_eq!(h.get(1), 3.15, "outputs are readable after termination");
    assert!(h.messages().is_empty(), "loggingOn = false: no info messages");
}

#[test]
fn wrong_state_calls_are_errors_naming_function_and_state() {
    let h = Harness::new();
    assert_eq!(h.step(0.0, 0.1), fmi2Error);
    assert_eq!(h.error(), "fmi2DoStep: not allowed in state `instantiated`");
    assert_eq!(h.inst().phase(), Error, "fmi2Error puts the instance into the error state");
    assert_eq!(h.step(0.0, 0.1), fmi2Error);
    assert!(h.error().contains("state `error`"));
    unsafe { assert_eq!(e::reset::<Toy>(h.c), fmi2OK) };
    assert_eq!(h.inst().phase(), Instantiated);
    let mut v = 0.0;
    assert_eq!(unsafe { e::get_real::<Toy>(h.c, &1, 1, &mut v) }, fmi2Error);
    assert_eq!(h.error(), "fmi2GetReal: not allowed in state `instantiated`");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    unsafe {
        assert_eq!(e::exit_initialization_mode::<Toy>(h.c), fmi2Error);
        assert_eq!(h.error(), "fmi2ExitInitializationMode: not allowed in state `step mode`");
        e::reset::<Toy>(h.c);
        h.init();
        assert_eq!(e::setup_experiment::<Toy>(h.c, 0, 0.0, 0.0, 0, 0.0), fmi2Error);
        assert!(h.error().starts_with("fmi2SetupExperiment: not allowed"));
    }
}

#[test]
fn variable_checks_name_the_variable() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.set(99, 1.0), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: unknown value reference 99 (no Real variable has it)");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.set(0, f64::NAN), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: `u` (input, continuous) = NaN: not a finite number");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.set(0, f64::INFINITY), fmi2Error);
    assert!(h.error().contains("= inf: not a finite number"));
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.set(2, 1.0), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: `p` (parameter, fixed) cannot be set in state `step mode`");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.set(1, 1.0), fmi2Error);
    assert!(h.error().contains("`y` (output, continuous) cannot be set"));
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.set(3, -1.0), fmi2Error, "the model's own range check");
    assert_eq!(h.error(), "fmi2SetReal: `q` (parameter, tunable): -1: must not be negative");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    let mut n = 0;
    assert_eq!(unsafe { e::get_integer::<Toy>(h.c, &0, 1, &mut n) }, fmi2Error);
    assert!(h.error().contains("unknown value reference 0 (no Integer variable has it)"));
}

#[test]
fn a_rejected_array_changes_nothing() {
    let h = Harness::new();
    h.init();
    let (vrs, vals) = ([0u32, 0], [7.0, f64::NAN]);
    assert_eq!(unsafe { e::set_real::<Toy>(h.c, vrs.as_ptr(), 2, vals.as_ptr()) }, fmi2Error);
    unsafe { e::reset::<Toy>(h.c) };
    unsafe { e::enter_initialization_mode::<Toy>(h.c) };
    assert_eq!(h.get(0), 0.0);
}

#[test]
fn null_pointers_are_errors_not_crashes() {
    let null = std::ptr::null_mut();
    unsafe {
        assert_eq!(e::do_step::<Toy>(null, 0.0, 0.1, 0), fmi2Error);
        assert_eq!(e::get_real::<Toy>(null, std::ptr::null(), 0, std::ptr::null_mut()), fmi2Error);
        e::free_instance::<Toy>(null);
    }
    let h = Harness::new();
    h.init();
    unsafe {
        assert_eq!(e::get_real::<Toy>(h.c, std::ptr::null(), 0, std::ptr::null_mut()), fmi2OK, "n = 0");
        assert_eq!(e::get_real::<Toy>(h.c, std::ptr::null(), 2, std::ptr::null_mut()), fmi2Error);
        assert_eq!(h.error(), "fmi2GetReal: `vr` is a null pointer (length 2)");
        e::reset::<Toy>(h.c);
        assert_eq!(e::get_fmu_state::<Toy>(h.c, std::ptr::null_mut()), fmi2Error);
        assert!(h.error().contains("`FMUstate` is a null pointer"));
    }
    let cb = std::ptr::null();
    let c = unsafe { e::instantiate::<Toy>(info(), c"x".as_ptr(), 1, c"{toy}".as_ptr(), std::ptr::null(), cb, 0, 0) };
    assert!(c.is_null(), "no callbacks: no instance");
}

#[test]
fn instantiate_checks_type_guid_and_location() {
    let h = Harness::with("{other}", c"");
    assert!(h.c.is_null());
    assert!(h.error().contains("fmuGUID `{other}` does not match this binary's `{toy}`"));
    let h = Harness::with(GUID, c"http://example.org/res");
    assert!(h.c.is_null());
    assert!(h.error().contains("not a file: URI"));
    let h = Harness::with(GUID, c"file:////tmp/res/");
    assert!(!h.c.is_null());
    assert_eq!(h.inst().resources.as_deref(), Some(Path::new("/tmp/res")));
    let sink = LogSink::new();
    let cb = sink.callbacks();
    let c = unsafe { e::instantiate::<Toy>(info(), c"me".as_ptr(), 0, c"{toy}".as_ptr(), std::ptr::null(), &cb, 0, 0) };
    assert!(c.is_null());
    assert!(sink.take()[0].text.contains("supports Co-Simulation (1) only"));
}

#[test]
fn panics_become_fatal_and_are_logged() {
    let h = Harness::new();
    h.init();
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    unsafe { e::get_fmu_state::<Toy>(h.c, &mut state) };
    assert_eq!(h.set(0, 13.0), fmi2OK);
    assert_eq!(h.step(0.0, 0.1), fmi2Fatal);
    let m = h.messages();
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].status, fmi2Fatal);
    // The `%` of the panic message reached the printf-style logger escaped, and came back intact.
    assert_eq!(m[0].text, "fmi2DoStep: internal error (panic): unlucky input 13 and 100% sure");
    assert_eq!(h.inst().phase(), Fatal);
    unsafe { assert_eq!(e::reset::<Toy>(h.c), fmi2Fatal, "only fmi2FreeInstance is allowed now") };
    assert!(h.messages()[0].text.contains("only fmi2FreeInstance is allowed"));
    unsafe { assert_eq!(e::free_fmu_state::<Toy>(h.c, &mut state), fmi2OK, "saved states can still be freed") };
    assert!(state.is_null());
}

#[test]
fn communication_points_may_drift_by_rounding() {
    let h = Harness::new();
    h.init();
    let mut t = 0.0;
    for _ in 0..1000 {
        assert_eq!(h.step(t, 0.009999999999999998), fmi2OK);
        t += 0.01; // the importer's own clock drifts away from the instance's
    }
    assert_eq!(h.step(t + 1e-6, 0.01), fmi2Error);
    assert!(h.error().contains("but the instance is at t = 9.99999999999"), "the difference is named");
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(h.step(0.0, 0.0), fmi2Error);
    assert!(h.error().contains("need finite t and h > 0"));
}

#[test]
fn stop_time_is_respected() {
    let h = Harness::new();
    unsafe {
        assert_eq!(e::setup_experiment::<Toy>(h.c, 0, 0.0, 0.0, 1, 0.25), fmi2OK);
        e::enter_initialization_mode::<Toy>(h.c);
        e::exit_initialization_mode::<Toy>(h.c);
    }
    assert_eq!(h.step(0.0, 0.1), fmi2OK);
    assert_eq!(h.step(0.1, 0.15000000000000002), fmi2OK);
    assert_eq!(h.step(0.25, 0.1), fmi2Error);
    assert!(h.error().contains("past stopTime = 0.25"));
}

#[test]
fn fmu_states_roll_back_and_round_trip() {
    let h = Harness::new();
    h.init();
    h.set(0, 0.3);
    h.step(0.0, 0.1);
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    unsafe { assert_eq!(e::get_fmu_state::<Toy>(h.c, &mut state), fmi2OK) };
    let y1 = h.get(1);
    h.set(0, 0.7);
    h.step(0.1, 0.1);
    assert_ne!(h.get(1), y1);
    unsafe { assert_eq!(e::set_fmu_state::<Toy>(h.c, state), fmi2OK) };
    assert_eq!(h.get(1).to_bits(), y1.to_bits());
    assert_eq!(h.step(0.1, 0.1), fmi2OK, "the time was rolled back too");
    // Serialize, and load the bytes into another instance.
    let mut size = 0;
    let mut bytes = Vec::new();
    unsafe {
        assert_eq!(e::serialized_fmu_state_size::<Toy>(h.c, state, &mut size), fmi2OK);
        bytes.resize(size, 0u8);
        assert_eq!(e::serialize_fmu_state::<Toy>(h.c, state, bytes.as_mut_ptr().cast(), size), fmi2OK);
    }
    let other = Harness::new();
    let mut copy: fmi2FMUstate = std::ptr::null_mut();
    unsafe {
        assert_eq!(e::deserialize_fmu_state::<Toy>(other.c, bytes.as_ptr().cast(), size, &mut copy), fmi2OK);
        assert_eq!(e::set_fmu_state::<Toy>(other.c, copy), fmi2OK);
    }
    assert_eq!(other.inst().phase(), StepMode, "the phase travels with the state");
    assert_eq!(other.get(1).to_bits(), y1.to_bits());
    // Damaged or foreign bytes are rejected with a reason.
    let mut bad = bytes.clone();
    bad[0] = b'X';
    let mut junk: fmi2FMUstate = std::ptr::null_mut();
    unsafe {
        assert_eq!(e::deserialize_fmu_state::<Toy>(other.c, bad.as_ptr().cast(), size, &mut junk), fmi2Error);
        assert!(other.error().contains("wrong header"));
        e::reset::<Toy>(other.c);
        let foreign = String::from_utf8_lossy(&bytes).replace(GUID, "{yot}").into_bytes();
        assert_eq!(
            e::deserialize_fmu_state::<Toy>(other.c, foreign.as_ptr().cast(), foreign.len(), &mut junk),
            fmi2Error
        );
        assert!(other.error().contains("GUID `{yot}`"));
        e::reset::<Toy>(other.c);
        assert_eq!(e::deserialize_fmu_state::<Toy>(other.c, bytes.as_ptr().cast(), size - 1, &mut junk), fmi2Error);
        assert!(other.error().contains("not a state of this FMU"));
        assert!(junk.is_null());
        assert_eq!(e::free_fmu_state::<Toy>(h.c, &mut state), fmi2OK);
        assert!(state.is_null());
        assert_eq!(e::free_fmu_state::<Toy>(other.c, &mut copy), fmi2OK);
    }
}

#[test]
fn get_fmu_state_reuses_an_existing_state() {
    let h = Harness::new();
    h.init();
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    unsafe {
        e::get_fmu_state::<Toy>(h.c, &mut state);
        let first = state;
        h.set(0, 1.0);
        h.step(0.0, 0.5);
        assert_eq!(e::get_fmu_state::<Toy>(h.c, &mut state), fmi2OK);
        assert_eq!(state, first, "overwritten in place");
        h.step(0.5, 0.5);
        e::set_fmu_state::<Toy>(h.c, state);
        assert_eq!(h.get(1), 2.5);
        e::free_fmu_state::<Toy>(h.c, &mut state);
    }
}

#[test]
fn directional_derivative_checks() {
    let h = Harness::new();
    h.init();
    let mut out = [0.0];
    let call = |u: u32, k: &[u32], s: &[f64], out: &mut [f64]| unsafe {
        e::get_directional_derivative::<Toy>(h.c, &u, 1, k.as_ptr(), k.len(), s.as_ptr(), out.as_mut_ptr())
    };
    assert_eq!(call(1, &[0], &[1.0], &mut out), fmi2OK);
    assert_eq!(out[0], 2.0);
    // A parameter with a zero seed is dropped before the model sees it.
    assert_eq!(call(1, &[0, 2], &[0.5, 0.0], &mut out), fmi2OK);
    assert_eq!(out[0], 1.0);
    assert_eq!(call(0, &[0], &[1.0], &mut out), fmi2Error);
    assert!(h.error().contains("`u` (input, continuous) cannot be an unknown"));
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(call(1, &[1], &[1.0], &mut out), fmi2Error);
    assert!(h.error().contains("`y` (output, continuous) cannot be a known"));
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(call(1, &[7], &[1.0], &mut out), fmi2Error);
    assert!(h.error().contains("unknown value reference 7"));
    unsafe { e::reset::<Toy>(h.c) };
    h.init();
    assert_eq!(call(1, &[0], &[f64::NAN], &mut out), fmi2Error);
    assert!(h.error().contains("seed for `u`"));
}

#[test]
fn input_derivatives_need_the_capability() {
    let h = Harness::new();
    h.init();
    let (vr, order, v) = (0u32, 1i32, 1.0);
    unsafe {
        assert_eq!(e::set_real_input_derivatives::<Toy>(h.c, &vr, 1, &order, &v), fmi2Error);
        assert!(h.error().contains("canInterpolateInputs = false"));
        e::reset::<Toy>(h.c);
        h.init();
        let mut out = 0.0;
        assert_eq!(e::get_real_output_derivatives::<Toy>(h.c, &vr, 1, &order, &mut out), fmi2Error);
        assert!(h.error().contains("maxOutputDerivativeOrder = 0"));
    }
}

#[test]
fn debug_logging_categories() {
    let h = Harness::new();
    let cats: [*const c_char; 1] = [c"logInfo".as_ptr()];
    unsafe {
        assert_eq!(e::set_debug_logging::<Toy>(h.c, 1, 1, cats.as_ptr()), fmi2OK);
        e::enter_initialization_mode::<Toy>(h.c);
    }
    let m = h.messages();
    assert_eq!(m.len(), 1);
    assert_eq!((m[0].category.as_str(), m[0].text.as_str()), ("logInfo", "entered initialization mode"));
    unsafe {
        assert_eq!(e::set_debug_logging::<Toy>(h.c, 0, 0, std::ptr::null()), fmi2OK, "all categories off");
        assert_eq!(e::enter_initialization_mode::<Toy>(h.c), fmi2Error);
    }
    assert!(h.messages().is_empty(), "logError was switched off too");
    unsafe { e::reset::<Toy>(h.c) };
    let bad: [*const c_char; 1] = [c"logEverything".as_ptr()];
    unsafe { assert_eq!(e::set_debug_logging::<Toy>(h.c, 1, 1, bad.as_ptr()), fmi2Error) };
    let all: [*const c_char; 1] = [c"logAll".as_ptr()];
    unsafe {
        e::reset::<Toy>(h.c);
        assert_eq!(e::set_debug_logging::<Toy>(h.c, 1, 1, all.as_ptr()), fmi2OK);
    }
    h.messages();
    assert_eq!(h.step(0.0, 1.0), fmi2Error);
    assert!(h.error().contains("not allowed"), "errors are logged again");
}

#[test]
fn status_queries() {
    let h = Harness::new();
    h.init();
    h.step(0.0, 0.25);
    let (mut t, mut b, mut s) = (0.0, 1, 0);
    unsafe {
        assert_eq!(e::get_real_status::<Toy>(h.c, fmi2LastSuccessfulTime, &mut t), fmi2OK);
        assert_eq!(t, 0.25);
        assert_eq!(e::get_boolean_status::<Toy>(h.c, fmi2Terminated, &mut b), fmi2OK);
        assert_eq!(b, fmi2False);
        assert_eq!(e::get_status::<Toy>(h.c, fmi2DoStepStatus, &mut s), fmi2Discard);
        assert_eq!(h.inst().phase(), StepMode, "fmi2Discard does not enter the error state");
        assert_eq!(e::cancel_step::<Toy>(h.c), fmi2Error);
    }
}

#[test]
fn a_model_that_ends_returns_discard_with_terminated_and_last_successful_time() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.step(0.0, 0.25), fmi2OK);
    let mut saved: fmi2FMUstate = std::ptr::null_mut();
    unsafe { assert_eq!(e::get_fmu_state::<Toy>(h.c, &mut saved), fmi2OK) };
    h.set(0, 99.0);
    assert_eq!(h.step(0.25, 0.5), fmi2Discard);
    assert!(h.messages().iter().any(|m| m.status == fmi2Discard && m.text.contains("stopped at t = 0.5")));
    assert_eq!(h.inst().phase(), StepFailed);
    let (mut t, mut b) = (0.0, 0);
    unsafe {
        assert_eq!(e::get_real_status::<Toy>(h.c, fmi2LastSuccessfulTime, &mut t), fmi2OK);
        assert_eq!(e::get_boolean_status::<Toy>(h.c, fmi2Terminated, &mut b), fmi2OK);
    }
    assert_eq!((t, b), (0.5, fmi2True));
    // The values at the last successful time can be read; no further step.
    assert_eq!(h.get(1), 2.0 * 99.0 + 99.0 * 0.25);
    assert_eq!(h.step(0.5, 0.1), fmi2Error);
    assert!(h.error().contains("not allowed in state `step failed"));
    // A state saved before the step brings the instance back.
    unsafe { assert_eq!(e::set_fmu_state::<Toy>(h.c, saved), fmi2OK) };
    assert_eq!(h.inst().phase(), StepMode);
    unsafe {
        assert_eq!(e::get_boolean_status::<Toy>(h.c, fmi2Terminated, &mut b), fmi2OK);
        e::free_fmu_state::<Toy>(h.c, &mut saved);
    }
    assert_eq!(b, fmi2False);
    assert_eq!(h.step(0.25, 0.25), fmi2OK);
    // fmi2Terminate is allowed after a discarded step.
    h.set(0, 99.0);
    assert_eq!(h.step(0.5, 0.25), fmi2Discard);
    assert_eq!(unsafe { e::terminate::<Toy>(h.c) }, fmi2OK);
}

#[test]
fn a_non_finite_output_is_an_error_naming_variable_and_time() {
    let h = Harness::new();
    h.init();
    h.step(0.0, 0.5);
    unsafe { e::reset::<Toy>(h.c) };
    h.set(2, 7.0);
    h.init();
    let (vr, mut v) = (1u32, 0.0);
    assert_eq!(unsafe { e::get_real::<Toy>(h.c, &vr, 1, &mut v) }, fmi2Error);
    let e = h.error();
    assert!(e.contains("`y` (output, continuous) = NaN") && e.contains("at t = 0"), "{e}");
}

#[test]
fn the_step_map_extension_is_refused_without_the_capability() {
    let h = Harness::new();
    h.init();
    let (u, k, s, mut out) = (1u32, 0u32, 1.0, 0.0);
    let status = unsafe { e::get_step_map_derivative::<Toy>(h.c, &u, 1, &k, 1, &s, &mut out) };
    assert_eq!(status, fmi2Error);
    assert!(h.error().contains("feedsimGetStepMapDerivative: not provided"));
}
