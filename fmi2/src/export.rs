//! Exporting a Rust model as an FMI 2.0 Co-Simulation FMU.
//!
//! A model implements [`Model`] (physics only); `fmi2::export_fmu!(MyModel);` in a cdylib crate
//! exports the 34 `fmi2*` functions. The layer owns everything the standard asks of an FMU: the
//! state machine, value-reference/causality/NaN checks, logging, panic containment, FMU states
//! and their serialization, and communication-time bookkeeping.

use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use crate::description::{Causality, DescriptionError, ModelDescription, ModelInfo, SetPhase, VarInfo, VarType};
use crate::ffi::*;

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

/// What a model implements. The layer has already checked the value reference (it exists and has
/// the right type), the causality/variability against the current state, and that Reals are
/// finite; the model only does physics and its own range checks. The layer adds the function and
/// variable names to the errors.
pub trait Model: Sized + Send + 'static {
    /// Static description; `modelDescription.xml` is generated from it.
    fn description() -> Result<ModelDescription, ModelError>;

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

    /// Advance from `t` to `t + h` with the inputs currently set (and their derivatives, if the
    /// model interpolates inputs). `t` is the importer's communication point, already checked
    /// against the instance's own time.
    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError>;

    /// First-order derivative of a Real input at the current communication point (only with
    /// `can_interpolate_inputs`; the layer rejects other orders). Convention of this workspace:
    /// the input is `u(t) + u̇ (τ − t)` during the next `do_step` only; the model clears `u̇`
    /// after that step, so a master that wants extrapolation sets it before every step.
    fn set_real_input_derivative(&mut self, _vr: u32, _order: i32, _value: f64) -> Result<(), ModelError> {
        Err("input derivatives are not supported".into())
    }

    /// `fmi2GetDirectionalDerivative` as FMI 2.0 defines it (only with
    /// `provides_directional_derivative`): `out[i] = Σ_j ∂unknowns[i]/∂knowns[j] · seed[j]` at the
    /// current instant — what `fmi2GetReal` of the unknowns would do if the knowns were changed
    /// by `fmi2SetReal` now, without a step. Unknowns are Real outputs/locals/calculated
    /// parameters, knowns Real inputs or parameters; parameters with a zero seed are removed by
    /// the layer.
    fn directional_derivative(
        &mut self,
        _unknowns: &[u32],
        _knowns: &[u32],
        _seed: &[f64],
        _out: &mut [f64],
    ) -> Result<(), ModelError> {
        Err("directional derivatives are not provided".into())
    }

    /// The extension `feedsimGetStepMapDerivative` (only with `provides_step_map_derivative`):
    /// derivatives of the step map, the unknowns after the last `do_step` with respect to the
    /// input values held during it. Same arguments as [`Model::directional_derivative`].
    fn step_map_derivative(
        &mut self,
        _unknowns: &[u32],
        _knowns: &[u32],
        _seed: &[f64],
        _out: &mut [f64],
    ) -> Result<(), ModelError> {
        Err("step-map derivatives are not provided".into())
    }

    /// Append the complete model state to `out` (everything `do_step` and the getters read).
    fn save_state(&self, out: &mut Vec<u8>) -> Result<(), ModelError>;
    /// Restore a state written by `save_state` of this model (possibly another instance).
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError>;
}

/// Model errors as the layer's messages.
trait Msg<T> {
    fn msg(self) -> Result<T, String>;
}

impl<T> Msg<T> for Result<T, ModelError> {
    fn msg(self) -> Result<T, String> {
        self.map_err(|e| error_chain(&*e))
    }
}

/// An error with its chain of sources, `a: b: c`.
fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    text
}

/// The phases of the FMI 2.0 Co-Simulation state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Instantiated,
    InitializationMode,
    StepMode,
    Terminated,
    Error,
    Fatal,
    /// `fmi2DoStep` returned `fmi2Discard` (the model stopped early): values and statuses can be
    /// read, the state can be set back; no further step.
    StepFailed,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "instantiated",
            Phase::InitializationMode => "initialization mode",
            Phase::StepMode => "step mode",
            Phase::Terminated => "terminated",
            Phase::Error => "error",
            Phase::Fatal => "fatal",
            Phase::StepFailed => "step failed (discarded)",
        }
    }
    fn code(self) -> u8 {
        self as u8
    }
    /// The phases a saved state can hold.
    fn from_code(c: u8) -> Option<Phase> {
        [Instantiated, InitializationMode, StepMode, Terminated, StepFailed].into_iter().find(|p| p.code() == c)
    }
}

use Phase::*;
const ALL_BUT_FATAL: &[Phase] = &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated, Error];
const GETTABLE: &[Phase] = &[InitializationMode, StepMode, StepFailed, Terminated, Error];
const SETTABLE: &[Phase] = &[Instantiated, InitializationMode, StepMode];
const STATE_OK: &[Phase] = &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated];
/// Where the `fmi2Get*Status` functions may be called.
const STATUS_OK: &[Phase] = &[StepMode, StepFailed, Terminated, Error];
/// Freeing a saved state touches no model data: allowed even after a fatal error.
const ANY: &[Phase] = &[Instantiated, InitializationMode, StepMode, StepFailed, Terminated, Error, Fatal];

/// Relative tolerance for matching the importer's communication point with the instance's time.
pub const TIME_RTOL: f64 = 1e-9;

/// One FMU instance: what `fmi2Component` points to.
pub struct Instance<M: Model> {
    info: &'static ModelInfo,
    name: CString,
    resources: Option<PathBuf>,
    logger: fmi2CallbackLogger,
    environment: fmi2ComponentEnvironment,
    log_errors: bool,
    log_info: bool,
    phase: Phase,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    /// The model ended the simulation (a step returned [`StepOutcome::Terminated`]).
    terminated: bool,
    model: M,
    /// Strings handed out by `fmi2GetString`; valid until the next `fmi2GetString`.
    strings: Vec<CString>,
    scratch_unknowns: Vec<u32>,
    scratch_knowns: Vec<u32>,
    scratch_seed: Vec<f64>,
}

impl<M: Model> Instance<M> {
    pub fn phase(&self) -> Phase {
        self.phase
    }
    pub fn model(&self) -> &M {
        &self.model
    }

    fn log(&self, status: fmi2Status, message: &str) {
        // A discarded step is reported like an error: the importer must learn why the model ended.
        let category = if status >= fmi2Discard { "logError" } else { "logInfo" };
        let enabled = if status >= fmi2Discard { self.log_errors } else { self.log_info };
        if enabled {
            log_to(self.logger, self.environment, &self.name, status, category, message);
        }
    }
}

/// Calls the importer's printf-style logger with `message` as the format: `%` is escaped.
fn log_to(
    logger: fmi2CallbackLogger,
    env: fmi2ComponentEnvironment,
    name: &CStr,
    status: fmi2Status,
    category: &str,
    message: &str,
) {
    let Some(logger) = logger else { return };
    let text = CString::new(message.replace('%', "%%").replace('\0', "")).unwrap_or_default();
    let cat = CString::new(category).unwrap_or_default();
    // SAFETY: the importer promised a valid logger; all strings are NUL-terminated and live.
    unsafe { logger(env, name.as_ptr(), status, cat.as_ptr(), text.as_ptr()) };
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic payload".to_owned()
    }
}

/// Runs `body` on the instance if the call is allowed in its phase; contains panics; turns an
/// `Err` into `fmi2Error` (the instance enters the error state, as the standard says) with the
/// message logged under the function's name.
///
/// # Safety
/// `c` is null or a pointer returned by `instantiate::<M>` and not yet freed.
unsafe fn call<M: Model>(
    c: fmi2Component,
    func: &'static str,
    allowed: &[Phase],
    body: impl FnOnce(&mut Instance<M>) -> Result<fmi2Status, String>,
) -> fmi2Status {
    if c.is_null() {
        return fmi2Error;
    }
    let inst = c.cast::<Instance<M>>();
    // SAFETY: by the contract above, `inst` is a live instance used by one thread at a time.
    let phase = unsafe { (*inst).phase };
    if phase == Fatal && !allowed.contains(&Fatal) {
        unsafe {
            (*inst).log(
                fmi2Fatal,
                &format!("{func}: the instance is in the fatal state; only fmi2FreeInstance is allowed"),
            )
        };
        return fmi2Fatal;
    }
    if !allowed.contains(&phase) {
        unsafe {
            (*inst).log(fmi2Error, &format!("{func}: not allowed in state `{}`", phase.name()));
            (*inst).phase = Error;
        }
        return fmi2Error;
    }
    match catch_unwind(AssertUnwindSafe(|| body(unsafe { &mut *inst }))) {
        Ok(Ok(status)) => status,
        Ok(Err(message)) => unsafe {
            (*inst).phase = Error;
            (*inst).log(fmi2Error, &format!("{func}: {message}"));
            fmi2Error
        },
        Err(payload) => unsafe {
            (*inst).phase = Fatal;
            (*inst).log(fmi2Fatal, &format!("{func}: internal error (panic): {}", panic_text(&*payload)));
            fmi2Fatal
        },
    }
}

/// A slice from an importer's pointer and length; null is an error unless the length is 0.
///
/// # Safety
/// A non-null `ptr` points to `n` valid elements.
unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        Ok(&[])
    } else if ptr.is_null() {
        Err(format!("`{what}` is a null pointer (length {n})"))
    } else {
        Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
    }
}

/// # Safety
/// A non-null `ptr` points to `n` writable elements.
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], String> {
    if n == 0 {
        Ok(&mut [])
    } else if ptr.is_null() {
        Err(format!("`{what}` is a null pointer (length {n})"))
    } else {
        Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
    }
}

fn find(info: &ModelInfo, t: VarType, vr: u32) -> Result<&VarInfo, String> {
    info.lookup(t, vr).ok_or_else(|| format!("unknown value reference {vr} (no {} variable has it)", t.as_str()))
}

fn describe(v: &VarInfo) -> String {
    format!("`{}` ({}, {})", v.var.name, v.var.causality.as_str(), v.var.variability.as_str())
}

fn set_phase(p: Phase) -> SetPhase {
    match p {
        Instantiated => SetPhase::Instantiated,
        InitializationMode => SetPhase::InitializationMode,
        _ => SetPhase::StepMode,
    }
}

/// Layer header of a saved state: magic, format version, GUID, layer fields, model bytes.
const STATE_MAGIC: &[u8; 8] = b"FMI2RSv1";
/// Tag at the start of every `fmi2FMUstate` this layer allocates.
const SNAPSHOT_TAG: u64 = 0x5253_5441_5445_4d49;

/// What an `fmi2FMUstate` points to: the serialized form, so get/set and (de)serialize share
/// one mechanism and a rollback restores the state bit for bit.
struct Snapshot {
    tag: u64,
    bytes: Vec<u8>,
}

impl<M: Model> Instance<M> {
    fn save_into(&self, out: &mut Vec<u8>) -> Result<(), String> {
        out.clear();
        out.extend_from_slice(STATE_MAGIC);
        let mut w = crate::state_bytes::StateWriter::new(out);
        w.str(&self.info.description.guid).u8(self.phase.code());
        w.f64(self.time).f64(self.start_time).f64(self.stop_time.unwrap_or(f64::NAN)).bool(self.stop_time.is_some());
        w.bool(self.terminated);
        let len_at = out.len();
        out.extend_from_slice(&0u64.to_le_bytes());
        self.model.save_state(out).msg()?;
        let model_len = (out.len() - len_at - 8) as u64;
        out[len_at..len_at + 8].copy_from_slice(&model_len.to_le_bytes());
        Ok(())
    }

    /// Parsed layer fields and the model part; checks everything but the model bytes.
    fn check_state<'b>(&self, bytes: &'b [u8]) -> Result<SavedLayer<'b>, String> {
        if bytes.len() < 8 || &bytes[..8] != STATE_MAGIC {
            return Err("not a state of this FMU (wrong header)".into());
        }
        let bad = |e: String| format!("not a state of this FMU: {e}");
        let mut r = crate::state_bytes::StateReader::new(&bytes[8..]);
        let guid = r.string().map_err(bad)?;
        if guid != self.info.description.guid {
            return Err(format!(
                "the state belongs to an FMU with GUID `{guid}`, this one has `{}`",
                self.info.description.guid
            ));
        }
        let code = r.u8().map_err(bad)?;
        let phase = Phase::from_code(code).ok_or_else(|| bad(format!("phase code {code}")))?;
        let (time, start_time, stop) = (r.f64().map_err(bad)?, r.f64().map_err(bad)?, r.f64().map_err(bad)?);
        let has_stop = r.bool().map_err(bad)?;
        let terminated = r.bool().map_err(bad)?;
        let model_len = r.u64().map_err(bad)?;
        let model = r.rest();
        if model.len() as u64 != model_len {
            return Err(bad(format!("model part is {} bytes, header says {model_len}", model.len())));
        }
        Ok(SavedLayer { phase, time, start_time, stop_time: has_stop.then_some(stop), terminated, model })
    }

    fn restore_from(&mut self, bytes: &[u8]) -> Result<(), String> {
        let saved = self.check_state(bytes)?;
        self.model.restore_state(saved.model).msg()?;
        (self.phase, self.time, self.start_time, self.stop_time, self.terminated) =
            (saved.phase, saved.time, saved.start_time, saved.stop_time, saved.terminated);
        Ok(())
    }
}

/// The layer's part of a saved state, and the model's bytes.
struct SavedLayer<'b> {
    phase: Phase,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    terminated: bool,
    model: &'b [u8],
}

/// The entry points the [`export_fmu!`](crate::export_fmu) macro forwards to. Each mirrors the
/// C function of the same name; the pointers come from the importer.
#[doc(hidden)]
pub mod entry {
    use super::*;

    pub fn types_platform() -> *const c_char {
        c"default".as_ptr()
    }

    pub fn version() -> *const c_char {
        c"2.0".as_ptr()
    }

    /// The validated description of a model, built once per process (inside `fmi2Instantiate`'s
    /// panic guard).
    pub fn model_info<M: Model>() -> Result<ModelInfo, DescriptionError> {
        ModelInfo::new(M::description().map_err(|e| DescriptionError(error_chain(&*e)))?)
    }

    /// Where the macro keeps a model's description for the life of the process.
    pub type InfoCell = std::sync::OnceLock<Result<ModelInfo, DescriptionError>>;

    /// # Safety
    /// Pointers are null or valid C strings / a valid callback struct, as the standard requires.
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
        // SAFETY: checked non-null; the struct is copied, so the importer may free it.
        let cb = unsafe { *functions };
        let name = if instance_name.is_null() {
            c"(unnamed)".to_owned()
        } else {
            unsafe { CStr::from_ptr(instance_name) }.to_owned()
        };
        let fail = |msg: String| {
            log_to(
                cb.logger,
                cb.componentEnvironment,
                &name,
                fmi2Error,
                "logError",
                &format!("fmi2Instantiate: {msg}"),
            );
            std::ptr::null_mut()
        };
        let result = catch_unwind(AssertUnwindSafe(|| -> Result<fmi2Component, String> {
            let info = info.get_or_init(model_info::<M>).as_ref().map_err(|e| e.to_string())?;
            if instance_name.is_null() {
                return Err("instanceName is a null pointer".into());
            }
            if fmu_type != fmi2CoSimulation {
                return Err(format!("fmuType = {fmu_type}: this FMU supports Co-Simulation (1) only"));
            }
            if guid.is_null() {
                return Err("fmuGUID is a null pointer".into());
            }
            let guid = unsafe { CStr::from_ptr(guid) }.to_string_lossy();
            if guid != info.description.guid {
                return Err(format!(
                    "fmuGUID `{guid}` does not match this binary's `{}` (modelDescription.xml from another build?)",
                    info.description.guid
                ));
            }
            let location = if resource_location.is_null() {
                String::new()
            } else {
                unsafe { CStr::from_ptr(resource_location) }.to_string_lossy().into_owned()
            };
            let resources = crate::uri::resource_dir(&location)?;
            let model = M::instantiate(resources.as_deref()).msg()?;
            let inst = Instance {
                info,
                name: name.clone(),
                resources,
                logger: cb.logger,
                environment: cb.componentEnvironment,
                log_errors: true,
                log_info: logging_on != fmi2False,
                phase: Instantiated,
                time: 0.0,
                start_time: 0.0,
                stop_time: None,
                terminated: false,
                model,
                strings: Vec::new(),
                scratch_unknowns: Vec::new(),
                scratch_knowns: Vec::new(),
                scratch_seed: Vec::new(),
            };
            inst.log(
                fmi2OK,
                &format!("instantiated `{}` (resources: {:?})", info.description.model_name, inst.resources),
            );
            Ok(Box::into_raw(Box::new(inst)).cast())
        }));
        match result {
            Ok(Ok(c)) => c,
            Ok(Err(msg)) => fail(msg),
            Err(payload) => fail(format!("internal error (panic): {}", panic_text(&*payload))),
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; it is invalid afterwards.
    pub unsafe fn free_instance<M: Model>(c: fmi2Component) {
        if !c.is_null() {
            // A panicking destructor must not unwind into C; the memory is then leaked.
            let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(c.cast::<Instance<M>>()) })));
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; `categories` holds `n` C strings.
    pub unsafe fn set_debug_logging<M: Model>(
        c: fmi2Component,
        logging_on: fmi2Boolean,
        n: usize,
        categories: *const fmi2String,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2SetDebugLogging", ALL_BUT_FATAL, |inst| {
                let on = logging_on != fmi2False;
                let cats = slice(categories, n, "categories")?;
                if cats.is_empty() {
                    (inst.log_errors, inst.log_info) = (on, on);
                }
                for &cat in cats {
                    if cat.is_null() {
                        return Err("a category is a null pointer".into());
                    }
                    match CStr::from_ptr(cat).to_string_lossy().as_ref() {
                        "logAll" => (inst.log_errors, inst.log_info) = (on, on),
                        "logError" => inst.log_errors = on,
                        "logInfo" => inst.log_info = on,
                        other => {
                            return Err(format!("unknown log category `{other}` (known: logError, logInfo, logAll)"));
                        }
                    }
                }
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn setup_experiment<M: Model>(
        c: fmi2Component,
        _tolerance_defined: fmi2Boolean,
        _tolerance: f64,
        start_time: f64,
        stop_time_defined: fmi2Boolean,
        stop_time: f64,
    ) -> fmi2Status {
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
    /// `c` is null or a live instance of `M`.
    pub unsafe fn enter_initialization_mode<M: Model>(c: fmi2Component) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2EnterInitializationMode", &[Instantiated], |inst| {
                inst.phase = InitializationMode;
                inst.log(fmi2OK, "entered initialization mode");
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn exit_initialization_mode<M: Model>(c: fmi2Component) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2ExitInitializationMode", &[InitializationMode], |inst| {
                inst.model.exit_initialization(inst.start_time).msg()?;
                (inst.phase, inst.time) = (StepMode, inst.start_time);
                inst.log(fmi2OK, &format!("entered step mode at t = {}", inst.time));
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn terminate<M: Model>(c: fmi2Component) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2Terminate", &[StepMode, StepFailed], |inst| {
                inst.phase = Terminated;
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn reset<M: Model>(c: fmi2Component) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2Reset", ALL_BUT_FATAL, |inst| {
                inst.model = M::instantiate(inst.resources.as_deref()).msg()?;
                (inst.phase, inst.time, inst.start_time, inst.stop_time, inst.terminated) =
                    (Instantiated, 0.0, 0.0, None, false);
                Ok(fmi2OK)
            })
        }
    }

    /// Shared body of `fmi2Get{Real,Integer,Boolean}`; `invalid` refuses a value the model
    /// should never report (a non-finite Real).
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
        unsafe {
            call::<M>(c, func, GETTABLE, |inst| {
                let (vrs, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
                for (&r, o) in vrs.iter().zip(out.iter_mut()) {
                    let v = find(inst.info, t, r)?;
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
    #[allow(clippy::too_many_arguments)]
    unsafe fn set<M: Model, T: Copy>(
        c: fmi2Component,
        func: &'static str,
        t: VarType,
        vr: *const fmi2ValueReference,
        n: usize,
        value: *const T,
        invalid: impl Fn(T) -> Option<String>,
        write: impl Fn(&mut M, u32, T) -> Result<(), ModelError>,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, func, SETTABLE, |inst| {
                let (vrs, vals) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
                let phase = set_phase(inst.phase);
                for (&r, &x) in vrs.iter().zip(vals) {
                    let v = find(inst.info, t, r)?;
                    if !v.settable_in(phase) {
                        return Err(format!("{} cannot be set in state `{}`", describe(v), inst.phase.name()));
                    }
                    if let Some(why) = invalid(x) {
                        return Err(format!("{} = {why}", describe(v)));
                    }
                }
                for (&r, &x) in vrs.iter().zip(vals) {
                    write(&mut inst.model, r, x)
                        .msg()
                        .map_err(|e| format!("{}: {e}", describe(find(inst.info, t, r).expect("checked"))))?;
                }
                Ok(fmi2OK)
            })
        }
    }

    fn finite(x: f64) -> Option<String> {
        (!x.is_finite()).then(|| format!("{x}: not a finite number"))
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; arrays hold `n` elements.
    pub unsafe fn get_real<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut f64) -> fmi2Status {
        unsafe { get::<M, f64>(c, "fmi2GetReal", VarType::Real, vr, n, value, |m, r| m.get_real(r), |x| finite(*x)) }
    }
    /// # Safety
    /// As [`get_real`].
    pub unsafe fn get_integer<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut i32) -> fmi2Status {
        unsafe { get::<M, i32>(c, "fmi2GetInteger", VarType::Integer, vr, n, value, |m, r| m.get_integer(r), |_| None) }
    }
    /// # Safety
    /// As [`get_real`].
    pub unsafe fn get_boolean<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *mut i32) -> fmi2Status {
        unsafe {
            get::<M, i32>(
                c,
                "fmi2GetBoolean",
                VarType::Boolean,
                vr,
                n,
                value,
                |m, r| m.get_boolean(r).map(i32::from),
                |_| None,
            )
        }
    }
    /// # Safety
    /// As [`get_real`]. The returned strings stay valid until the next `fmi2GetString`.
    pub unsafe fn get_string<M: Model>(
        c: fmi2Component,
        vr: *const u32,
        n: usize,
        value: *mut fmi2String,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2GetString", GETTABLE, |inst| {
                let (vrs, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
                inst.strings.clear();
                for &r in vrs {
                    let v = find(inst.info, VarType::String, r)?;
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
    /// `c` is null or a live instance of `M`; arrays hold `n` elements.
    pub unsafe fn set_real<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const f64) -> fmi2Status {
        unsafe { set::<M, f64>(c, "fmi2SetReal", VarType::Real, vr, n, value, finite, |m, r, x| m.set_real(r, x)) }
    }
    /// # Safety
    /// As [`set_real`].
    pub unsafe fn set_integer<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const i32) -> fmi2Status {
        unsafe {
            set::<M, i32>(c, "fmi2SetInteger", VarType::Integer, vr, n, value, |_| None, |m, r, x| m.set_integer(r, x))
        }
    }
    /// # Safety
    /// As [`set_real`].
    pub unsafe fn set_boolean<M: Model>(c: fmi2Component, vr: *const u32, n: usize, value: *const i32) -> fmi2Status {
        unsafe {
            set::<M, i32>(
                c,
                "fmi2SetBoolean",
                VarType::Boolean,
                vr,
                n,
                value,
                |_| None,
                |m, r, x| m.set_boolean(r, x != fmi2False),
            )
        }
    }
    /// # Safety
    /// As [`set_real`]; each string is a valid C string (copied, the caller keeps ownership).
    pub unsafe fn set_string<M: Model>(
        c: fmi2Component,
        vr: *const u32,
        n: usize,
        value: *const fmi2String,
    ) -> fmi2Status {
        let invalid = |p: fmi2String| {
            if p.is_null() {
                Some("a null pointer".to_owned())
            } else if unsafe { CStr::from_ptr(p) }.to_str().is_err() {
                Some("a string that is not UTF-8".to_owned())
            } else {
                None
            }
        };
        unsafe {
            set::<M, fmi2String>(c, "fmi2SetString", VarType::String, vr, n, value, invalid, |m, r, p| {
                m.set_string(r, CStr::from_ptr(p).to_str().expect("checked"))
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; `state` points to an `fmi2FMUstate` that is null or
    /// was made by this layer.
    pub unsafe fn get_fmu_state<M: Model>(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2GetFMUstate", STATE_OK, |inst| {
                if state.is_null() {
                    return Err("`FMUstate` is a null pointer".into());
                }
                if (*state).is_null() {
                    let mut bytes = Vec::new();
                    inst.save_into(&mut bytes)?;
                    *state = Box::into_raw(Box::new(Snapshot { tag: SNAPSHOT_TAG, bytes })).cast();
                } else {
                    // Overwrite in place: a rollback loop allocates nothing after the first step.
                    let snap = snapshot_mut(*state)?;
                    inst.save_into(&mut snap.bytes)?;
                }
                Ok(fmi2OK)
            })
        }
    }

    unsafe fn snapshot_mut<'a>(state: fmi2FMUstate) -> Result<&'a mut Snapshot, String> {
        if state.is_null() {
            return Err("`FMUstate` is a null pointer".into());
        }
        let snap = unsafe { &mut *state.cast::<Snapshot>() };
        if snap.tag != SNAPSHOT_TAG {
            return Err("`FMUstate` was not created by this FMU".into());
        }
        Ok(snap)
    }

    /// # Safety
    /// As [`get_fmu_state`].
    pub unsafe fn set_fmu_state<M: Model>(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2SetFMUstate", ALL_BUT_FATAL, |inst| {
                let snap = snapshot_mut(state)?;
                inst.restore_from(&snap.bytes)?;
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// As [`get_fmu_state`]; `*state` is null afterwards.
    pub unsafe fn free_fmu_state<M: Model>(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2FreeFMUstate", ANY, |_| {
                if state.is_null() || (*state).is_null() {
                    return Ok(fmi2OK);
                }
                snapshot_mut(*state)?;
                drop(Box::from_raw((*state).cast::<Snapshot>()));
                *state = std::ptr::null_mut();
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// As [`get_fmu_state`]; `size` is writable.
    pub unsafe fn serialized_fmu_state_size<M: Model>(
        c: fmi2Component,
        state: fmi2FMUstate,
        size: *mut usize,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2SerializedFMUstateSize", ALL_BUT_FATAL, |_| {
                let snap = snapshot_mut(state)?;
                *slice_mut(size, 1, "size")?.first_mut().expect("one") = snap.bytes.len();
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// As [`get_fmu_state`]; `bytes` holds `size` writable bytes.
    pub unsafe fn serialize_fmu_state<M: Model>(
        c: fmi2Component,
        state: fmi2FMUstate,
        bytes: *mut fmi2Byte,
        size: usize,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2SerializeFMUstate", ALL_BUT_FATAL, |_| {
                let snap = snapshot_mut(state)?;
                if size < snap.bytes.len() {
                    return Err(format!(
                        "buffer of {size} bytes is smaller than the state ({} bytes)",
                        snap.bytes.len()
                    ));
                }
                let out = slice_mut(bytes.cast::<u8>(), size, "serializedState")?;
                out[..snap.bytes.len()].copy_from_slice(&snap.bytes);
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// As [`get_fmu_state`]; `bytes` holds `size` readable bytes.
    pub unsafe fn deserialize_fmu_state<M: Model>(
        c: fmi2Component,
        bytes: *const fmi2Byte,
        size: usize,
        state: *mut fmi2FMUstate,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2DeSerializeFMUstate", ALL_BUT_FATAL, |inst| {
                let data = slice(bytes.cast::<u8>(), size, "serializedState")?;
                if state.is_null() {
                    return Err("`FMUstate` is a null pointer".into());
                }
                inst.check_state(data)?;
                if (*state).is_null() {
                    *state = Box::into_raw(Box::new(Snapshot { tag: SNAPSHOT_TAG, bytes: data.to_vec() })).cast();
                } else {
                    let snap = snapshot_mut(*state)?;
                    snap.bytes.clear();
                    snap.bytes.extend_from_slice(data);
                }
                Ok(fmi2OK)
            })
        }
    }

    /// Which derivative a call asks for.
    #[derive(Clone, Copy)]
    enum Derivative {
        /// `fmi2GetDirectionalDerivative`: at the current instant.
        Instant,
        /// `feedsimGetStepMapDerivative`: of the last step's map.
        StepMap,
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; arrays hold the given numbers of elements.
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn get_directional_derivative<M: Model>(
        c: fmi2Component,
        v_unknown: *const u32,
        n_unknown: usize,
        v_known: *const u32,
        n_known: usize,
        dv_known: *const f64,
        dv_unknown: *mut f64,
    ) -> fmi2Status {
        // SAFETY: forwarded contract.
        unsafe { derivative::<M>(c, Derivative::Instant, v_unknown, n_unknown, v_known, n_known, dv_known, dv_unknown) }
    }

    /// `feedsimGetStepMapDerivative`: the signature of `fmi2GetDirectionalDerivative`, the
    /// derivatives of the last step's map (see [`Model::step_map_derivative`]).
    ///
    /// # Safety
    /// As [`get_directional_derivative`].
    #[allow(clippy::too_many_arguments)]
    pub unsafe fn get_step_map_derivative<M: Model>(
        c: fmi2Component,
        v_unknown: *const u32,
        n_unknown: usize,
        v_known: *const u32,
        n_known: usize,
        dv_known: *const f64,
        dv_unknown: *mut f64,
    ) -> fmi2Status {
        // SAFETY: forwarded contract.
        unsafe { derivative::<M>(c, Derivative::StepMap, v_unknown, n_unknown, v_known, n_known, dv_known, dv_unknown) }
    }

    /// Shared body of both derivative functions: checks, parameter seeds dropped, result checked.
    ///
    /// # Safety
    /// As [`get_directional_derivative`].
    #[allow(clippy::too_many_arguments)]
    unsafe fn derivative<M: Model>(
        c: fmi2Component,
        which: Derivative,
        v_unknown: *const u32,
        n_unknown: usize,
        v_known: *const u32,
        n_known: usize,
        dv_known: *const f64,
        dv_unknown: *mut f64,
    ) -> fmi2Status {
        let func = match which {
            Derivative::Instant => "fmi2GetDirectionalDerivative",
            Derivative::StepMap => "feedsimGetStepMapDerivative",
        };
        // SAFETY: `c` as the caller promised; the slices below are built from the importer's
        // pointers and lengths, which the standard makes the importer's responsibility.
        unsafe {
            call::<M>(c, func, GETTABLE, |inst| {
                let caps = inst.info.description.capabilities;
                match which {
                    Derivative::Instant if !caps.provides_directional_derivative => {
                        return Err("not provided by this FMU (providesDirectionalDerivative = false)".into());
                    }
                    Derivative::StepMap if !caps.provides_step_map_derivative => {
                        return Err("not provided by this FMU (no StepMapDerivative vendor annotation)".into());
                    }
                    _ => {}
                }
                let unknowns = slice(v_unknown, n_unknown, "vUnknown_ref")?;
                let knowns = slice(v_known, n_known, "vKnown_ref")?;
                let seed = slice(dv_known, n_known, "dvKnown")?;
                let out = slice_mut(dv_unknown, n_unknown, "dvUnknown")?;
                let mut u = std::mem::take(&mut inst.scratch_unknowns);
                let mut k = std::mem::take(&mut inst.scratch_knowns);
                let mut s = std::mem::take(&mut inst.scratch_seed);
                u.clear();
                k.clear();
                s.clear();
                let result = (|| {
                    for &r in unknowns {
                        let v = find(inst.info, VarType::Real, r)?;
                        let c = v.var.causality;
                        if !matches!(c, Causality::Output | Causality::Local | Causality::CalculatedParameter) {
                            return Err(format!("{} cannot be an unknown (only outputs and locals)", describe(v)));
                        }
                        u.push(r);
                    }
                    for (&r, &x) in knowns.iter().zip(seed) {
                        let v = find(inst.info, VarType::Real, r)?;
                        let is_param = v.var.causality == Causality::Parameter;
                        if v.var.causality != Causality::Input && !is_param {
                            return Err(format!("{} cannot be a known (only inputs and parameters)", describe(v)));
                        }
                        if let Some(why) = finite(x) {
                            return Err(format!("seed for {} = {why}", describe(v)));
                        }
                        // A zero seed on a parameter contributes nothing (importers such as
                        // OMSimulator pass whole dependency lists).
                        if !(is_param && x == 0.0) {
                            k.push(r);
                            s.push(x);
                        }
                    }
                    match which {
                        Derivative::Instant => inst.model.directional_derivative(&u, &k, &s, out),
                        Derivative::StepMap => inst.model.step_map_derivative(&u, &k, &s, out),
                    }
                    .msg()?;
                    if let Some(i) = out.iter().position(|x| !x.is_finite()) {
                        let v = find(inst.info, VarType::Real, u[i])?;
                        return Err(format!("the derivative of {} is {} at t = {}", describe(v), out[i], inst.time));
                    }
                    Ok(())
                })();
                (inst.scratch_unknowns, inst.scratch_knowns, inst.scratch_seed) = (u, k, s);
                result.map(|()| fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; arrays hold `n` elements.
    pub unsafe fn set_real_input_derivatives<M: Model>(
        c: fmi2Component,
        vr: *const u32,
        n: usize,
        order: *const i32,
        value: *const f64,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2SetRealInputDerivatives", SETTABLE, |inst| {
                if !inst.info.description.capabilities.can_interpolate_inputs {
                    return Err("not supported by this FMU (canInterpolateInputs = false)".into());
                }
                let (vrs, orders, vals) = (slice(vr, n, "vr")?, slice(order, n, "order")?, slice(value, n, "value")?);
                for ((&r, &o), &x) in vrs.iter().zip(orders).zip(vals) {
                    let v = find(inst.info, VarType::Real, r)?;
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
                for ((&r, &o), &x) in vrs.iter().zip(orders).zip(vals) {
                    inst.model.set_real_input_derivative(r, o, x).msg()?;
                }
                Ok(fmi2OK)
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn get_real_output_derivatives<M: Model>(
        c: fmi2Component,
        _vr: *const u32,
        _n: usize,
        _order: *const i32,
        _value: *mut f64,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2GetRealOutputDerivatives", &[StepMode, Terminated, Error], |_| {
                Err("not supported (maxOutputDerivativeOrder = 0)".into())
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn do_step<M: Model>(c: fmi2Component, t: f64, h: f64, _no_prior: fmi2Boolean) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2DoStep", &[StepMode], |inst| {
                if !(t.is_finite() && h.is_finite() && h > 0.0) {
                    return Err(format!(
                        "currentCommunicationPoint = {t}, communicationStepSize = {h}: need finite t and h > 0"
                    ));
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
                let outcome =
                    inst.model.do_step(t, h).msg().map_err(|e| format!("step from t = {t} with h = {h}: {e}"))?;
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
                        inst.log(fmi2Discard, &format!("fmi2DoStep: the model stopped at t = {time}: {reason}"));
                        Ok(fmi2Discard)
                    }
                }
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`.
    pub unsafe fn cancel_step<M: Model>(c: fmi2Component) -> fmi2Status {
        unsafe {
            call::<M>(c, "fmi2CancelStep", ALL_BUT_FATAL, |_| {
                Err("no step is in progress (fmi2DoStep never returns fmi2Pending)".into())
            })
        }
    }

    /// Shared body of the `fmi2Get*Status` functions.
    unsafe fn status<M: Model, T>(
        c: fmi2Component,
        func: &'static str,
        kind: fmi2StatusKind,
        value: *mut T,
        answer: impl Fn(&Instance<M>, fmi2StatusKind) -> Option<T>,
    ) -> fmi2Status {
        unsafe {
            call::<M>(c, func, STATUS_OK, |inst| {
                let out = slice_mut(value, 1, "value")?;
                match answer(inst, kind) {
                    Some(v) => {
                        out[0] = v;
                        Ok(fmi2OK)
                    }
                    None => {
                        inst.log(
                            fmi2Discard,
                            &format!("{func}: status kind {kind} is not available (no asynchronous steps)"),
                        );
                        Ok(fmi2Discard)
                    }
                }
            })
        }
    }

    /// # Safety
    /// `c` is null or a live instance of `M`; `value` is writable.
    pub unsafe fn get_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Status) -> fmi2Status {
        unsafe { status::<M, fmi2Status>(c, "fmi2GetStatus", s, value, |_, _| None) }
    }
    /// # Safety
    /// As [`get_status`].
    pub unsafe fn get_real_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut f64) -> fmi2Status {
        unsafe {
            status::<M, f64>(c, "fmi2GetRealStatus", s, value, |inst, k| {
                (k == fmi2LastSuccessfulTime).then_some(inst.time)
            })
        }
    }
    /// # Safety
    /// As [`get_status`].
    pub unsafe fn get_integer_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut i32) -> fmi2Status {
        unsafe { status::<M, i32>(c, "fmi2GetIntegerStatus", s, value, |_, _| None) }
    }
    /// # Safety
    /// As [`get_status`].
    pub unsafe fn get_boolean_status<M: Model>(c: fmi2Component, s: fmi2StatusKind, value: *mut i32) -> fmi2Status {
        unsafe {
            status::<M, i32>(c, "fmi2GetBooleanStatus", s, value, |inst, k| {
                (k == fmi2Terminated).then_some(if inst.terminated { fmi2True } else { fmi2False })
            })
        }
    }
    /// # Safety
    /// As [`get_status`].
    pub unsafe fn get_string_status<M: Model>(
        c: fmi2Component,
        s: fmi2StatusKind,
        value: *mut fmi2String,
    ) -> fmi2Status {
        unsafe { status::<M, fmi2String>(c, "fmi2GetStringStatus", s, value, |_, _| None) }
    }
}

/// Exports a [`Model`] as the 34 `fmi2*` C functions of an FMI 2.0 Co-Simulation FMU.
/// Invoke once, in a `cdylib` crate: `fmi2::export_fmu!(my_crate::MyModel);`.
#[macro_export]
macro_rules! export_fmu {
    ($model:ty) => {
        const _: () = {
            use $crate::export::entry as e;
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
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: fmi2Component,
                on: fmi2Boolean,
                n: usize,
                cats: *const fmi2String,
            ) -> fmi2Status {
                unsafe { e::set_debug_logging::<M>(c, on, n, cats) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: fmi2String,
                kind: fmi2Type,
                guid: fmi2String,
                resources: fmi2String,
                functions: *const fmi2CallbackFunctions,
                visible: fmi2Boolean,
                logging_on: fmi2Boolean,
            ) -> fmi2Component {
                // SAFETY: the importer's pointers are passed on under the standard's contract.
                unsafe { e::instantiate::<M>(&INFO, name, kind, guid, resources, functions, visible, logging_on) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
                unsafe { e::free_instance::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: fmi2Component,
                tol_defined: fmi2Boolean,
                tol: f64,
                start: f64,
                stop_defined: fmi2Boolean,
                stop: f64,
            ) -> fmi2Status {
                unsafe { e::setup_experiment::<M>(c, tol_defined, tol, start, stop_defined, stop) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
                unsafe { e::enter_initialization_mode::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
                unsafe { e::exit_initialization_mode::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
                unsafe { e::terminate::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
                unsafe { e::reset::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetReal(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *mut f64,
            ) -> fmi2Status {
                unsafe { e::get_real::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> fmi2Status {
                unsafe { e::get_integer::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *mut i32,
            ) -> fmi2Status {
                unsafe { e::get_boolean::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetString(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *mut fmi2String,
            ) -> fmi2Status {
                unsafe { e::get_string::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetReal(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *const f64,
            ) -> fmi2Status {
                unsafe { e::set_real::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> fmi2Status {
                unsafe { e::set_integer::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *const i32,
            ) -> fmi2Status {
                unsafe { e::set_boolean::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetString(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                v: *const fmi2String,
            ) -> fmi2Status {
                unsafe { e::set_string::<M>(c, vr, n, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
                unsafe { e::get_fmu_state::<M>(c, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: fmi2Component, s: fmi2FMUstate) -> fmi2Status {
                unsafe { e::set_fmu_state::<M>(c, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2FreeFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
                unsafe { e::free_fmu_state::<M>(c, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: fmi2Component,
                s: fmi2FMUstate,
                size: *mut usize,
            ) -> fmi2Status {
                unsafe { e::serialized_fmu_state_size::<M>(c, s, size) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: fmi2Component,
                s: fmi2FMUstate,
                bytes: *mut fmi2Byte,
                size: usize,
            ) -> fmi2Status {
                unsafe { e::serialize_fmu_state::<M>(c, s, bytes, size) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: fmi2Component,
                bytes: *const fmi2Byte,
                size: usize,
                s: *mut fmi2FMUstate,
            ) -> fmi2Status {
                unsafe { e::deserialize_fmu_state::<M>(c, bytes, size, s) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: fmi2Component,
                vu: *const u32,
                nu: usize,
                vk: *const u32,
                nk: usize,
                dvk: *const f64,
                dvu: *mut f64,
            ) -> fmi2Status {
                unsafe { e::get_directional_derivative::<M>(c, vu, nu, vk, nk, dvk, dvu) }
            }
            /// The opt-in extension of this workspace (see `fmi2::export::Model::step_map_derivative`);
            /// exported always, announced in modelDescription.xml only when the model provides it.
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn feedsimGetStepMapDerivative(
                c: fmi2Component,
                vu: *const u32,
                nu: usize,
                vk: *const u32,
                nk: usize,
                dvk: *const f64,
                dvu: *mut f64,
            ) -> fmi2Status {
                unsafe { e::get_step_map_derivative::<M>(c, vu, nu, vk, nk, dvk, dvu) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                order: *const i32,
                v: *const f64,
            ) -> fmi2Status {
                unsafe { e::set_real_input_derivatives::<M>(c, vr, n, order, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: fmi2Component,
                vr: *const u32,
                n: usize,
                order: *const i32,
                v: *mut f64,
            ) -> fmi2Status {
                unsafe { e::get_real_output_derivatives::<M>(c, vr, n, order, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2DoStep(c: fmi2Component, t: f64, h: f64, no_prior: fmi2Boolean) -> fmi2Status {
                unsafe { e::do_step::<M>(c, t, h, no_prior) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
                unsafe { e::cancel_step::<M>(c) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2Status,
            ) -> fmi2Status {
                unsafe { e::get_status::<M>(c, s, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, v: *mut f64) -> fmi2Status {
                unsafe { e::get_real_status::<M>(c, s, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut i32,
            ) -> fmi2Status {
                unsafe { e::get_integer_status::<M>(c, s, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut i32,
            ) -> fmi2Status {
                unsafe { e::get_boolean_status::<M>(c, s, v) }
            }
            #[unsafe(no_mangle)]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: fmi2Component,
                s: fmi2StatusKind,
                v: *mut fmi2String,
            ) -> fmi2Status {
                unsafe { e::get_string_status::<M>(c, s, v) }
            }
        };
    };
}

#[cfg(test)]
#[path = "export_tests.rs"]
mod tests;
