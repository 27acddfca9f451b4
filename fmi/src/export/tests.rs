//! The export layer called through its C entry points in-process, with a toy model:
//! state machine, checks, logging, panics, FMU states.

use std::ffi::{CStr, CString, c_char};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::exported as e;
use super::instance::Instance;
use super::instance::Phase;
use super::*;
use crate::description::{CoSimulationFlags, ModelDescription, Variable};
use crate::ffi::*;
use crate::import::{LogMessage, LogSink};
use Phase::*;

/// `y = 2 u + s`, `s += u h` per step; panics when asked to step with `u = 13`.
struct Toy {
    u: f64,
    s: f64,
    p: f64,
    q: f64,
}

#[derive(Serialize, Deserialize)]
struct ToyState {
    u: f64,
    s: f64,
    p: f64,
    q: f64,
}

const GUID: &str = "{toy}";

impl Model for Toy {
    type State<'a> = ToyState;

    fn description() -> Result<ModelDescription, ModelError> {
        let flags = CoSimulationFlags { provides_directional_derivative: true, ..CoSimulationFlags::EXPORTED };
        let mut d = ModelDescription::co_simulation(
            "toy",
            GUID,
            "",
            "1",
            flags,
            vec![
                Variable::real_input("u", 0, 0.0, "").range(-1e3, 1e3),
                Variable::real_output("y", 1, "").depends_on(&["u"]),
                Variable::parameter("p", 2, 1.0, false),
                Variable::parameter("q", 3, 1.0, true),
            ],
        );
        d.default_experiment = None;
        Ok(d)
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
    // u = 5 at the start is legal but suspicious.
    fn initialization_warning(&mut self) -> Option<String> {
        (self.u == 5.0).then(|| "u starts at 5".to_owned())
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
    fn derivative(&mut self, kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        assert_eq!(kind, Derivative::Instant, "the layer refuses the step map: not announced");
        out[0] = 2.0 * at.seed.iter().sum::<f64>();
        Ok(())
    }
    fn save(&mut self) -> Result<ToyState, ModelError> {
        Ok(ToyState { u: self.u, s: self.s, p: self.p, q: self.q })
    }
    fn restore(&mut self, st: ToyState) -> Result<(), ModelError> {
        (self.u, self.s, self.p, self.q) = (st.u, st.s, st.p, st.q);
        Ok(())
    }
}

fn info() -> &'static e::InfoCell {
    static INFO: e::InfoCell = e::InfoCell::new();
    &INFO
}

/// An instance with its log sink, and the C functions as safe methods. `c` is null or the live
/// instance this harness made (freed on drop); every pointer a method passes is a local or
/// argument of the length it passes with it, or null with length 0 — or, where a test says so,
/// null on purpose (the layer must refuse it).
struct Harness {
    c: fmi2Component,
    sink: Box<LogSink>,
}

const NO_STATE: fmi2FMUstate = std::ptr::null_mut();

impl Harness {
    fn new() -> Harness {
        Self::with(GUID, c"file:///tmp")
    }

    fn with(guid: &str, location: &CStr) -> Harness {
        let sink = LogSink::new();
        let guid = CString::new(guid).unwrap();
        let c = instantiate(c"toy1", fmi2CoSimulation, &guid, location, Some(&sink.callbacks()));
        Harness { c, sink }
    }

    fn inst(&self) -> &Instance<Toy> {
        assert!(!self.c.is_null());
        // SAFETY: a live instance of Toy (the harness's invariant), read while no call runs.
        unsafe { &*self.c.cast::<Instance<Toy>>() }
    }

    fn phase(&self) -> Phase {
        self.inst().phase
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

    fn setup(&self, stop: Option<f64>) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::setup_experiment::<Toy>(self.c, 0, 0.0, 0.0, stop.is_some().into(), stop.unwrap_or(0.0)) }
    }
    fn enter(&self) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::enter_initialization_mode::<Toy>(self.c) }
    }
    fn exit(&self) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::exit_initialization_mode::<Toy>("fmi2ExitInitializationMode", self.c) }
    }
    fn terminate(&self) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::terminate::<Toy>("fmi2Terminate", self.c) }
    }
    fn reset(&self) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::reset::<Toy>("fmi2Reset", self.c) }
    }
    fn init(&self) {
        assert_eq!((self.setup(None), self.enter(), self.exit()), (fmi2OK, fmi2OK, fmi2OK));
    }
    fn set(&self, vr: u32, v: f64) -> fmi2Status {
        self.set_reals(&[vr], &[v])
    }
    fn set_reals(&self, vrs: &[u32], values: &[f64]) -> fmi2Status {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: the harness's invariant; both arrays hold `vrs.len()` elements.
        unsafe { e::set_real::<Toy>(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }
    fn try_get(&self, vr: u32) -> (fmi2Status, f64) {
        let mut v = f64::NAN;
        // SAFETY: the harness's invariant; one element each.
        (unsafe { e::get_real::<Toy>(self.c, &vr, 1, &mut v) }, v)
    }
    fn get(&self, vr: u32) -> f64 {
        let (status, v) = self.try_get(vr);
        assert_eq!(status, fmi2OK, "{:?}", self.messages());
        v
    }
    /// fmi2GetReal with raw pointers: null on purpose.
    fn get_raw(&self, vr: *const u32, n: usize, out: *mut f64) -> fmi2Status {
        assert!(n == 0 || vr.is_null() || out.is_null(), "only null arrays here");
        // SAFETY: the harness's invariant; a null array is allowed by the contract.
        unsafe { e::get_real::<Toy>(self.c, vr, n, out) }
    }
    fn get_integer(&self, vr: u32) -> fmi2Status {
        let mut n = 0;
        // SAFETY: the harness's invariant; one element each.
        unsafe { e::get_integer::<Toy>(self.c, &vr, 1, &mut n) }
    }
    fn step(&self, t: f64, h: f64) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::do_step::<Toy>(self.c, t, h, 0) }
    }
    fn cancel(&self) -> fmi2Status {
        // SAFETY: the harness's invariant.
        unsafe { e::cancel_step::<Toy>(self.c) }
    }
    /// fmi2GetFMUstate into `state` (null: a new state; else overwritten in place).
    fn get_state(&self, state: &mut fmi2FMUstate) -> fmi2Status {
        // SAFETY: the harness's invariant; `state` holds null or a state of this harness's FMU.
        unsafe { e::get_fmu_state::<Toy>("fmi2GetFMUstate", self.c, state) }
    }
    fn get_state_null(&self) -> fmi2Status {
        // SAFETY: the harness's invariant; a null `FMUstate*` is refused by the layer.
        unsafe { e::get_fmu_state::<Toy>("fmi2GetFMUstate", self.c, std::ptr::null_mut()) }
    }
    fn set_state(&self, state: fmi2FMUstate) -> fmi2Status {
        // SAFETY: the harness's invariant; `state` is a live state of Toy (the tests keep them so).
        unsafe { e::set_fmu_state::<Toy>("fmi2SetFMUstate", self.c, state) }
    }
    fn free_state(&self, state: &mut fmi2FMUstate) -> fmi2Status {
        // SAFETY: the harness's invariant; `state` is null or a live state of Toy.
        unsafe { e::free_fmu_state::<Toy>("fmi2FreeFMUstate", self.c, state) }
    }
    fn serialize(&self, state: fmi2FMUstate) -> Vec<u8> {
        let mut size = 0;
        // SAFETY: the harness's invariant; `state` is a live state of Toy; `size` a local.
        let status =
            unsafe { e::serialized_fmu_state_size::<Toy>("fmi2SerializedFMUstateSize", self.c, state, &mut size) };
        assert_eq!(status, fmi2OK);
        let mut bytes = vec![0u8; size];
        // SAFETY: as above; `bytes` holds `size` bytes.
        let status = unsafe {
            e::serialize_fmu_state::<Toy>("fmi2SerializeFMUstate", self.c, state, bytes.as_mut_ptr().cast(), size)
        };
        assert_eq!(status, fmi2OK);
        bytes
    }
    fn deserialize(&self, bytes: &[u8], state: &mut fmi2FMUstate) -> fmi2Status {
        // SAFETY: the harness's invariant; `bytes` holds its length; `state` holds null or a live state.
        unsafe {
            e::deserialize_fmu_state::<Toy>(
                "fmi2DeSerializeFMUstate",
                self.c,
                bytes.as_ptr().cast(),
                bytes.len(),
                state,
            )
        }
    }
    fn derivative(&self, kind: Derivative, u: u32, k: &[u32], s: &[f64], out: &mut f64) -> fmi2Status {
        assert_eq!(k.len(), s.len());
        // SAFETY: the harness's invariant; one unknown and output, `k.len()` knowns and seeds.
        unsafe { e::derivative::<Toy>(self.c, kind, &u, 1, k.as_ptr(), k.len(), s.as_ptr(), out) }
    }
    fn input_derivative(&self, vr: u32, order: i32, v: f64) -> fmi2Status {
        // SAFETY: the harness's invariant; one element each.
        unsafe { e::set_real_input_derivatives::<Toy>(self.c, &vr, 1, &order, &v) }
    }
    fn output_derivative(&self, vr: u32, order: i32) -> fmi2Status {
        let mut out = 0.0;
        // SAFETY: the harness's invariant; one element each.
        unsafe { e::get_real_output_derivatives::<Toy>(self.c, &vr, 1, &order, &mut out) }
    }
    fn debug_logging(&self, on: bool, categories: &[&CStr]) -> fmi2Status {
        let ptrs: Vec<*const c_char> = categories.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: the harness's invariant; `ptrs` holds its length of NUL-terminated strings.
        unsafe { e::set_debug_logging::<Toy>("fmi2SetDebugLogging", self.c, on.into(), ptrs.len(), ptrs.as_ptr()) }
    }
    fn last_successful_time(&self) -> (fmi2Status, f64) {
        let mut t = f64::NAN;
        // SAFETY: the harness's invariant; the answer goes to a local.
        (unsafe { e::get_real_status::<Toy>(self.c, fmi2LastSuccessfulTime, &mut t) }, t)
    }
    fn terminated(&self) -> (fmi2Status, fmi2Boolean) {
        let mut b = -1;
        // SAFETY: the harness's invariant; the answer goes to a local.
        (unsafe { e::get_boolean_status::<Toy>(self.c, fmi2Terminated, &mut b) }, b)
    }
    fn do_step_status(&self) -> fmi2Status {
        let mut s = -1;
        // SAFETY: the harness's invariant; the answer goes to a local.
        unsafe { e::get_status::<Toy>(self.c, fmi2DoStepStatus, &mut s) }
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        // SAFETY: the harness's invariant; the instance is not used again.
        unsafe { e::free_instance::<Toy>(self.c) };
    }
}

/// fmi2Instantiate of Toy; `callbacks: None` passes a null pointer.
fn instantiate(
    name: &CStr,
    kind: fmi2Type,
    guid: &CStr,
    location: &CStr,
    callbacks: Option<&fmi2CallbackFunctions>,
) -> fmi2Component {
    let cb = callbacks.map_or(std::ptr::null(), |c| c as *const _);
    // SAFETY: NUL-terminated strings and a callback struct (or null) that outlive the call.
    unsafe { e::instantiate::<Toy>(info(), name.as_ptr(), kind, guid.as_ptr(), location.as_ptr(), cb, 0, 0) }
}

#[test]
fn platform_and_version() {
    // SAFETY: both return pointers to static NUL-terminated strings.
    let (platform, version) = unsafe { (CStr::from_ptr(e::types_platform()), CStr::from_ptr(e::version())) };
    assert_eq!((platform, version), (c"default", c"2.0"));
}

#[test]
fn normal_life_cycle() {
    let h = Harness::new();
    assert!(!h.c.is_null());
    assert_eq!(h.set(0, 1.5), fmi2OK, "inputs are settable when instantiated");
    assert_eq!(h.set(2, 4.0), fmi2OK);
    assert_eq!(h.enter(), fmi2OK);
    assert_eq!(h.get(1), 3.0, "calculated outputs are readable in initialization mode");
    assert_eq!(h.set(2, 5.0), fmi2OK, "fixed parameters are settable in initialization mode");
    assert_eq!(h.exit(), fmi2OK);
    assert_eq!(h.phase(), StepMode);
    assert_eq!(h.step(0.0, 0.1), fmi2OK);
    assert_eq!(h.set(3, 2.0), fmi2OK, "tunable parameters are settable in step mode");
    assert_eq!(h.get(1), 3.15);
    assert_eq!(h.terminate(), fmi2OK);
    assert_eq!(h.get(1), 3.15, "outputs are readable after termination");
    assert!(h.messages().is_empty(), "loggingOn = false: no info messages");
}

#[test]
fn wrong_state_calls_are_errors_naming_function_and_state() {
    let h = Harness::new();
    assert_eq!(h.step(0.0, 0.1), fmi2Error);
    assert_eq!(h.error(), "fmi2DoStep: not allowed in state `instantiated`");
    assert_eq!(h.phase(), Error, "fmi2Error puts the instance into the error state");
    assert_eq!(h.step(0.0, 0.1), fmi2Error);
    assert!(h.error().contains("state `error`"));
    assert_eq!(h.reset(), fmi2OK);
    assert_eq!(h.phase(), Instantiated);
    assert_eq!(h.try_get(1).0, fmi2Error);
    assert_eq!(h.error(), "fmi2GetReal: not allowed in state `instantiated`");
    h.reset();
    h.init();
    assert_eq!(h.exit(), fmi2Error);
    assert_eq!(h.error(), "fmi2ExitInitializationMode: not allowed in state `step mode`");
    h.reset();
    h.init();
    assert_eq!(h.setup(None), fmi2Error);
    assert!(h.error().starts_with("fmi2SetupExperiment: not allowed"));
}

#[test]
fn variable_checks_name_the_variable() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.set(99, 1.0), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: unknown value reference 99 (no Real variable has it)");
    h.reset();
    h.init();
    assert_eq!(h.set(0, f64::NAN), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: `u` (input, continuous) = NaN: not a finite number");
    h.reset();
    h.init();
    assert_eq!(h.set(0, f64::INFINITY), fmi2Error);
    assert!(h.error().contains("= inf: not a finite number"));
    h.reset();
    h.init();
    assert_eq!(h.set(0, 1001.0), fmi2Error);
    assert_eq!(
        h.error(),
        "fmi2SetReal: `u` (input, continuous) = 1.001e3: outside the declared range [-1e3, 1e3] (min/max in modelDescription.xml)"
    );
    assert_eq!(h.get(0), 0.0, "refused: unchanged");
    h.reset();
    h.init();
    assert_eq!(h.set(0, 1000.0), fmi2OK, "the range includes its ends");
    assert_eq!(h.set(2, 1.0), fmi2Error);
    assert_eq!(h.error(), "fmi2SetReal: `p` (parameter, fixed) cannot be set in state `step mode`");
    h.reset();
    h.init();
    assert_eq!(h.set(1, 1.0), fmi2Error);
    assert!(h.error().contains("`y` (output, continuous) cannot be set"));
    h.reset();
    h.init();
    assert_eq!(h.set(3, -1.0), fmi2Error, "the model's own range check");
    assert_eq!(h.error(), "fmi2SetReal: `q` (parameter, tunable): -1: must not be negative");
    h.reset();
    h.init();
    assert_eq!(h.get_integer(0), fmi2Error);
    assert!(h.error().contains("unknown value reference 0 (no Integer variable has it)"));
}

#[test]
fn a_rejected_array_changes_nothing() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.set_reals(&[0, 0], &[7.0, f64::NAN]), fmi2Error);
    h.reset();
    h.enter();
    assert_eq!(h.get(0), 0.0);
}

#[test]
fn null_pointers_are_errors_not_crashes() {
    let nothing = Harness { c: std::ptr::null_mut(), sink: LogSink::new() };
    assert_eq!(nothing.step(0.0, 0.1), fmi2Error);
    assert_eq!(nothing.get_raw(std::ptr::null(), 0, std::ptr::null_mut()), fmi2Error);
    drop(nothing); // fmi2FreeInstance(NULL) does nothing
    let h = Harness::new();
    h.init();
    assert_eq!(h.get_raw(std::ptr::null(), 0, std::ptr::null_mut()), fmi2OK, "n = 0");
    assert_eq!(h.get_raw(std::ptr::null(), 2, std::ptr::null_mut()), fmi2Error);
    assert_eq!(h.error(), "fmi2GetReal: `vr` is a null pointer (length 2)");
    h.reset();
    assert_eq!(h.get_state_null(), fmi2Error);
    assert!(h.error().contains("`FMUstate` is a null pointer"));
    assert!(instantiate(c"x", fmi2CoSimulation, c"{toy}", c"", None).is_null(), "no callbacks: no instance");
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
    assert!(instantiate(c"me", fmi2ModelExchange, c"{toy}", c"", Some(&sink.callbacks())).is_null());
    let m = sink.take();
    assert!(m[0].text.contains("supports Co-Simulation (1) only"), "{m:?}");
    assert_eq!(m[0].category, "logError");
}

#[test]
fn panics_become_fatal_and_are_logged() {
    let h = Harness::new();
    h.init();
    let mut state = NO_STATE;
    assert_eq!(h.get_state(&mut state), fmi2OK);
    assert_eq!(h.set(0, 13.0), fmi2OK);
    assert_eq!(h.step(0.0, 0.1), fmi2Fatal);
    let m = h.messages();
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].status, fmi2Fatal);
    // The `%` of the panic message reached the printf-style logger escaped, and came back intact.
    assert_eq!(m[0].text, "fmi2DoStep: internal error (panic): unlucky input 13 and 100% sure");
    assert_eq!(h.phase(), Fatal);
    assert_eq!(h.reset(), fmi2Fatal, "only fmi2FreeInstance is allowed now");
    assert!(h.messages()[0].text.contains("only fmi2FreeInstance is allowed"));
    assert_eq!(h.free_state(&mut state), fmi2OK, "saved states can still be freed");
    assert!(state.is_null());
}

#[test]
fn a_panic_in_the_description_is_an_instantiation_error() {
    struct Broken;
    impl Model for Broken {
        type State<'a> = ();
        fn description() -> Result<ModelDescription, ModelError> {
            panic!("no description today")
        }
        fn instantiate(_: Option<&Path>) -> Result<Self, ModelError> {
            Ok(Broken)
        }
        fn set_real(&mut self, _: u32, _: f64) -> Result<(), ModelError> {
            Ok(())
        }
        fn get_real(&mut self, _: u32) -> Result<f64, ModelError> {
            Ok(0.0)
        }
        fn exit_initialization(&mut self, _: f64) -> Result<(), ModelError> {
            Ok(())
        }
        fn do_step(&mut self, _: f64, _: f64) -> Result<StepOutcome, ModelError> {
            Ok(StepOutcome::Complete)
        }
        fn save(&mut self) -> Result<(), ModelError> {
            Ok(())
        }
        fn restore(&mut self, _: ()) -> Result<(), ModelError> {
            Ok(())
        }
    }
    static INFO: e::InfoCell = e::InfoCell::new();
    let sink = LogSink::new();
    let cb = sink.callbacks();
    for _ in 0..2 {
        // SAFETY: NUL-terminated strings and a callback struct that outlive the call.
        let c = unsafe {
            e::instantiate::<Broken>(&INFO, c"b".as_ptr(), fmi2CoSimulation, c"{b}".as_ptr(), c"".as_ptr(), &cb, 0, 0)
        };
        assert!(c.is_null());
        let m = sink.take();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].text, "fmi2Instantiate: internal error (panic): no description today");
    }
    assert!(INFO.get().is_none(), "a panicking initialization leaves the cell empty; the next call tries again");
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
    h.reset();
    h.init();
    assert_eq!(h.step(0.0, 0.0), fmi2Error);
    assert!(h.error().contains("need finite t and h > 0"));
}

#[test]
fn stop_time_is_respected() {
    let h = Harness::new();
    assert_eq!((h.setup(Some(0.25)), h.enter(), h.exit()), (fmi2OK, fmi2OK, fmi2OK));
    assert_eq!(h.step(0.0, 0.1), fmi2OK);
    assert_eq!(h.step(0.1, 0.15000000000000002), fmi2OK);
    assert_eq!(h.step(0.25, 0.1), fmi2Error);
    assert!(h.error().contains("past stopTime = 0.25"));
}

#[test]
fn fmu_states_roll_back_bit_for_bit_and_round_trip() {
    let h = Harness::new();
    h.init();
    h.set(0, 0.3);
    h.step(0.0, 0.1);
    h.set(0, -0.0);
    let mut state = NO_STATE;
    assert_eq!(h.get_state(&mut state), fmi2OK);
    let y1 = h.get(1);
    h.set(0, 0.7);
    h.step(0.1, 0.1);
    assert_ne!(h.get(1), y1);
    assert_eq!(h.set_state(state), fmi2OK);
    assert_eq!(h.get(1).to_bits(), y1.to_bits());
    assert_eq!(h.get(0).to_bits(), (-0.0f64).to_bits(), "the sign of zero survives");
    assert_eq!(h.step(0.1, 0.1), fmi2OK, "the time was rolled back too");
    // Serialize, and load the bytes into another instance.
    let bytes = h.serialize(state);
    let other = Harness::new();
    let mut copy = NO_STATE;
    assert_eq!(other.deserialize(&bytes, &mut copy), fmi2OK);
    assert_eq!(other.set_state(copy), fmi2OK);
    assert_eq!(other.phase(), StepMode, "the phase travels with the state");
    assert_eq!(other.get(1).to_bits(), y1.to_bits());
    // Damaged, foreign, truncated, padded or random bytes are rejected with a reason: by the
    // digest, and where the digest is made to fit (as a forger would), by what it protects.
    let mut junk = NO_STATE;
    let mut refused = |bad: &[u8], why: &str| {
        other.reset();
        assert_eq!(other.deserialize(bad, &mut junk), fmi2Error);
        let e = other.error();
        assert!(e.contains(why), "`{e}` does not say `{why}`");
        assert!(junk.is_null());
    };
    let body = &bytes[..bytes.len() - 8];
    let sealed = |body: &[u8]| [body, &crate::digest::digest(body).to_le_bytes()].concat();
    assert_eq!(sealed(body), bytes, "a serialized state ends with the digest of the rest");
    for at in [0, 9, bytes.len() / 2, bytes.len() - 9, bytes.len() - 1] {
        let mut flipped = bytes.clone();
        flipped[at] ^= 0x01;
        refused(&flipped, "its digest does not match its bytes (damaged or edited)");
    }
    refused(&bytes[..bytes.len() - 1], "digest does not match");
    refused(&bytes[..7], "7 bytes are too few");
    let mut bad = body.to_vec();
    bad[0] = b'X';
    refused(&sealed(&bad), "wrong header");
    let mut older = body.to_vec();
    older[7] = b'2';
    refused(&sealed(&older), "a state of another format (`FMI2RSv2`); this FMU reads `FMI2RSv3`");
    let mut foreign = body.to_vec();
    let at = foreign.windows(GUID.len()).position(|w| w == GUID.as_bytes()).unwrap();
    foreign[at..at + GUID.len()].copy_from_slice(b"{yot}");
    refused(&sealed(&foreign), "GUID `{yot}`");
    refused(&sealed(&body[..body.len() - 1]), "not a state of this FMU");
    refused(&sealed(&[body, &[0]].concat()), "1 unexpected trailing bytes");
    let mut error_phase = body.to_vec();
    let at = 8 + 1 + GUID.len(); // magic, the GUID's length and text, then the phase
    error_phase[at] = 4; // Phase::Error
    refused(&sealed(&error_phase), "phase `error` is never saved");
    let mut random = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..200 {
        let bytes: Vec<u8> = (0..64)
            .map(|_| {
                random ^= random << 13;
                random ^= random >> 7;
                random ^= random << 17;
                random as u8
            })
            .collect();
        refused(&bytes, "not a state of this FMU");
        refused(&sealed(&[&b"FMI2RSv3"[..], &bytes].concat()), "not a state of this FMU");
    }
    assert_eq!(h.free_state(&mut state), fmi2OK);
    assert!(state.is_null());
    assert_eq!(other.free_state(&mut copy), fmi2OK);
}

#[test]
fn get_fmu_state_reuses_an_existing_state() {
    let h = Harness::new();
    h.init();
    let mut state = NO_STATE;
    h.get_state(&mut state);
    let first = state;
    h.set(0, 1.0);
    h.step(0.0, 0.5);
    assert_eq!(h.get_state(&mut state), fmi2OK);
    assert_eq!(state, first, "overwritten in place");
    h.step(0.5, 0.5);
    h.set_state(state);
    assert_eq!(h.get(1), 2.5);
    h.free_state(&mut state);
}

#[test]
fn directional_derivative_checks() {
    let h = Harness::new();
    h.init();
    let mut out = 0.0;
    let mut call = |u: u32, k: &[u32], s: &[f64]| h.derivative(Derivative::Instant, u, k, s, &mut out);
    assert_eq!(call(1, &[0], &[1.0]), fmi2OK);
    assert_eq!(out, 2.0);
    let mut call = |u: u32, k: &[u32], s: &[f64]| h.derivative(Derivative::Instant, u, k, s, &mut out);
    // A parameter with a zero seed is dropped before the model sees it.
    assert_eq!(call(1, &[0, 2], &[0.5, 0.0]), fmi2OK);
    assert_eq!(out, 1.0);
    let mut call = |u: u32, k: &[u32], s: &[f64]| h.derivative(Derivative::Instant, u, k, s, &mut out);
    assert_eq!(call(0, &[0], &[1.0]), fmi2Error);
    assert!(h.error().contains("`u` (input, continuous) cannot be an unknown"));
    h.reset();
    h.init();
    assert_eq!(call(1, &[1], &[1.0]), fmi2Error);
    assert!(h.error().contains("`y` (output, continuous) cannot be a known"));
    h.reset();
    h.init();
    assert_eq!(call(1, &[7], &[1.0]), fmi2Error);
    assert!(h.error().contains("unknown value reference 7"));
    h.reset();
    h.init();
    assert_eq!(call(1, &[0], &[f64::NAN]), fmi2Error);
    assert!(h.error().contains("seed for `u`"));
}

#[test]
fn input_derivatives_need_the_capability() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.input_derivative(0, 1, 1.0), fmi2Error);
    assert!(h.error().contains("canInterpolateInputs = false"));
    h.reset();
    h.init();
    assert_eq!(h.output_derivative(0, 1), fmi2Error);
    assert!(h.error().contains("maxOutputDerivativeOrder = 0"));
}

#[test]
fn an_initialization_warning_is_logged_and_returned_and_the_run_goes_on() {
    let h = Harness::new();
    h.setup(None);
    h.enter();
    h.set(0, 5.0);
    assert_eq!(h.exit(), fmi2Warning);
    let m = h.messages();
    assert_eq!(m.len(), 1, "loggingOn = false still shows warnings: {m:?}");
    assert_eq!(m[0].status, fmi2Warning);
    assert_eq!(
        (m[0].category.as_str(), m[0].text.as_str()),
        ("logWarning", "fmi2ExitInitializationMode: u starts at 5")
    );
    assert_eq!(h.phase(), Phase::StepMode);
    assert_eq!(h.step(0.0, 1.0), fmi2OK);

    h.reset();
    assert_eq!(h.debug_logging(false, &[c"logWarning"]), fmi2OK);
    h.setup(None);
    h.enter();
    h.set(0, 5.0);
    assert_eq!(h.exit(), fmi2Warning, "the status says so even when the message is switched off");
    assert!(h.messages().is_empty());

    h.reset();
    h.init();
    assert_eq!(h.phase(), Phase::StepMode);
    assert!(h.messages().is_empty(), "no warning without cause");
}

#[test]
fn debug_logging_categories() {
    let h = Harness::new();
    assert_eq!(h.debug_logging(true, &[c"logInfo"]), fmi2OK);
    h.enter();
    let m = h.messages();
    assert_eq!(m.len(), 1);
    assert_eq!((m[0].category.as_str(), m[0].text.as_str()), ("logInfo", "entered initialization mode"));
    assert_eq!(h.debug_logging(false, &[]), fmi2OK, "all categories off");
    assert_eq!(h.enter(), fmi2Error);
    assert!(h.messages().is_empty(), "logError was switched off too");
    h.reset();
    assert_eq!(h.debug_logging(true, &[c"logEverything"]), fmi2Error);
    h.reset();
    assert_eq!(h.debug_logging(true, &[c"logAll"]), fmi2OK);
    h.messages();
    assert_eq!(h.step(0.0, 1.0), fmi2Error);
    assert!(h.error().contains("not allowed"), "errors are logged again");
}

#[test]
fn status_queries() {
    let h = Harness::new();
    h.init();
    h.step(0.0, 0.25);
    assert_eq!(h.last_successful_time(), (fmi2OK, 0.25));
    assert_eq!(h.terminated(), (fmi2OK, fmi2False));
    assert_eq!(h.do_step_status(), fmi2Discard);
    assert_eq!(h.phase(), StepMode, "fmi2Discard does not enter the error state");
    assert_eq!(h.cancel(), fmi2Error);
}

#[test]
fn a_model_that_ends_returns_discard_with_terminated_and_last_successful_time() {
    let h = Harness::new();
    h.init();
    assert_eq!(h.step(0.0, 0.25), fmi2OK);
    let mut saved = NO_STATE;
    assert_eq!(h.get_state(&mut saved), fmi2OK);
    h.set(0, 99.0);
    assert_eq!(h.step(0.25, 0.5), fmi2Discard);
    assert!(h.messages().iter().any(|m| m.status == fmi2Discard && m.text.contains("stopped at t = 0.5")));
    assert_eq!(h.phase(), StepFailed);
    assert_eq!((h.last_successful_time(), h.terminated()), ((fmi2OK, 0.5), (fmi2OK, fmi2True)));
    // The values at the last successful time can be read; no further step.
    assert_eq!(h.get(1), 2.0 * 99.0 + 99.0 * 0.25);
    assert_eq!(h.step(0.5, 0.1), fmi2Error);
    assert!(h.error().contains("not allowed in state `step failed"));
    // A state saved before the step brings the instance back.
    assert_eq!(h.set_state(saved), fmi2OK);
    assert_eq!(h.phase(), StepMode);
    assert_eq!(h.terminated(), (fmi2OK, fmi2False));
    h.free_state(&mut saved);
    assert_eq!(h.step(0.25, 0.25), fmi2OK);
    // fmi2Terminate is allowed after a discarded step.
    h.set(0, 99.0);
    assert_eq!(h.step(0.5, 0.25), fmi2Discard);
    assert_eq!(h.terminate(), fmi2OK);
}

#[test]
fn a_non_finite_output_is_an_error_naming_variable_and_time() {
    let h = Harness::new();
    h.init();
    h.step(0.0, 0.5);
    h.reset();
    h.set(2, 7.0);
    h.init();
    assert_eq!(h.try_get(1).0, fmi2Error);
    let e = h.error();
    assert!(e.contains("`y` (output, continuous) = NaN") && e.contains("at t = 0"), "{e}");
}

#[test]
fn the_step_map_extension_is_refused_without_the_capability() {
    let h = Harness::new();
    h.init();
    let mut out = 0.0;
    assert_eq!(h.derivative(Derivative::StepMap, 1, &[0], &[1.0], &mut out), fmi2Error);
    assert!(h.error().contains("feedsimGetStepMapDerivative: not provided"));
}
