//! Importing any FMI 2.0 Co-Simulation FMU: unpack, read the description, load the binary,
//! and call it through a safe API.
//!
//! ```no_run
//! # fn main() -> Result<(), fmi2::import::Error> {
//! use fmi2::import::Fmu;
//! let fmu = Fmu::load("dist/oscillator.fmu".as_ref())?;
//! let (force, x) = (fmu.value_reference("F")?, fmu.value_reference("x")?);
//! let mut inst = fmu.instantiate("osc", false)?;
//! inst.setup_experiment(None, 0.0, None)?;
//! inst.enter_initialization_mode()?;
//! inst.exit_initialization_mode()?;
//! inst.set_real(&[force], &[1.0])?;
//! inst.do_step(0.0, 0.01)?;
//! let mut out = [0.0];
//! inst.get_real(&[x], &mut out)?;
//! # Ok(()) }
//! ```
//!
//! The logger: FMUs call it printf-style with variadic arguments. Stable Rust cannot define a
//! variadic function, so a ten-line C shim (`csrc/logger.c`) formats the message with the C
//! library's `vsnprintf` and passes the text to Rust. This formats every FMU's messages
//! correctly (including `%s`/`%g` arguments) on any platform, unlike reading only the fixed
//! arguments through a non-variadic function pointer.

mod parse;

pub use parse::{CoSimulationFlags, Experiment, FmuDescription, ScalarVariable, parse_model_description};

use std::collections::VecDeque;
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use libloading::Library;

use crate::description::{Causality, VarType};
use crate::ffi::*;

/// Everything that can go wrong, with enough context to act on it.
#[derive(Clone, Debug, PartialEq)]
pub enum Error {
    /// The archive, its description or its binary: which file and what is wrong.
    Load { path: PathBuf, message: String },
    /// An FMI function returned something other than `fmi2OK`/`fmi2Warning`.
    Call { fmu: String, instance: String, function: &'static str, status: fmi2Status, messages: Vec<String> },
    /// The FMU lacks a capability the caller needs.
    Capability { fmu: String, capability: Capability },
    /// Misuse of this API (unknown variable name, slices of different lengths, ...).
    Usage(String),
}

impl Error {
    /// The status of a failed call (`None` for other errors).
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Call { status, .. } => Status::from_raw(*status),
            _ => None,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Load { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Call { fmu, instance, function, status, messages } => {
                let status =
                    Status::from_raw(*status).map_or_else(|| format!("invalid status {status}"), |s| s.name().into());
                write!(f, "FMU `{fmu}` (instance `{instance}`): {function} returned {status}")?;
                if messages.is_empty() {
                    write!(f, " (the FMU logged nothing)")
                } else {
                    write!(f, "; FMU log: {}", messages.join(" | "))
                }
            }
            Error::Capability { fmu, capability } => {
                write!(f, "FMU `{fmu}` does not declare {} in modelDescription.xml", capability.attribute())
            }
            Error::Usage(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

/// Optional Co-Simulation capabilities, checked with [`Fmu::require`] before use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Capability {
    VariableStepSize,
    InterpolateInputs,
    GetSetState,
    SerializeState,
    DirectionalDerivative,
    OutputDerivatives,
    /// This workspace's extension `feedsimGetStepMapDerivative`.
    StepMapDerivative,
}

impl Capability {
    /// The XML attribute that declares it.
    pub fn attribute(self) -> &'static str {
        match self {
            Capability::VariableStepSize => "canHandleVariableCommunicationStepSize=\"true\"",
            Capability::InterpolateInputs => "canInterpolateInputs=\"true\"",
            Capability::GetSetState => "canGetAndSetFMUstate=\"true\"",
            Capability::SerializeState => "canSerializeFMUstate=\"true\"",
            Capability::DirectionalDerivative => "providesDirectionalDerivative=\"true\"",
            Capability::OutputDerivatives => "maxOutputDerivativeOrder ≥ 1",
            Capability::StepMapDerivative => {
                "<VendorAnnotations><Tool name=\"feedsim\"><StepMapDerivative/> (and the symbol feedsimGetStepMapDerivative)"
            }
        }
    }
}

/// A directory removed (recursively) on drop.
#[derive(Debug)]
struct TempDir(PathBuf);

impl TempDir {
    fn new(stem: &str) -> std::io::Result<TempDir> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let nanos =
                std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
            let dir = base.join(format!("fmi2rs-{stem}-{}-{n}-{nanos}", std::process::id()));
            match std::fs::create_dir(&dir) {
                Ok(()) => return Ok(TempDir(dir)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

macro_rules! api_table {
    ($($field:ident: $ty:ty = $sym:literal,)*) => {
        /// The resolved functions. Declared after nothing that outlives it: `lib` keeps them valid.
        struct Api {
            $($field: $ty,)*
            /// This workspace's extension, if the binary exports it.
            step_map_derivative: Option<fmi2GetDirectionalDerivativeTYPE>,
            _lib: Library,
        }

        impl Api {
            /// # Safety
            /// Loading a library runs its initializers; it must be an FMU binary.
            unsafe fn load(path: &Path) -> Result<Api, String> {
                let lib = unsafe { Library::new(path) }.map_err(|e| format!("cannot load the binary: {e}"))?;
                $(let $field = *unsafe { lib.get::<$ty>($sym) }
                    .map_err(|e| format!("the binary does not export `{}`: {e}", $sym))?;)*
                // SAFETY: the symbol, if present, has the signature of fmi2GetDirectionalDerivative
                // (the extension's definition); `lib` is kept with the pointer.
                let step_map_derivative =
                    unsafe { lib.get::<fmi2GetDirectionalDerivativeTYPE>(b"feedsimGetStepMapDerivative") }.ok().map(|f| *f);
                Ok(Api { $($field,)* step_map_derivative, _lib: lib })
            }
        }
    };
}

api_table! {
    get_types_platform: fmi2GetTypesPlatformTYPE = "fmi2GetTypesPlatform",
    get_version: fmi2GetVersionTYPE = "fmi2GetVersion",
    set_debug_logging: fmi2SetDebugLoggingTYPE = "fmi2SetDebugLogging",
    instantiate: fmi2InstantiateTYPE = "fmi2Instantiate",
    free_instance: fmi2FreeInstanceTYPE = "fmi2FreeInstance",
    setup_experiment: fmi2SetupExperimentTYPE = "fmi2SetupExperiment",
    enter_initialization_mode: fmi2ComponentOnlyTYPE = "fmi2EnterInitializationMode",
    exit_initialization_mode: fmi2ComponentOnlyTYPE = "fmi2ExitInitializationMode",
    terminate: fmi2ComponentOnlyTYPE = "fmi2Terminate",
    reset: fmi2ComponentOnlyTYPE = "fmi2Reset",
    get_real: fmi2GetRealTYPE = "fmi2GetReal",
    get_integer: fmi2GetIntegerTYPE = "fmi2GetInteger",
    get_boolean: fmi2GetBooleanTYPE = "fmi2GetBoolean",
    get_string: fmi2GetStringTYPE = "fmi2GetString",
    set_real: fmi2SetRealTYPE = "fmi2SetReal",
    set_integer: fmi2SetIntegerTYPE = "fmi2SetInteger",
    set_boolean: fmi2SetBooleanTYPE = "fmi2SetBoolean",
    set_string: fmi2SetStringTYPE = "fmi2SetString",
    get_fmu_state: fmi2GetFMUstateTYPE = "fmi2GetFMUstate",
    set_fmu_state: fmi2SetFMUstateTYPE = "fmi2SetFMUstate",
    free_fmu_state: fmi2FreeFMUstateTYPE = "fmi2FreeFMUstate",
    serialized_fmu_state_size: fmi2SerializedFMUstateSizeTYPE = "fmi2SerializedFMUstateSize",
    serialize_fmu_state: fmi2SerializeFMUstateTYPE = "fmi2SerializeFMUstate",
    deserialize_fmu_state: fmi2DeSerializeFMUstateTYPE = "fmi2DeSerializeFMUstate",
    get_directional_derivative: fmi2GetDirectionalDerivativeTYPE = "fmi2GetDirectionalDerivative",
    set_real_input_derivatives: fmi2SetRealInputDerivativesTYPE = "fmi2SetRealInputDerivatives",
    get_real_output_derivatives: fmi2GetRealOutputDerivativesTYPE = "fmi2GetRealOutputDerivatives",
    do_step: fmi2DoStepTYPE = "fmi2DoStep",
    cancel_step: fmi2ComponentOnlyTYPE = "fmi2CancelStep",
    get_status: fmi2GetStatusTYPE = "fmi2GetStatus",
    get_real_status: fmi2GetRealStatusTYPE = "fmi2GetRealStatus",
    get_integer_status: fmi2GetIntegerStatusTYPE = "fmi2GetIntegerStatus",
    get_boolean_status: fmi2GetBooleanStatusTYPE = "fmi2GetBooleanStatus",
    get_string_status: fmi2GetStringStatusTYPE = "fmi2GetStringStatus",
}

/// A loaded FMU: description, binary and (for archives) the unpacked directory.
/// Field order matters: the library is unloaded before the directory is removed.
struct Loaded {
    api: Api,
    description: FmuDescription,
    root: PathBuf,
    _unpacked: Option<TempDir>,
}

/// An FMI 2.0 Co-Simulation FMU, ready to instantiate (any number of times).
#[derive(Clone)]
pub struct Fmu {
    inner: Arc<Loaded>,
}

impl fmt::Debug for Fmu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Fmu({} at {})", self.inner.description.model_identifier, self.inner.root.display())
    }
}

impl Fmu {
    /// Unpack an `.fmu` archive to a temporary directory (removed when the last handle is dropped)
    /// and load it.
    pub fn load(archive: &Path) -> Result<Fmu, Error> {
        let err = |message: String| Error::Load { path: archive.to_owned(), message };
        let file = std::fs::File::open(archive).map_err(|e| err(format!("cannot open: {e}")))?;
        let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
            .map_err(|e| err(format!("not a valid zip archive: {e}")))?;
        let stem = archive.file_stem().and_then(|s| s.to_str()).unwrap_or("fmu");
        let stem: String = stem.chars().filter(|c| c.is_ascii_alphanumeric() || *c == '_').take(32).collect();
        let dir = TempDir::new(&stem).map_err(|e| err(format!("cannot create a temporary directory: {e}")))?;
        zip.extract(&dir.0).map_err(|e| err(format!("cannot unpack into {}: {e}", dir.0.display())))?;
        let root = dir.0.clone();
        Self::open(&root, Some(dir)).map_err(|e| match e {
            Error::Load { message, .. } => err(message),
            other => other,
        })
    }

    /// Load an FMU that is already unpacked in `dir` (it must stay there while in use).
    pub fn load_unpacked(dir: &Path) -> Result<Fmu, Error> {
        Self::open(dir, None)
    }

    fn open(root: &Path, unpacked: Option<TempDir>) -> Result<Fmu, Error> {
        let md_path = root.join("modelDescription.xml");
        let err = |path: &Path, message: String| Error::Load { path: path.to_owned(), message };
        let text = std::fs::read_to_string(&md_path).map_err(|e| {
            let what = if e.kind() == std::io::ErrorKind::NotFound { "missing".to_owned() } else { e.to_string() };
            err(&md_path, format!("modelDescription.xml: {what}"))
        })?;
        let description =
            parse_model_description(&text).map_err(|m| err(&md_path, format!("modelDescription.xml: {m}")))?;
        let binary =
            root.join("binaries").join(crate::package::PLATFORM).join(format!("{}.so", description.model_identifier));
        if !binary.is_file() {
            let platforms: Vec<String> = std::fs::read_dir(root.join("binaries"))
                .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
                .unwrap_or_default();
            return Err(err(
                &binary,
                format!("missing: no {} binary (binaries/ holds: {:?})", crate::package::PLATFORM, platforms),
            ));
        }
        // SAFETY: loading a library runs its constructors; an FMU binary is trusted code by definition.
        let api = unsafe { Api::load(&binary) }.map_err(|m| err(&binary, m))?;
        let version = unsafe { CStr::from_ptr((api.get_version)()) }.to_string_lossy().into_owned();
        if !version.starts_with("2.") {
            return Err(err(&binary, format!("fmi2GetVersion returned `{version}`, expected 2.0")));
        }
        let platform = unsafe { CStr::from_ptr((api.get_types_platform)()) }.to_string_lossy().into_owned();
        if platform != "default" {
            return Err(err(&binary, format!("fmi2GetTypesPlatform returned `{platform}`, expected `default`")));
        }
        let mut description = description;
        // The extension counts only where it is both announced and exported.
        description.flags.provides_step_map_derivative &= api.step_map_derivative.is_some();
        Ok(Fmu { inner: Arc::new(Loaded { api, description, root: root.to_owned(), _unpacked: unpacked }) })
    }

    pub fn description(&self) -> &FmuDescription {
        &self.inner.description
    }

    /// The unpacked FMU directory (with `modelDescription.xml`, `resources/`, ...).
    pub fn root(&self) -> &Path {
        &self.inner.root
    }

    pub fn name(&self) -> &str {
        &self.inner.description.model_identifier
    }

    /// The variable with this name.
    pub fn variable(&self, name: &str) -> Result<&ScalarVariable, Error> {
        self.inner
            .description
            .variable(name)
            .ok_or_else(|| Error::Usage(format!("FMU `{}` has no variable named `{name}`", self.name())))
    }

    /// The value reference of a variable.
    pub fn value_reference(&self, name: &str) -> Result<u32, Error> {
        Ok(self.variable(name)?.value_reference)
    }

    /// Error unless the FMU declares `capability`.
    pub fn require(&self, capability: Capability) -> Result<(), Error> {
        let f = &self.inner.description.flags;
        let has = match capability {
            Capability::VariableStepSize => f.can_handle_variable_communication_step_size,
            Capability::InterpolateInputs => f.can_interpolate_inputs,
            Capability::GetSetState => f.can_get_and_set_fmu_state,
            Capability::SerializeState => f.can_serialize_fmu_state,
            Capability::DirectionalDerivative => f.provides_directional_derivative,
            Capability::OutputDerivatives => f.max_output_derivative_order >= 1,
            Capability::StepMapDerivative => f.provides_step_map_derivative,
        };
        if has { Ok(()) } else { Err(Error::Capability { fmu: self.name().to_owned(), capability }) }
    }

    /// A new instance (`fmi2Instantiate` for Co-Simulation, resources from the unpacked directory).
    pub fn instantiate(&self, instance_name: &str, logging_on: bool) -> Result<Instance, Error> {
        let d = &self.inner.description;
        let fail = |m: String| Error::Usage(format!("FMU `{}`: {m}", d.model_identifier));
        let name = CString::new(instance_name).map_err(|_| fail("instance name contains a NUL byte".into()))?;
        let guid = CString::new(d.guid.as_str()).map_err(|_| fail("GUID contains a NUL byte".into()))?;
        let resources = self.inner.root.join("resources");
        let location = CString::new(crate::uri::file_uri(&resources)).map_err(|_| fail("path contains NUL".into()))?;
        let sink = LogSink::new();
        let callbacks = Box::new(sink.callbacks());
        // SAFETY: all pointers are valid for the call; `callbacks` and `sink` outlive the instance.
        let component = unsafe {
            (self.inner.api.instantiate)(
                name.as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                location.as_ptr(),
                &*callbacks,
                fmi2False,
                c_int::from(logging_on),
            )
        };
        if component.is_null() {
            return Err(Error::Call {
                fmu: d.model_identifier.clone(),
                instance: instance_name.to_owned(),
                function: "fmi2Instantiate",
                status: fmi2Error,
                messages: sink.recent(),
            });
        }
        Ok(Instance {
            fmu: self.clone(),
            component,
            name: instance_name.to_owned(),
            sink,
            _callbacks: callbacks,
            states: Vec::new(),
        })
    }
}

unsafe extern "C" {
    /// The C shim in `csrc/logger.c`.
    fn fmi2rs_logger(
        env: *mut c_void,
        instance: fmi2String,
        status: fmi2Status,
        category: fmi2String,
        message: fmi2String,
        ...
    );
    fn calloc(n: usize, size: usize) -> *mut c_void;
    fn free(p: *mut c_void);
}

/// One message an FMU logged.
#[derive(Clone, Debug, PartialEq)]
pub struct LogMessage {
    pub status: fmi2Status,
    pub category: String,
    pub text: String,
}

/// How many messages an instance keeps (the oldest are dropped).
const LOG_CAPACITY: usize = 256;

/// `componentEnvironment`: the C shim calls `sink` (the first field) with the formatted text.
#[repr(C)]
pub(crate) struct LogSink {
    sink: unsafe extern "C" fn(*mut c_void, fmi2String, fmi2Status, fmi2String, fmi2String),
    messages: Mutex<VecDeque<LogMessage>>,
    echo: bool,
}

impl LogSink {
    pub(crate) fn new() -> Box<LogSink> {
        Box::new(LogSink {
            sink: log_sink,
            messages: Mutex::new(VecDeque::new()),
            echo: std::env::var_os("FMI2_ECHO_LOG").is_some(),
        })
    }

    /// The callbacks an FMU gets: this sink as componentEnvironment, libc's allocator.
    /// The sink must outlive every instance that uses them.
    pub(crate) fn callbacks(&self) -> fmi2CallbackFunctions {
        fmi2CallbackFunctions {
            logger: Some(fmi2rs_logger),
            allocateMemory: Some(calloc),
            freeMemory: Some(free),
            stepFinished: None,
            componentEnvironment: (self as *const LogSink).cast_mut().cast(),
        }
    }

    /// Take all messages logged so far.
    pub(crate) fn take(&self) -> Vec<LogMessage> {
        self.messages.lock().unwrap_or_else(|p| p.into_inner()).drain(..).collect()
    }

    /// The last few messages, newest last, for error reports.
    fn recent(&self) -> Vec<String> {
        let m = self.messages.lock().unwrap_or_else(|p| p.into_inner());
        m.iter().rev().take(5).rev().map(|x| format!("[{}] {}", x.category, x.text)).collect()
    }
}

unsafe extern "C" fn log_sink(
    env: *mut c_void,
    instance: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    message: fmi2String,
) {
    let text = |p: *const c_char| {
        if p.is_null() { String::new() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
    };
    // Never unwind into the FMU.
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `env` is the `LogSink` this importer passed as componentEnvironment.
        let sink = unsafe { &*env.cast::<LogSink>() };
        let msg = LogMessage { status, category: text(category), text: text(message) };
        if sink.echo {
            eprintln!("[{}] {} {}: {}", text(instance), msg.status, msg.category, msg.text);
        }
        let mut m = sink.messages.lock().unwrap_or_else(|p| p.into_inner());
        if m.len() == LOG_CAPACITY {
            m.pop_front();
        }
        m.push_back(msg);
    });
}

/// A saved FMU state, owned by the instance that made it (freed with it).
#[derive(Debug, PartialEq, Eq)]
pub struct FmuState {
    id: u64,
}

/// One FMU instance. Freed (`fmi2FreeInstance`) on drop. `Send`: an instance may move between
/// threads, but it is not shared (`&mut self` for every call).
pub struct Instance {
    fmu: Fmu,
    component: fmi2Component,
    name: String,
    sink: Box<LogSink>,
    _callbacks: Box<fmi2CallbackFunctions>,
    states: Vec<(u64, fmi2FMUstate)>,
}

// SAFETY: FMI 2.0 instances carry no thread affinity; `Instance` is used by one thread at a time.
unsafe impl Send for Instance {}

impl fmt::Debug for Instance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Instance({} of {})", self.name, self.fmu.name())
    }
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

    fn api(&self) -> &Api {
        &self.fmu.inner.api
    }

    fn check(&self, function: &'static str, status: fmi2Status) -> Result<(), Error> {
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
        let s = unsafe { (self.api().set_debug_logging)(self.component, c_int::from(on), ptrs.len(), ptrs.as_ptr()) };
        self.check("fmi2SetDebugLogging", s)
    }

    pub fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Result<(), Error> {
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
        let s = unsafe { (self.api().enter_initialization_mode)(self.component) };
        self.check("fmi2EnterInitializationMode", s)
    }

    pub fn exit_initialization_mode(&mut self) -> Result<(), Error> {
        let s = unsafe { (self.api().exit_initialization_mode)(self.component) };
        self.check("fmi2ExitInitializationMode", s)
    }

    pub fn terminate(&mut self) -> Result<(), Error> {
        let s = unsafe { (self.api().terminate)(self.component) };
        self.check("fmi2Terminate", s)
    }

    pub fn reset(&mut self) -> Result<(), Error> {
        let s = unsafe { (self.api().reset)(self.component) };
        self.check("fmi2Reset", s)
    }

    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), Error> {
        same_len("get_real", vrs.len(), out.len())?;
        let s = unsafe { (self.api().get_real)(self.component, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        self.check("fmi2GetReal", s)
    }

    pub fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Result<(), Error> {
        same_len("get_integer", vrs.len(), out.len())?;
        let s = unsafe { (self.api().get_integer)(self.component, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        self.check("fmi2GetInteger", s)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [bool]) -> Result<(), Error> {
        same_len("get_boolean", vrs.len(), out.len())?;
        let mut raw = vec![0 as fmi2Boolean; vrs.len()];
        let s = unsafe { (self.api().get_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr()) };
        self.check("fmi2GetBoolean", s)?;
        for (o, r) in out.iter_mut().zip(raw) {
            *o = r != fmi2False;
        }
        Ok(())
    }

    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>, Error> {
        let mut raw = vec![std::ptr::null::<c_char>(); vrs.len()];
        let s = unsafe { (self.api().get_string)(self.component, vrs.as_ptr(), vrs.len(), raw.as_mut_ptr()) };
        self.check("fmi2GetString", s)?;
        // Copy at once: the FMU's strings are valid only until its next call.
        Ok(raw
            .into_iter()
            .map(
                |p| {
                    if p.is_null() {
                        String::new()
                    } else {
                        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
                    }
                },
            )
            .collect())
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), Error> {
        same_len("set_real", vrs.len(), values.len())?;
        let s = unsafe { (self.api().set_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetReal", s)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), Error> {
        same_len("set_integer", vrs.len(), values.len())?;
        let s = unsafe { (self.api().set_integer)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetInteger", s)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), Error> {
        same_len("set_boolean", vrs.len(), values.len())?;
        let raw: Vec<fmi2Boolean> = values.iter().map(|&b| c_int::from(b)).collect();
        let s = unsafe { (self.api().set_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw.as_ptr()) };
        self.check("fmi2SetBoolean", s)
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), Error> {
        same_len("set_string", vrs.len(), values.len())?;
        let owned: Vec<CString> = values
            .iter()
            .map(|v| CString::new(*v).map_err(|_| Error::Usage(format!("string `{v}` contains a NUL byte"))))
            .collect::<Result<_, _>>()?;
        let ptrs: Vec<fmi2String> = owned.iter().map(|c| c.as_ptr()).collect();
        let s = unsafe { (self.api().set_string)(self.component, vrs.as_ptr(), vrs.len(), ptrs.as_ptr()) };
        self.check("fmi2SetString", s)
    }

    /// `fmi2DoStep(t, h, noSetFMUStatePriorToCurrentPoint = false)`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Error> {
        let s = unsafe { (self.api().do_step)(self.component, t, h, fmi2False) };
        self.check("fmi2DoStep", s)
    }

    /// `fmi2CancelStep` (only meaningful for asynchronous FMUs).
    pub fn cancel_step(&mut self) -> Result<(), Error> {
        let s = unsafe { (self.api().cancel_step)(self.component) };
        self.check("fmi2CancelStep", s)
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn last_successful_time(&mut self) -> Result<f64, Error> {
        let mut t = f64::NAN;
        let s = unsafe { (self.api().get_real_status)(self.component, fmi2LastSuccessfulTime, &mut t) };
        self.check("fmi2GetRealStatus", s)?;
        Ok(t)
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`.
    pub fn terminated(&mut self) -> Result<bool, Error> {
        let mut b = fmi2False;
        let s = unsafe { (self.api().get_boolean_status)(self.component, fmi2Terminated, &mut b) };
        self.check("fmi2GetBooleanStatus", s)?;
        Ok(b != fmi2False)
    }

    /// `fmi2GetStatus`, `fmi2GetIntegerStatus`, `fmi2GetStringStatus` for a status kind (raw
    /// status values; mostly for asynchronous FMUs).
    pub fn status_kinds(&mut self, kind: fmi2StatusKind) -> (fmi2Status, fmi2Status, fmi2Status) {
        let (mut a, mut b, mut c) = (0, 0, std::ptr::null());
        unsafe {
            (
                (self.api().get_status)(self.component, kind, &mut a),
                (self.api().get_integer_status)(self.component, kind, &mut b),
                (self.api().get_string_status)(self.component, kind, &mut c),
            )
        }
    }

    /// Save the current state (`fmi2GetFMUstate`). Requires [`Capability::GetSetState`].
    pub fn get_state(&mut self) -> Result<FmuState, Error> {
        self.fmu.require(Capability::GetSetState)?;
        let mut raw: fmi2FMUstate = std::ptr::null_mut();
        let s = unsafe { (self.api().get_fmu_state)(self.component, &mut raw) };
        self.check("fmi2GetFMUstate", s)?;
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
        let s = unsafe { (self.api().get_fmu_state)(self.component, &mut raw) };
        self.states[i].1 = raw;
        self.check("fmi2GetFMUstate", s)
    }

    /// Restore a saved state (`fmi2SetFMUstate`).
    pub fn set_state(&mut self, state: &FmuState) -> Result<(), Error> {
        let (_, raw) = self.raw_state(state)?;
        let s = unsafe { (self.api().set_fmu_state)(self.component, raw) };
        self.check("fmi2SetFMUstate", s)
    }

    /// Free a saved state now (otherwise it is freed with the instance).
    pub fn free_state(&mut self, state: FmuState) -> Result<(), Error> {
        let (i, mut raw) = self.raw_state(&state)?;
        self.states.swap_remove(i);
        let s = unsafe { (self.api().free_fmu_state)(self.component, &mut raw) };
        self.check("fmi2FreeFMUstate", s)
    }

    /// Serialize a saved state to bytes. Requires [`Capability::SerializeState`].
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>, Error> {
        self.fmu.require(Capability::SerializeState)?;
        let (_, raw) = self.raw_state(state)?;
        let mut size = 0usize;
        let s = unsafe { (self.api().serialized_fmu_state_size)(self.component, raw, &mut size) };
        self.check("fmi2SerializedFMUstateSize", s)?;
        let mut bytes = vec![0u8; size];
        let s = unsafe { (self.api().serialize_fmu_state)(self.component, raw, bytes.as_mut_ptr().cast(), size) };
        self.check("fmi2SerializeFMUstate", s)?;
        Ok(bytes)
    }

    /// A saved state from bytes made by [`Instance::serialize_state`] (of an instance of the same FMU).
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState, Error> {
        self.fmu.require(Capability::SerializeState)?;
        let mut raw: fmi2FMUstate = std::ptr::null_mut();
        let s =
            unsafe { (self.api().deserialize_fmu_state)(self.component, bytes.as_ptr().cast(), bytes.len(), &mut raw) };
        self.check("fmi2DeSerializeFMUstate", s)?;
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
        same_len("directional_derivative (knowns)", knowns.len(), seed.len())?;
        same_len("directional_derivative (unknowns)", unknowns.len(), out.len())?;
        let s = unsafe {
            (self.api().get_directional_derivative)(
                self.component,
                unknowns.as_ptr(),
                unknowns.len(),
                knowns.as_ptr(),
                knowns.len(),
                seed.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        self.check("fmi2GetDirectionalDerivative", s)
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
        same_len("step_map_derivative (knowns)", knowns.len(), seed.len())?;
        same_len("step_map_derivative (unknowns)", unknowns.len(), out.len())?;
        let f = self.api().step_map_derivative.ok_or_else(|| Error::Capability {
            fmu: self.fmu.name().to_owned(),
            capability: Capability::StepMapDerivative,
        })?;
        // SAFETY: a live component; every array holds the length passed with it (checked above).
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
        self.check("feedsimGetStepMapDerivative", s)
    }

    /// Input derivatives of the given orders at the current communication point.
    /// Requires [`Capability::InterpolateInputs`].
    pub fn set_real_input_derivatives(&mut self, vrs: &[u32], orders: &[i32], values: &[f64]) -> Result<(), Error> {
        self.fmu.require(Capability::InterpolateInputs)?;
        same_len("set_real_input_derivatives", vrs.len(), values.len())?;
        same_len("set_real_input_derivatives (orders)", vrs.len(), orders.len())?;
        let s = unsafe {
            (self.api().set_real_input_derivatives)(
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
        same_len("get_real_output_derivatives", vrs.len(), out.len())?;
        same_len("get_real_output_derivatives (orders)", vrs.len(), orders.len())?;
        let s = unsafe {
            (self.api().get_real_output_derivatives)(
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
        unsafe {
            for (_, mut raw) in std::mem::take(&mut self.states) {
                (self.api().free_fmu_state)(self.component, &mut raw);
            }
            (self.api().free_instance)(self.component);
        }
    }
}
