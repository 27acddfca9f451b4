//! Importing any FMI 2.0 or FMI 3.0 Co-Simulation FMU: unpack, read the description, load the
//! binary, and call it through one safe API. An FMI 3.0 FMU is seen through the scalar view of
//! [`Description3`](crate::fmi3::xml::Description3): each array element is a variable of its own
//! (`name[k]`), so that systems connect FMUs of both versions by the same names; the importer
//! gathers and scatters the elements of each call into whole arrays.
//!
//! ```no_run
//! # fn main() -> Result<(), fmi::import::Error> {
//! use fmi::import::Fmu;
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

mod api;
mod api3;
mod host;
mod instance;
mod log;
mod me;
mod v3;

/// The description types under the names an importer meets them by (`<ScalarVariable>`, the
/// FMU's description, its default experiment).
pub use crate::description::{
    CoSimulationFlags, DefaultExperiment as Experiment, ModelDescription as FmuDescription, Variable as ScalarVariable,
};
pub use crate::xml::parse_model_description;
pub use host::name_python_library;
pub use instance::{FmuState, Instance};
pub use log::LogMessage;
pub use me::EventUpdate;

use std::ffi::{CStr, CString, c_int};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::ffi::*;
use api::Api;
use api3::Api3;

/// The description at an FMU's root.
const MODEL_DESCRIPTION: &str = "modelDescription.xml";

/// The most an FMU may unpack to (its description, binary and resources): 4 GiB.
pub const MAX_UNPACKED_BYTES: u64 = 4 << 30;
pub(crate) use log::LogSink;

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
    /// An FMI 3.0 FMU asked to end the simulation (`terminateSimulation`) or returned early
    /// from `fmi3DoStep`, at `time`.
    Ended { fmu: String, instance: String, time: f64, terminated: bool },
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
                let status = if function.starts_with("fmi3") || function.starts_with("feedsim3") {
                    crate::fmi3::ffi::status_name(*status)
                } else {
                    Status::from_raw(*status).map_or_else(|| format!("invalid status {status}"), |s| s.name().into())
                };
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
            Error::Ended { fmu, instance, time, terminated } => {
                let why = if *terminated { "terminateSimulation" } else { "earlyReturn" };
                write!(f, "FMU `{fmu}` (instance `{instance}`): fmi3DoStep ended the simulation at t = {time} ({why})")
            }
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

/// The FMI interface an FMU is loaded as.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interface {
    CoSimulation,
    ModelExchange,
}

impl Interface {
    /// As the command line and the XML say it.
    pub fn name(self) -> &'static str {
        match self {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
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

/// A loaded FMU: description, binary and (for archives) the unpacked directory.
/// Field order matters: the library is unloaded before the directory is removed.
struct Loaded {
    api: Binary,
    interface: Interface,
    description: FmuDescription,
    /// FMI 3.0: where each scalar of the view lives, and the variables left out of it.
    v3: Option<View3>,
    root: PathBuf,
    _unpacked: Option<TempDir>,
}

/// The functions of the binary, by FMI version.
enum Binary {
    V2(Api),
    V3(Api3),
}

/// What the importer keeps of an FMI 3.0 description besides its scalar view.
struct View3 {
    elements: Vec<crate::fmi3::xml::Element>,
    skipped: Vec<(String, String)>,
}

/// A description as the importer reads it, once per load: the scalar view, and of an FMI 3.0
/// one what the importer keeps besides.
struct Described {
    view: crate::description::ModelDescription,
    v3: Option<View3>,
}

impl Described {
    /// Reads the text of a `modelDescription.xml` of FMI 2.0 or 3.0 (the version it declares).
    fn read(text: &str) -> Result<Described, crate::xml::ReadError> {
        let doc = crate::xml::read::parse_document(text)?;
        let major = doc.root_element().attribute("fmiVersion").and_then(|v| v.trim().split('.').next()?.parse().ok());
        if major == Some(3u32) {
            let d = crate::fmi3::xml::read_model_description3(&doc)?;
            Ok(Described { view: d.view, v3: Some(View3 { elements: d.elements, skipped: d.skipped }) })
        } else {
            Ok(Described { view: crate::xml::read::read_model_description(&doc)?, v3: None })
        }
    }

    /// The platform directory of the binaries for this FMI version.
    fn platform(&self) -> &'static str {
        if self.v3.is_some() { crate::fmi3::PLATFORM } else { crate::package::PLATFORM }
    }

    /// The interface to load: the one asked for, else Co-Simulation where the FMU offers it,
    /// else Model Exchange.
    fn interface(&self, asked: Option<Interface>) -> Result<Interface, String> {
        let (cs, me) = (self.view.co_simulation, self.view.model_exchange.is_some());
        match asked {
            Some(Interface::CoSimulation) if !cs => {
                Err("the FMU offers no Co-Simulation (no <CoSimulation> in modelDescription.xml)".into())
            }
            Some(Interface::ModelExchange) if !me => {
                Err("the FMU offers no Model Exchange (no <ModelExchange> in modelDescription.xml)".into())
            }
            Some(i) => Ok(i),
            None if cs => Ok(Interface::CoSimulation),
            None => Ok(Interface::ModelExchange),
        }
    }

    /// The binary the description names for `interface`: `binaries/<platform>/<identifier>.so`.
    fn binary_entry(&self, interface: Interface) -> String {
        let identifier = match (&self.view.model_exchange, interface) {
            (Some(me), Interface::ModelExchange) => &me.model_identifier,
            _ => &self.view.model_identifier,
        };
        format!("binaries/{}/{identifier}.so", self.platform())
    }
}

/// An FMI 2.0 or 3.0 Co-Simulation FMU, ready to instantiate (any number of times).
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
    /// and load it. Only what an importer uses is unpacked — `modelDescription.xml`, this
    /// platform's binary, `resources/` — at most [`MAX_UNPACKED_BYTES`] of it; documentation,
    /// sources and other platforms' binaries stay packed.
    pub fn load(archive: &Path) -> Result<Fmu, Error> {
        Self::load_as(archive, None)
    }

    /// [`Fmu::load`] as the interface asked for (`None`: Co-Simulation where the FMU offers it,
    /// else Model Exchange).
    pub fn load_as(archive: &Path, interface: Option<Interface>) -> Result<Fmu, Error> {
        let err = |message: String| Error::Load { path: archive.to_owned(), message };
        let file = std::fs::File::open(archive).map_err(|e| err(format!("cannot open: {e}")))?;
        let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
            .map_err(|e| err(format!("not a valid zip archive: {e}")))?;
        if zip.has_duplicate_names() {
            return Err(err("the archive lists an entry name twice: which one is meant is ambiguous".into()));
        }
        let stem = archive.file_stem().and_then(|s| s.to_str()).unwrap_or("fmu");
        let stem: String = stem.chars().filter(|c| c.is_ascii_alphanumeric() || *c == '_').take(32).collect();
        let dir = TempDir::new(&stem).map_err(|e| err(format!("cannot create a temporary directory: {e}")))?;
        let mut budget = MAX_UNPACKED_BYTES;
        let mut unpack = |zip: &mut zip::ZipArchive<_>, name: &str| {
            crate::archive::unpack_entry(zip, name, &dir.0, &mut budget, MAX_UNPACKED_BYTES)
                .map_err(|e| err(e.to_string()))
        };
        if zip.index_for_name(MODEL_DESCRIPTION).is_some() {
            unpack(&mut zip, MODEL_DESCRIPTION)?;
        }
        // the binary's name comes from the description (open() reports a missing or bad one)
        let described =
            std::fs::read_to_string(dir.0.join(MODEL_DESCRIPTION)).ok().and_then(|text| Described::read(&text).ok());
        let binary = described.as_ref().and_then(|d| Some(d.binary_entry(d.interface(interface).ok()?)));
        let needed: Vec<String> = zip
            .file_names()
            .filter_map(Result::ok)
            .filter(|n| Some(n.as_ref()) == binary.as_deref() || n.starts_with("resources/"))
            .map(|n| n.into_owned())
            .collect();
        for name in needed {
            unpack(&mut zip, &name)?;
        }
        let root = dir.0.clone();
        Self::open(&root, Some(dir), described, interface).map_err(|e| match e {
            Error::Load { message, .. } => err(message),
            other => other,
        })
    }

    /// Load an FMU that is already unpacked in `dir` (it must stay there while in use).
    pub fn load_unpacked(dir: &Path) -> Result<Fmu, Error> {
        Self::open(dir, None, None, None)
    }

    /// [`Fmu::load_unpacked`] as the interface asked for.
    pub fn load_unpacked_as(dir: &Path, interface: Option<Interface>) -> Result<Fmu, Error> {
        Self::open(dir, None, None, interface)
    }

    /// Loads the FMU in `root`, its description read there unless `described` holds it already.
    fn open(
        root: &Path,
        unpacked: Option<TempDir>,
        described: Option<Described>,
        asked: Option<Interface>,
    ) -> Result<Fmu, Error> {
        let md_path = root.join("modelDescription.xml");
        let err = |path: &Path, message: String| Error::Load { path: path.to_owned(), message };
        let described = match described {
            Some(d) => d,
            None => {
                let text = std::fs::read_to_string(&md_path).map_err(|e| {
                    let what =
                        if e.kind() == std::io::ErrorKind::NotFound { "missing".to_owned() } else { e.to_string() };
                    err(&md_path, format!("modelDescription.xml: {what}"))
                })?;
                Described::read(&text).map_err(|m| err(&md_path, format!("modelDescription.xml: {m}")))?
            }
        };
        let interface = described.interface(asked).map_err(|m| err(&md_path, m))?;
        let (platform, binary) = (described.platform(), root.join(described.binary_entry(interface)));
        let Described { view: description, v3 } = described;
        if !binary.is_file() {
            let platforms: Vec<String> = std::fs::read_dir(root.join("binaries"))
                .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name().to_string_lossy().into_owned()).collect())
                .unwrap_or_default();
            return Err(err(&binary, format!("missing: no {platform} binary (binaries/ holds: {platforms:?})")));
        }
        let text = |p: *const std::ffi::c_char| {
            // SAFETY: a string the FMU's version functions return: static and NUL-terminated, or
            // (if broken) null, which is checked.
            if p.is_null() { "(null)".to_owned() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
        };
        let mut description = description;
        if let (Interface::ModelExchange, Some(me)) = (interface, &description.model_exchange) {
            // the identity and capabilities an importer acts on are those of the interface in use
            (description.model_identifier, description.flags) = (me.model_identifier.clone(), me.flags());
        }
        let api = if v3.is_some() {
            // SAFETY: the binary named by an FMU's description is, by the FMI 3.0 contract an
            // importer accepts when it loads an FMU, code of that FMU with the standard's
            // functions; running its initializers and trusting its signatures is what loading
            // an FMU means.
            let api = unsafe { Api3::load(&binary, interface, b"feedsim3GetStepMapDerivative") }
                .map_err(|m| err(&binary, m))?;
            // SAFETY: a loaded function of the standard's type without arguments.
            let version = text(unsafe { (api.get_version)() });
            if !version.starts_with("3.") {
                return Err(err(&binary, format!("fmi3GetVersion returned `{version}`, expected 3.x")));
            }
            description.flags.provides_step_map_derivative &= api.step_map_derivative.is_some();
            Binary::V3(api)
        } else {
            // SAFETY: as above, under the FMI 2.0 contract.
            let api = unsafe { Api::load(&binary, interface, b"feedsimGetStepMapDerivative") }
                .map_err(|m| err(&binary, m))?;
            // SAFETY: loaded functions of the standard's types without arguments.
            let (version, platform) = unsafe { (text((api.get_version)()), text((api.get_types_platform)())) };
            if !version.starts_with("2.") {
                return Err(err(&binary, format!("fmi2GetVersion returned `{version}`, expected 2.0")));
            }
            if platform != "default" {
                return Err(err(&binary, format!("fmi2GetTypesPlatform returned `{platform}`, expected `default`")));
            }
            // The extension counts only where it is both announced and exported.
            description.flags.provides_step_map_derivative &= api.step_map_derivative.is_some();
            Binary::V2(api)
        };
        Ok(Fmu {
            inner: Arc::new(Loaded { api, interface, description, v3, root: root.to_owned(), _unpacked: unpacked }),
        })
    }

    /// The interface the FMU is loaded as.
    pub fn interface(&self) -> Interface {
        self.inner.interface
    }

    /// The FMI version's major number: 2 or 3.
    pub fn fmi_major_version(&self) -> u32 {
        if self.inner.v3.is_some() { 3 } else { 2 }
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
        self.inner.description.variable(name).ok_or_else(|| {
            let skipped = self.inner.v3.as_ref().and_then(|v| v.skipped.iter().find(|(n, _)| n == name));
            Error::Usage(match skipped {
                Some((_, why)) => format!("FMU `{}`: variable `{name}` is not exchanged ({why})", self.name()),
                None => format!("FMU `{}` has no variable named `{name}`", self.name()),
            })
        })
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

    /// A new instance (`fmi2Instantiate`, `fmi3InstantiateCoSimulation` or
    /// `fmi3InstantiateModelExchange` as the interface loaded; resources from the unpacked
    /// directory; FMI 3.0 Co-Simulation without event mode and without early return).
    pub fn instantiate(&self, instance_name: &str, logging_on: bool) -> Result<Instance, Error> {
        let d = &self.inner.description;
        let fail = |m: String| Error::Usage(format!("FMU `{}`: {m}", d.model_identifier));
        let name = CString::new(instance_name).map_err(|_| fail("instance name contains a NUL byte".into()))?;
        let guid = CString::new(d.guid.as_str()).map_err(|_| fail("GUID contains a NUL byte".into()))?;
        let resources = self.inner.root.join("resources");
        let sink = LogSink::new();
        let me = self.inner.interface == Interface::ModelExchange;
        let (component, callbacks, function) = match &self.inner.api {
            Binary::V2(api) => {
                let uri = crate::uri::file_uri(&resources);
                let location = CString::new(uri).map_err(|_| fail("path contains NUL".into()))?;
                let callbacks = Box::new(sink.callbacks());
                // SAFETY: a loaded function (`self` keeps the binary); the strings are
                // NUL-terminated and live for the call; `callbacks` and the sink it points to are
                // boxed and moved into the instance, so they stay where they are until it is freed.
                let component = unsafe {
                    (api.instantiate)(
                        name.as_ptr(),
                        if me { fmi2ModelExchange } else { fmi2CoSimulation },
                        guid.as_ptr(),
                        location.as_ptr(),
                        &*callbacks,
                        fmi2False,
                        c_int::from(logging_on),
                    )
                };
                (component, Some(callbacks), "fmi2Instantiate")
            }
            Binary::V3(api) if me => {
                let path = format!("{}/", resources.display());
                let location = CString::new(path).map_err(|_| fail("path contains NUL".into()))?;
                let (env, logger) = sink.fmi3_logger();
                let instantiate = api.me.as_ref().expect("loaded as Model Exchange").instantiate;
                // SAFETY: a loaded function (`self` keeps the binary); the strings are
                // NUL-terminated and live for the call; the sink (`env`) is boxed and moved into
                // the instance, so it stays where it is until the instance is freed.
                let component = unsafe {
                    instantiate(name.as_ptr(), guid.as_ptr(), location.as_ptr(), 0, u8::from(logging_on), env, logger)
                };
                (component, None, "fmi3InstantiateModelExchange")
            }
            Binary::V3(api) => {
                // FMI 3.0: a native path ending with a separator
                let path = format!("{}/", resources.display());
                let location = CString::new(path).map_err(|_| fail("path contains NUL".into()))?;
                let (env, logger) = sink.fmi3_logger();
                let instantiate = api.cs.as_ref().expect("loaded as Co-Simulation").instantiate;
                // SAFETY: a loaded function (`self` keeps the binary); the strings are
                // NUL-terminated and live for the call; the sink (`env`) is boxed and moved into
                // the instance, so it stays where it is until the instance is freed.
                let component = unsafe {
                    instantiate(
                        name.as_ptr(),
                        guid.as_ptr(),
                        location.as_ptr(),
                        0,
                        u8::from(logging_on),
                        0,
                        0,
                        std::ptr::null(),
                        0,
                        env,
                        logger,
                        None,
                    )
                };
                (component, None, "fmi3InstantiateCoSimulation")
            }
        };
        if component.is_null() {
            return Err(Error::Call {
                fmu: d.model_identifier.clone(),
                instance: instance_name.to_owned(),
                function,
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
            v3: self.inner.v3.as_ref().map(|_| Box::default()),
        })
    }
}
