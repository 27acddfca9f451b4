//! `feedsim._feedsim`: the library crates behind the Python package `feedsim`. Each function
//! takes a scene (a file, or the TOML text of a dict) and the command line's options as
//! arguments, runs what the `master` command runs, releases the GIL while it computes, and
//! returns what the command's `--json` and `--out` hold (JSON text, CSV text); `feedsim/__init__.py`
//! turns them into dicts, numpy arrays and data frames.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Parser;
use feedcore::scene::{MAX_SCENE_BYTES, Scene, SceneError as InvalidScene, ValidScene};
use master::limits::{Footprint, Limits, check_memory};
use master::options::{CompensationArg, SchemeName, SchemeOptions, SystemFileArgs, check_dt, positive};
use master::report::{Modal, Statics, run_summary, static_utilisation};
use master::simulate::{Method, Run};
use master::sweep;
use master::system::SystemFile;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

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

/// An error with its whole chain of causes, as the command line prints it.
fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text += &format!(": {s}");
        source = s.source();
    }
    text
}

fn run_error(e: &(dyn std::error::Error + 'static)) -> PyErr {
    RunError::new_err(chain(e))
}

/// The method and its steps, as `master run` takes them (the same flags, the same checks).
#[derive(clap::Args)]
struct Stepping {
    #[arg(long, value_enum)]
    scheme: SchemeName,
    #[arg(long, value_parser = positive)]
    dt: Option<f64>,
    #[arg(long, value_parser = positive)]
    t_end: Option<f64>,
    #[command(flatten)]
    options: SchemeOptions,
}

/// The options of `master run --scene` the package passes on.
#[derive(Parser)]
#[command(name = "feedsim.run", no_binary_name = true)]
struct RunArgs {
    #[command(flatten)]
    stepping: Stepping,
    #[arg(long, value_enum, default_value_t = CompensationArg::On)]
    compensation: CompensationArg,
}

/// An option the library refuses (with its chain of causes).
fn option_value_error(e: &anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{e:#}"))
}

/// An option error as clap words it, without its usage lines.
fn option_error(e: clap::Error) -> PyErr {
    let text = e.render().to_string();
    let first = text.lines().next().unwrap_or("").trim_start_matches("error: ").to_string();
    PyValueError::new_err(first)
}

/// The net of a run at every sample: (times, every cable point's x, y, z as little-endian
/// float64 bytes, cables, points per cable).
type Net = (Vec<f64>, Vec<u8>, usize, usize);

/// One run: (the `--json` summary, the `--out` CSV, with `net` the net at every sample).
/// `progress(t, t_end)` is called at most every [`PROGRESS_PERIOD`] of wall time; an exception
/// it raises, or a pending signal (Ctrl-C), stops the run and is raised.
#[pyfunction]
#[pyo3(signature = (path, toml, label, argv, progress=None, net=false))]
fn run(
    py: Python<'_>,
    path: Option<String>,
    toml: Option<String>,
    label: String,
    argv: Vec<String>,
    progress: Option<Py<PyAny>>,
    net: bool,
) -> PyResult<(String, String, Option<Net>)> {
    let source = Source::new(path, toml, label)?;
    let RunArgs { stepping: args, compensation } = RunArgs::try_parse_from(&argv).map_err(option_error)?;
    let scene = source.load().map_err(scene_error)?;
    let scene = compensation.apply(&scene).map_err(|e| option_value_error(&e))?;
    let method = args.options.method(args.scheme).map_err(|e| option_value_error(&e))?;
    check_dt(args.options.adaptive, args.dt).map_err(|e| option_value_error(&e))?;
    let dt = args.dt.unwrap_or(scene.solver.dt_s);
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    if let Some(reason) = method.net_refusal().filter(|_| net) {
        return Err(PyValueError::new_err(format!("net=True: {reason}")));
    }
    let file = source.file();
    py.detach(|| run_scene(&scene, &file, method, dt, t_end, progress, net))
}

/// How often a run looks at the interpreter (signals, the progress callback): rarely enough to
/// cost nothing against the steps, often enough for Ctrl-C to feel immediate.
const PROGRESS_PERIOD: Duration = Duration::from_millis(100);

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
    let mut raised: Option<PyErr> = None;
    let mut last = Instant::now();
    let mut watch = |t: f64| -> Result<(), String> {
        if last.elapsed() < PROGRESS_PERIOD {
            return Ok(());
        }
        last = Instant::now();
        let looked = Python::attach(|py| {
            py.check_signals()?;
            if let Some(callback) = &progress {
                callback.call1(py, (t, t_end))?;
            }
            Ok::<(), PyErr>(())
        });
        looked.map_err(|e| {
            let text = e.to_string();
            raised = Some(e);
            text
        })
    };
    let mut record = net.then(master::net::NetRecord::default);
    let sink = record.as_mut().map(|r| (r as &mut dyn master::net::NetSink, 1));
    let trace = run.execute_with_net(true, &mut watch, sink);
    if let Some(e) = raised {
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

/// The options of `master run --system` the package passes on.
#[derive(Parser)]
#[command(name = "feedsim.run_system", no_binary_name = true)]
struct SystemArgs {
    #[command(flatten)]
    stepping: Stepping,
    #[command(flatten)]
    files: SystemFileArgs,
}

/// A run of an SSP system file: (the `--json` summary, the `--out` CSV).
#[pyfunction]
#[pyo3(signature = (path, argv))]
fn run_system(py: Python<'_>, path: String, argv: Vec<String>) -> PyResult<(String, String)> {
    let SystemArgs { stepping: args, files } = SystemArgs::try_parse_from(&argv).map_err(option_error)?;
    let method = args.options.method(args.scheme).map_err(|e| option_value_error(&e))?;
    py.detach(|| {
        let file = Path::new(&path);
        let system = SystemFile::prepare(file, method, args.dt, args.t_end, &files.limits(), &Limits::default())
            .and_then(|s| s.with_model_exchange(&files.model_exchange()?))
            .map_err(|e| RunError::new_err(format!("{e:#}")))?;
        let mut csv = Vec::new();
        let sinks = master::system::Sinks { csv: Some(&mut csv), real: None };
        let outcome = system.execute(true, sinks).map_err(|e| run_error(&e))?;
        let csv = String::from_utf8(csv).map_err(|e| run_error(&e))?;
        Ok((system.summary(&outcome).to_string(), csv))
    })
}

/// The options of `master sweep` the package passes on.
#[derive(Parser)]
#[command(name = "feedsim.sweep", no_binary_name = true)]
struct SweepArgs {
    #[arg(long = "grid")]
    grid: Vec<String>,
    #[arg(long, allow_hyphen_values = true)]
    surface: Option<String>,
    #[arg(long, requires = "surface", allow_negative_numbers = true)]
    tilt_share: Option<f64>,
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    modes: u32,
    #[arg(long, value_enum)]
    run: Option<SchemeName>,
    #[arg(long, default_value_t = 2.0, value_parser = positive)]
    t_end: f64,
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    jobs: Option<u16>,
    #[command(flatten)]
    options: SchemeOptions,
}

/// `master sweep` without its files: (the columns of sweep.csv, its rows as text).
#[pyfunction]
#[pyo3(name = "sweep", signature = (path, toml, label, argv))]
#[allow(clippy::type_complexity)]
fn sweep_grid(
    py: Python<'_>,
    path: Option<String>,
    toml: Option<String>,
    label: String,
    argv: Vec<String>,
) -> PyResult<(Vec<String>, Vec<Vec<String>>)> {
    let source = Source::new(path, toml, label)?;
    let args = SweepArgs::try_parse_from(&argv).map_err(option_error)?;
    let scene = source.load().map_err(scene_error)?;
    let value_error = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let grid = sweep::Grid::parse(&args.grid).map_err(|e| value_error(&e))?;
    let surface = args.surface.as_deref().map(sweep::Surface::parse).transpose().map_err(|e| value_error(&e))?;
    let placement = sweep::Placement { surface, tilt_share: args.tilt_share };
    let method = args.run.map(|s| args.options.method(s)).transpose().map_err(|e| option_value_error(&e))?;
    let limits = Limits::default();
    let request = sweep::Request {
        modes: args.modes as usize,
        run: method.clone().map(|m| (m, args.t_end)),
        limits,
        utilisation: scene.cables.breaking_load_n.is_some(),
    };
    let file = source.file();
    py.detach(|| {
        // every run's steps and what its method needs, at every step swept, before the first point
        if let Some(method) = method {
            for dt in grid.steps(scene.solver.dt_s) {
                Run::prepare(&scene, &file, method.clone(), dt, args.t_end, &limits).map_err(|e| run_error(&e))?;
            }
        }
        let points: Vec<usize> = (0..grid.len()).collect();
        let jobs = args.jobs.map(usize::from);
        let rows = master::parallel::map_longest_first(
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
