//! `feedsim._feedsim`: the library crates behind the Python package `feedsim`. Each function
//! takes a scene (a file, or the TOML text of a dict) and the command line's options as
//! arguments, runs what the `master` command runs, releases the GIL while it computes, and
//! returns what the command's `--json` and `--out` hold (JSON text, CSV text); `feedsim/__init__.py`
//! turns them into dicts, numpy arrays and data frames.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use feedcore::scene::{MAX_SCENE_BYTES, Scene, SceneError as InvalidScene, ValidScene};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use studies::limits::{Footprint, Limits, check_memory};
use studies::options::{
    self as opt, Compensation, Named, SchemeName, SchemeOptions, SystemFiles, UNPACKED_MB, check_dt, positive,
};
use studies::report::{Modal, Statics, run_summary, static_utilisation};
use studies::simulate::{Method, Run};
use studies::stepping::{Unwatched, Watch};
use studies::sweep;
use studies::system::SystemFile;

create_exception!(feedsim, SceneError, PyValueError, "A scene that cannot be read or is not valid.");
create_exception!(feedsim, RunError, PyRuntimeError, "A run that cannot start or stopped.");

/// Where a scene comes from: a file, or TOML text named by a label in errors.
enum Source {
    File(PathBuf),
    Text { toml: String, label: String },
}

impl Source {
    fn new(path: Option<String>, toml: Option<String>, label: String) -> PyResult<Source> {
        match (path, toml) {
            (Some(p), None) => Ok(Source::File(PathBuf::from(p))),
            (None, Some(toml)) => Ok(Source::Text { toml, label }),
            _ => Err(PyValueError::new_err("give the scene as a path or as the TOML text of a dict, not both")),
        }
    }

    fn load(&self) -> Result<ValidScene, InvalidScene> {
        match self {
            Source::File(p) => Scene::load_limited(p, MAX_SCENE_BYTES),
            Source::Text { toml, label } => Scene::from_toml(toml, label),
        }
    }

    /// What relative paths in the scene (its `[system]` FMUs) resolve against: the scene file,
    /// or for a dict a file of that label in the working folder.
    fn file(&self) -> PathBuf {
        match self {
            Source::File(p) => p.clone(),
            Source::Text { label, .. } => PathBuf::from(label),
        }
    }
}

fn scene_error(e: InvalidScene) -> PyErr {
    SceneError::new_err(e.to_string())
}

/// An error with its whole chain of causes, as the command line prints it: a cause the text
/// already ends with (an error that quotes its cause) is not repeated.
fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let cause = s.to_string();
        if !text.ends_with(&cause) {
            text += &format!(": {cause}");
        }
        source = s.source();
    }
    text
}

fn run_error(e: &(dyn std::error::Error + 'static)) -> PyErr {
    RunError::new_err(chain(e))
}

/// Keyword options, taken one by one by their command-line names (`_` for `-`): each value is
/// read as the text a user would type and checked by the library's check of that option, so
/// that a value refused here is refused by the command line with the same reason.
struct Kwargs<'py> {
    dict: Bound<'py, PyDict>,
}

impl<'py> Kwargs<'py> {
    fn new(dict: Bound<'py, PyDict>) -> Kwargs<'py> {
        Kwargs { dict }
    }

    /// The text of option `name`, if given (`None` counts as not given).
    fn text(&self, name: &str) -> PyResult<Option<String>> {
        let Some(value) = self.dict.get_item(name)? else { return Ok(None) };
        self.dict.del_item(name)?;
        if value.is_none() {
            return Ok(None);
        }
        if value.is_instance_of::<pyo3::types::PyBool>() {
            return Err(invalid(name, &value.str()?.to_string(), "a flag takes True or False, not a value"));
        }
        Ok(Some(value.str()?.to_string()))
    }

    /// Option `name` checked by `check`.
    fn take<T>(&self, name: &str, check: impl Fn(&str) -> Result<T, String>) -> PyResult<Option<T>> {
        match self.text(name)? {
            Some(text) => check(&text).map(Some).map_err(|reason| invalid(name, &text, &reason)),
            None => Ok(None),
        }
    }

    /// Option `name`, one of a library enum's names.
    fn named<T: Named>(&self, name: &str) -> PyResult<Option<T>> {
        self.take(name, T::parse)
    }

    /// A flag: `True` or `False` (or absent).
    fn flag(&self, name: &str) -> PyResult<bool> {
        let Some(value) = self.dict.get_item(name)? else { return Ok(false) };
        self.dict.del_item(name)?;
        if value.is_none() {
            return Ok(false);
        }
        value.extract::<bool>().map_err(|_| invalid(name, &value.to_string(), "a flag takes True or False"))
    }

    /// A list option: a list of values, or one comma-separated string.
    fn list(&self, name: &str) -> PyResult<Vec<String>> {
        let Some(value) = self.dict.get_item(name)? else { return Ok(Vec::new()) };
        self.dict.del_item(name)?;
        if value.is_none() {
            return Ok(Vec::new());
        }
        if let Ok(text) = value.extract::<String>() {
            return Ok(text.split(',').map(str::to_owned).collect());
        }
        value.try_iter()?.map(|item| Ok(item?.str()?.to_string())).collect()
    }

    /// What is left is not an option of this function.
    fn done(self) -> PyResult<()> {
        match self.dict.keys().iter().next() {
            Some(key) => Err(PyValueError::new_err(format!("unexpected argument '{key}' found"))),
            None => Ok(()),
        }
    }

    /// The scheme options among them, each at the library's default when not given.
    fn scheme_options(&self) -> PyResult<SchemeOptions> {
        let d = SchemeOptions::default();
        Ok(SchemeOptions {
            extrapolation: self.named("extrapolation")?,
            tol: self.take("tol", positive)?.unwrap_or(d.tol),
            max_iter: self.take("max_iter", opt::max_iter)?.unwrap_or(d.max_iter),
            relaxation: self.take("relaxation", opt::relaxation)?.unwrap_or(d.relaxation),
            jacobian: self.named("jacobian")?.unwrap_or(d.jacobian),
            iqn_reuse: self.take("iqn_reuse", opt::whole)?.unwrap_or(d.iqn_reuse),
            iqn_filter: self.take("iqn_filter", opt::below_one)?.unwrap_or(d.iqn_filter),
            iqn_relaxation: self.take("iqn_relaxation", opt::factor)?.unwrap_or(d.iqn_relaxation),
            adaptive: self.flag("adaptive")?,
            rtol: self.take("rtol", opt::tolerance)?.unwrap_or(d.rtol),
            atol: self.take("atol", positive)?.unwrap_or(d.atol),
            h_min: self.take("h_min", positive)?.unwrap_or(d.h_min),
            h_max: self.take("h_max", positive)?.unwrap_or(d.h_max),
            watch: self.list("watch")?,
            estimate: self.named("estimate")?,
        })
    }

    /// The method and its steps: `scheme`, `dt`, `t_end` and the scheme options.
    fn method(&self) -> PyResult<(SchemeName, Option<f64>, Option<f64>, SchemeOptions)> {
        let scheme = self.named("scheme")?.ok_or_else(|| PyValueError::new_err("give a scheme"))?;
        let dt = self.take("dt", positive)?;
        let t_end = self.take("t_end", positive)?;
        Ok((scheme, dt, t_end, self.scheme_options()?))
    }
}

/// A value an option refuses, worded as the command line words it.
fn invalid(name: &str, value: &str, reason: &str) -> PyErr {
    PyValueError::new_err(format!("invalid value '{value}' for '{name}': {reason}"))
}

/// An option the library refuses (with its chain of causes).
fn option_value_error(e: &anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{e:#}"))
}

/// The net of a run at every sample: (times, every cable point's x, y, z as little-endian
/// float64 bytes, cables, points per cable).
type Net = (Vec<f64>, Vec<u8>, usize, usize);

/// One run: (the `--json` summary, the `--out` CSV, with `net` the net at every sample).
/// `progress(t, t_end)` is called at most every [`PROGRESS_PERIOD`] of wall time; an exception
/// it raises, or a pending signal (Ctrl-C), stops the run and is raised.
#[pyfunction]
#[pyo3(signature = (path, toml, label, options, progress=None, net=false))]
fn run(
    py: Python<'_>,
    path: Option<String>,
    toml: Option<String>,
    label: String,
    options: Bound<'_, PyDict>,
    progress: Option<Py<PyAny>>,
    net: bool,
) -> PyResult<(String, String, Option<Net>)> {
    let source = Source::new(path, toml, label)?;
    let kwargs = Kwargs::new(options);
    let (scheme, dt, t_end, options) = kwargs.method()?;
    let compensation = kwargs.named::<Compensation>("compensation")?.unwrap_or_default();
    let wind_seed = kwargs.take("wind_seed", studies::options::seed)?;
    kwargs.done()?;
    let scene = source.load().map_err(scene_error)?;
    let scene = compensation.apply(&scene).map_err(|e| option_value_error(&e))?;
    let scene = studies::options::with_wind_seed(&scene, wind_seed).map_err(|e| option_value_error(&e))?;
    let method = options.method(scheme).map_err(|e| option_value_error(&e))?;
    check_dt(options.adaptive, dt).map_err(|e| option_value_error(&e))?;
    let dt = dt.unwrap_or(scene.solver.dt_s);
    let t_end = t_end.unwrap_or(scene.solver.t_end_s);
    if let Some(reason) = method.net_refusal().filter(|_| net) {
        return Err(PyValueError::new_err(format!("net=True: {reason}")));
    }
    let file = source.file();
    py.detach(|| run_scene(&scene, &file, method, dt, t_end, progress, net))
}

/// How often a run looks at the interpreter (signals, the progress callback): rarely enough to
/// cost nothing against the steps, often enough for Ctrl-C to feel immediate.
const PROGRESS_PERIOD: Duration = Duration::from_millis(100);

/// The interpreter's side of a run: a pending signal (Ctrl-C) or an exception raised by the
/// progress callback stops it; both are looked at every [`PROGRESS_PERIOD`] of wall time.
struct Interpreter {
    progress: Option<Py<PyAny>>,
    t_end: f64,
    last: Instant,
    raised: Option<PyErr>,
}

impl Watch for Interpreter {
    fn stepped(&mut self, _: u64, t: f64) -> Result<(), String> {
        if self.last.elapsed() < PROGRESS_PERIOD {
            return Ok(());
        }
        self.last = Instant::now();
        let looked = Python::attach(|py| {
            py.check_signals()?;
            if let Some(callback) = &self.progress {
                callback.call1(py, (t, self.t_end))?;
            }
            Ok::<(), PyErr>(())
        });
        looked.map_err(|e| {
            let text = e.to_string();
            self.raised = Some(e);
            text
        })
    }
}

fn run_scene(
    scene: &ValidScene,
    file: &Path,
    method: Method,
    dt: f64,
    t_end: f64,
    progress: Option<Py<PyAny>>,
    net: bool,
) -> PyResult<(String, String, Option<Net>)> {
    let run = Run::prepare(scene, file, method, dt, t_end, &Limits::default()).map_err(|e| run_error(&e))?;
    let mut watch = Interpreter { progress, t_end, last: Instant::now(), raised: None };
    let mut record = net.then(studies::net::NetRecord::default);
    let sink = record.as_mut().map(|r| (r as &mut dyn studies::net::NetSink, 1));
    let trace = run.execute_with_net(&mut watch, sink);
    if let Some(e) = watch.raised {
        return Err(e);
    }
    let trace = trace.map_err(|e| run_error(&e))?;
    let utilisation = static_utilisation(scene).map_err(|e| run_error(&e))?;
    let summary = run_summary(scene, &trace, utilisation.as_deref());
    let mut csv = Vec::new();
    trace.write_csv(&mut csv, &scene.outputs.quantities).map_err(|e| run_error(&e))?;
    let csv = String::from_utf8(csv).map_err(|e| run_error(&e))?;
    let net = record.map(|r| {
        let bytes = r.positions.iter().flat_map(|x| x.to_le_bytes()).collect();
        (r.times, bytes, r.cables, r.points_per_cable)
    });
    Ok((summary.to_string(), csv, net))
}

/// `master statics --json`.
#[pyfunction]
#[pyo3(signature = (path, toml, label))]
fn statics(py: Python<'_>, path: Option<String>, toml: Option<String>, label: String) -> PyResult<String> {
    let scene = Source::new(path, toml, label)?.load().map_err(scene_error)?;
    py.detach(|| {
        check_memory(&scene, Footprint::CableModel, 0, &Limits::default()).map_err(|e| run_error(&e))?;
        let s = Statics::of(&scene).map_err(|e| run_error(&e))?;
        Ok(s.json().to_string())
    })
}

/// `master modes --count N --json`.
#[pyfunction]
#[pyo3(signature = (path, toml, label, count))]
fn modes(py: Python<'_>, path: Option<String>, toml: Option<String>, label: String, count: usize) -> PyResult<String> {
    if !(1..=10_000).contains(&count) {
        return Err(PyValueError::new_err(format!("count = {count}: give 1 to 10000 modes")));
    }
    let scene = Source::new(path, toml, label)?.load().map_err(scene_error)?;
    py.detach(|| {
        let built = cable::model::CableCabin::modes_built(&scene, count);
        check_memory(&scene, Footprint::CableModel, built, &Limits::default()).map_err(|e| run_error(&e))?;
        let m = Modal::of(&scene, count).map_err(|e| run_error(&e))?;
        Ok(m.json().to_string())
    })
}

/// A run of an SSP system file: (the `--json` summary, the `--out` CSV).
#[pyfunction]
#[pyo3(signature = (path, options))]
fn run_system(py: Python<'_>, path: String, options: Bound<'_, PyDict>) -> PyResult<(String, String)> {
    let kwargs = Kwargs::new(options);
    let (scheme, dt, t_end, options) = kwargs.method()?;
    let defaults = SystemFiles::default();
    let files = SystemFiles {
        allow_external_fmus: kwargs.flag("allow_external_fmus")?,
        max_archive_entries: kwargs.take("max_archive_entries", opt::whole)?,
        max_unpacked_mb: kwargs.take("max_unpacked_mb", |t| opt::megabytes(t, UNPACKED_MB))?,
        interface: kwargs
            .list("interface")?
            .iter()
            .map(|t| opt::interface(t).map_err(|r| invalid("interface", t, &r)))
            .collect::<PyResult<_>>()?,
        me_solver: kwargs.named("me_solver")?.unwrap_or(defaults.me_solver),
        me_rtol: kwargs.take("me_rtol", opt::tolerance)?.unwrap_or(defaults.me_rtol),
        me_atol: kwargs.take("me_atol", positive)?.unwrap_or(defaults.me_atol),
        rate: kwargs
            .list("rate")?
            .iter()
            .map(|t| opt::rate(t).map_err(|r| invalid("rate", t, &r)))
            .collect::<PyResult<_>>()?,
        python_library: kwargs.take("python_library", |t| Ok::<_, String>(std::path::PathBuf::from(t)))?,
    };
    kwargs.done()?;
    let method = options.method(scheme).map_err(|e| option_value_error(&e))?;
    py.detach(|| {
        let file = Path::new(&path);
        let system = SystemFile::prepare(file, method, dt, t_end, &files, &Limits::default())
            .map_err(|e| RunError::new_err(format!("{e:#}")))?;
        let mut csv = Vec::new();
        let sinks = studies::system::Sinks { csv: Some(&mut csv), real: None };
        let outcome = system.execute(&mut Unwatched, sinks).map_err(|e| run_error(&e))?;
        let csv = String::from_utf8(csv).map_err(|e| run_error(&e))?;
        Ok((system.summary(&outcome).to_string(), csv))
    })
}

/// `master sweep` without its files: (the columns of sweep.csv, its rows as text).
#[pyfunction]
#[pyo3(name = "sweep", signature = (path, toml, label, grid, options))]
#[allow(clippy::type_complexity)]
fn sweep_grid(
    py: Python<'_>,
    path: Option<String>,
    toml: Option<String>,
    label: String,
    grid: Vec<String>,
    options: Bound<'_, PyDict>,
) -> PyResult<(Vec<String>, Vec<Vec<String>>)> {
    let source = Source::new(path, toml, label)?;
    let kwargs = Kwargs::new(options);
    let surface = kwargs.take("surface", |t| sweep::Surface::parse(t).map_err(|e| e.to_string()))?;
    let tilt_share = kwargs.take("tilt_share", opt::finite)?;
    if tilt_share.is_some() && surface.is_none() {
        return Err(PyValueError::new_err("tilt_share needs a surface"));
    }
    let modes = kwargs.take("modes", sweep::mode_count)?.unwrap_or(sweep::DEFAULT_MODES);
    let run = kwargs.named::<SchemeName>("run")?;
    let t_end = kwargs.take("t_end", positive)?.unwrap_or(sweep::DEFAULT_RUN_S);
    let jobs = kwargs.take("jobs", opt::jobs)?;
    let options = kwargs.scheme_options()?;
    kwargs.done()?;
    let scene = source.load().map_err(scene_error)?;
    let value_error = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let grid = sweep::Grid::parse(&grid).map_err(|e| value_error(&e))?;
    let placement = sweep::Placement { surface, tilt_share };
    let method = run.map(|s| options.method(s)).transpose().map_err(|e| option_value_error(&e))?;
    let limits = Limits::default();
    let request = sweep::Request {
        modes,
        run: method.clone().map(|m| (m, t_end)),
        limits,
        utilisation: scene.cables.breaking_load_n.is_some(),
    };
    let file = source.file();
    py.detach(|| {
        // every run's steps and what its method needs, at every step swept, before the first point
        if let Some(method) = method {
            for dt in grid.steps(scene.solver.dt_s) {
                Run::prepare(&scene, &file, method.clone(), dt, t_end, &limits).map_err(|e| run_error(&e))?;
            }
        }
        let points: Vec<usize> = (0..grid.len()).collect();
        let rows = studies::parallel::map_longest_first(
            &points,
            jobs,
            |&index| grid.cost(index),
            |_, &index| {
                let values = grid.point(index);
                let outcome = sweep::evaluate(&scene, &file, &placement, &request, &values);
                sweep::cells(index, &values, &request, &outcome)
            },
        )
        .map_err(|e| run_error(&e))?;
        Ok((sweep::columns(&grid, &request), rows))
    })
}

#[pymodule]
fn _feedsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(statics, m)?)?;
    m.add_function(wrap_pyfunction!(modes, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_grid, m)?)?;
    m.add_function(wrap_pyfunction!(run_system, m)?)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    Ok(())
}
