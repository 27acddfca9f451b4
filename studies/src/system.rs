//! Systems of FMUs as the master runs them: the scene's `[system]` table as a
//! [`SystemSpec`], and a run of any system (`master run --system`) that records every output of
//! every component ([`SystemRun`]: checked before it starts, stepped through the one step loop).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cosim::error_estimate::Kind;
use cosim::step_control::{Controller, Limits, REFACTORIZING_HOLD, Tolerances};
use cosim::system::spec::{Component, Connection, Endpoint, Matching, Parameter, Value};
use cosim::{Coupled, FmuSystem, Needs, Options, SetupError, SystemSpec};
use feedcore::scene::{Start, ValidScene};
use fmi::{Causality, VarType};

use crate::limits::{Limits as StepLimits, Plan, Schedule};
use crate::simulate::RunError;
use crate::stepping::{Flow, Request, Step, Watch, drive};

mod file;
pub use file::SystemFile;

/// Resolves a scene-relative path.
fn relative_to(scene_file: &Path, path: &str) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() { p.to_owned() } else { scene_file.parent().unwrap_or(Path::new(".")).join(p) }
}

/// The scene's `[system]` as a system description: FMU paths relative to the scene file,
/// connections by name prefix, parameters as text (`"@scene"`: the scene itself, handed over as
/// a `data:` URI named after its file, so that the FMUs read exactly this scene, a variant made in
/// memory included).
pub fn scene_spec(scene: &ValidScene, scene_file: &Path) -> Result<SystemSpec, SetupError> {
    let file_error = |message: String| SetupError::File { path: scene_file.to_owned(), message };
    let sys = scene
        .system
        .as_ref()
        .ok_or_else(|| file_error("the scene has no [system] section (FMUs and their connections)".into()))?;
    let file_name = scene_file.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let scene_text = fmi::uri::data_uri("application/toml", &file_name, &scene.to_toml());
    let endpoint = |text: &str| {
        let (component, variable) =
            text.split_once('.').expect("a ValidScene's connection ends and parameters are `fmu.name`");
        Endpoint { component: component.into(), variable: variable.into() }
    };
    Ok(SystemSpec {
        origin: format!("{} [system]", scene_file.display()),
        components: sys
            .fmus
            .iter()
            .map(|f| Component { name: f.name.clone(), source: relative_to(scene_file, &f.path), interface: None })
            .collect(),
        connections: sys
            .connections
            .iter()
            .map(|c| Connection {
                from: endpoint(&c.from),
                to: endpoint(&c.to),
                matching: Matching::Prefix,
                transform: None,
            })
            .collect(),
        parameters: sys
            .parameters
            .iter()
            .map(|(key, value)| Parameter {
                target: endpoint(key),
                value: Value::Text(if value == "@scene" { scene_text.clone() } else { value.clone() }),
            })
            .collect(),
        connectors: Vec::new(),
        observed: Vec::new(),
        watch: Vec::new(),
        kink_at_start: scene.motion.start != Start::Ramp,
    })
}

/// What a scheme needs from every FMU.
pub fn needs(options: &Options, adaptive: bool) -> Needs {
    let what = if adaptive {
        format!("the adaptive step with scheme {}", options.scheme.name())
    } else {
        format!("scheme {}", options.scheme.name())
    };
    Needs { what, rollback: options.scheme.is_implicit() || adaptive, model_exchange: Default::default() }
}

/// Step-size settings of an adaptive run.
#[derive(Clone, Debug, PartialEq)]
pub struct Adaptive {
    pub tolerances: Tolerances,
    pub h_min: f64,
    pub h_max: f64,
    /// The coupled inputs the error estimate watches (names or prefixes, [`Coupled::watch`]);
    /// empty: the runner's default.
    pub watch: Vec<String>,
    /// How the local error is estimated.
    pub estimate: Kind,
}

impl Adaptive {
    /// The controller. The first steps cannot be judged (no history), so they are small: ten
    /// times the smallest step. It keeps a step size unless it may grow by
    /// [`REFACTORIZING_HOLD`]: a new size is a new step map — the monolithic model and the cable
    /// FMU refactorize their iteration matrices, IJCSA recomputes its interface Jacobian.
    pub fn controller(&self) -> Result<Controller, String> {
        let h_init = (10.0 * self.h_min).min(self.h_max);
        Ok(Controller::new(Limits { h_min: self.h_min, h_max: self.h_max, h_init })?.holding(REFACTORIZING_HOLD))
    }
}

/// Which components run as Model Exchange, and how those are integrated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelExchangeChoice {
    /// (component, or every component, interface), in order: a later entry overrides.
    pub interfaces: Vec<(Option<String>, fmi::import::Interface)>,
    pub options: cosim::me::MeOptions,
}

impl ModelExchangeChoice {
    /// Applies the interfaces to the components of `spec`; a component not in it is an error.
    pub fn apply(&self, spec: &mut SystemSpec) -> Result<(), String> {
        for (component, interface) in &self.interfaces {
            match component {
                None => spec.components.iter_mut().for_each(|c| c.interface = Some(*interface)),
                Some(name) => {
                    let c = spec
                        .components
                        .iter_mut()
                        .find(|c| &c.name == name)
                        .ok_or_else(|| format!("--interface {name}=…: the system has no component `{name}`"))?;
                    c.interface = Some(*interface);
                }
            }
        }
        Ok(())
    }
}

/// Every output variable of one component, by type, in the order of its description.
struct ComponentOutputs {
    component: usize,
    real: Vec<u32>,
    integer: Vec<u32>,
    boolean: Vec<u32>,
    string: Vec<u32>,
    /// `<component>.<variable>` of the Real outputs.
    real_names: Vec<String>,
    /// (type, index within the type) of every output, in description order.
    order: Vec<(VarType, usize)>,
}

/// Where the samples of a run of a system go.
#[derive(Default)]
pub struct Sinks<'a> {
    /// CSV: `time`, then every output of every component as `<component>.<variable>`.
    pub csv: Option<&'a mut dyn Write>,
    /// The Real outputs kept in memory (e.g. for a plot).
    pub real: Option<&'a mut RealHistory>,
}

/// The Real outputs of every component over time.
#[derive(Clone, Debug, Default)]
pub struct RealHistory {
    /// `<component>.<variable>` of each column.
    pub names: Vec<String>,
    pub t: Vec<f64>,
    /// One column per name.
    pub values: Vec<Vec<f64>>,
}

/// What a run of a system did.
#[derive(Clone, Debug, Default)]
pub struct SystemOutcome {
    pub steps: u64,
    pub rejected_steps: u64,
    pub h_min_used: f64,
    pub h_max_used: f64,
    pub mean_iterations: f64,
    pub max_residual: f64,
    pub t_end: f64,
    /// Set when a component ended the run (fmi2Discard): the last time all components reached,
    /// and what the component said.
    pub stopped_early: Option<(f64, String)>,
    pub wall_time_s: f64,
    /// `time` and every output, as in the CSV.
    pub columns: Vec<String>,
    /// What the integration of each Model Exchange component did: (component, solver, stats).
    pub model_exchange: Vec<(String, &'static str, cosim::me::MeStats)>,
}

/// A run of a system checked whole, ready to start (like [`crate::simulate::Run`]).
pub struct SystemRun<'a> {
    spec: &'a SystemSpec,
    options: Options,
    adaptive: Option<Adaptive>,
    schedule: Schedule,
    /// How Model Exchange components are integrated.
    pub model_exchange: cosim::me::MeOptions,
}

impl<'a> SystemRun<'a> {
    /// Checks the steps before anything is loaded: `dt` steps that reach `t_end` exactly within
    /// the step cap, or (`adaptive`) a scheme that iterates and a step range whose largest steps
    /// stay within the cap.
    pub fn prepare(
        spec: &'a SystemSpec,
        options: Options,
        adaptive: Option<Adaptive>,
        dt: f64,
        t_end: f64,
        limits: &StepLimits,
    ) -> Result<SystemRun<'a>, RunError> {
        let method = options.scheme.name();
        let refused = |reason: String| RunError::Refused { method, reason };
        let schedule = match &adaptive {
            Some(a) => {
                if !options.scheme.is_implicit() {
                    return Err(refused(format!(
                        "the adaptive step needs a scheme that iterates (iterative, ijcsa, iqn-ils), not {method}"
                    )));
                }
                a.controller().map_err(refused)?;
                Schedule::adaptive(t_end, a.h_min, a.h_max, limits).map_err(|e| refused(e.to_string()))?
            }
            None => Schedule::Fixed(Plan::new(dt, t_end, limits).map_err(|e| refused(e.to_string()))?),
        };
        Ok(SystemRun { spec, options, adaptive, schedule, model_exchange: Default::default() })
    }

    /// Runs it from 0 to the end time, writing the samples (every step) to `sinks`. Stops on a
    /// non-finite output it reads (the coupled ones are always checked; the others when a sink
    /// asks for them). A component that ends the run (fmi2Discard) ends it at the last
    /// communication point: not an error.
    pub fn execute(&self, watcher: &mut dyn Watch, mut sinks: Sinks<'_>) -> Result<SystemOutcome, RunError> {
        let method = self.options.scheme.name();
        let setup = |e: &(dyn std::error::Error + 'static)| RunError::setup(method, e);
        let output = |source: std::io::Error| RunError::Output { method, source };
        let start = Instant::now();
        // what is watched: --watch, else what the description suggests, else every coupled
        // input (nothing else is known of the FMUs' quantities); outputs named are read after
        // every step too
        let watch = self.adaptive.as_ref().map(|a| if a.watch.is_empty() { &self.spec.watch } else { &a.watch });
        let spec = watch.filter(|w| !w.is_empty()).map(|w| SystemSpec { observed: w.clone(), ..self.spec.clone() });
        let needs = Needs { model_exchange: self.model_exchange, ..needs(&self.options, self.adaptive.is_some()) };
        let system = FmuSystem::load(spec.as_ref().unwrap_or(self.spec), &needs).map_err(|e| setup(&e))?;
        let mut c = Coupled::new(system, self.options).map_err(|e| setup(&e))?;
        if let (Some(a), Some(watch)) = (&self.adaptive, watch) {
            let from =
                if a.watch.is_empty() { format!("{} (its annotation)", self.spec.origin) } else { "--watch".into() };
            c.watch(watch).map_err(|e| RunError::Refused { method, reason: format!("{from}: {e}") })?;
            c.estimate_by(a.estimate);
        }
        let mut outputs = Vec::new();
        // an adaptive run's rows are its accepted steps, each with its size
        let adaptive = self.adaptive.is_some();
        let mut columns = vec!["time".to_string()];
        if adaptive {
            columns.push("h_s".to_string());
        }
        for (k, (name, inst)) in c.units_mut().instances().enumerate() {
            let mut o = ComponentOutputs {
                component: k,
                real: vec![],
                integer: vec![],
                boolean: vec![],
                string: vec![],
                real_names: vec![],
                order: vec![],
            };
            for v in inst.fmu().description().variables.iter().filter(|v| v.causality == Causality::Output) {
                columns.push(format!("{name}.{}", v.name));
                let list = match v.var_type {
                    VarType::Real => {
                        o.real_names.push(format!("{name}.{}", v.name));
                        &mut o.real
                    }
                    VarType::Integer => &mut o.integer,
                    VarType::Boolean => &mut o.boolean,
                    VarType::String => &mut o.string,
                };
                o.order.push((v.var_type, list.len()));
                list.push(v.value_reference);
            }
            outputs.push(o);
        }
        if let Some(f) = sinks.csv.as_mut() {
            writeln!(f, "{}", columns.iter().map(|c| csv_text(c)).collect::<Vec<_>>().join(",")).map_err(output)?;
        }
        if let Some(h) = sinks.real.as_mut() {
            h.names = outputs.iter().flat_map(|o| o.real_names.iter().cloned()).collect();
            h.values = vec![Vec::new(); h.names.len()];
        }
        let reads = sinks.csv.is_some() || sinks.real.is_some();
        let mut buf = (Vec::new(), Vec::new(), Vec::new());
        // one row of samples at time t, after a step of h (0 at the start)
        let mut sample = |c: &mut Coupled<FmuSystem>, t: f64, h: f64, sinks: &mut Sinks<'_>| -> Result<(), RunError> {
            if !reads {
                return Ok(());
            }
            if let Some(f) = sinks.csv.as_mut() {
                write!(f, "{t}").map_err(output)?;
                if adaptive {
                    write!(f, ",{h}").map_err(output)?;
                }
            }
            if let Some(h) = sinks.real.as_mut() {
                h.t.push(t);
            }
            let mut column = 0;
            for o in &outputs {
                let inst = c.units_mut().instances().nth(o.component).expect("a component").1;
                let failed = |e: fmi::import::Error| RunError::Stopped { method, time: t, reason: e.to_string() };
                buf.0.resize(o.real.len(), 0.0);
                buf.1.resize(o.integer.len(), 0);
                buf.2.resize(o.boolean.len(), false);
                inst.get_real(&o.real, &mut buf.0).map_err(failed)?;
                inst.get_integer(&o.integer, &mut buf.1).map_err(failed)?;
                inst.get_boolean(&o.boolean, &mut buf.2).map_err(failed)?;
                if let Some(i) = buf.0.iter().position(|x| !x.is_finite()) {
                    return Err(RunError::Stopped {
                        method,
                        time: t,
                        reason: format!("the output `{}` is {}", o.real_names[i], buf.0[i]),
                    });
                }
                if let Some(h) = sinks.real.as_mut() {
                    for (x, col) in buf.0.iter().zip(&mut h.values[column..]) {
                        col.push(*x);
                    }
                }
                column += o.real.len();
                let Some(f) = sinks.csv.as_mut() else { continue };
                let strings =
                    if o.string.is_empty() { Vec::new() } else { inst.get_string(&o.string).map_err(failed)? };
                for (ty, j) in &o.order {
                    match ty {
                        VarType::Real => write!(f, ",{:e}", buf.0[*j]),
                        VarType::Integer => write!(f, ",{}", buf.1[*j]),
                        VarType::Boolean => write!(f, ",{}", u8::from(buf.2[*j])),
                        VarType::String => write!(f, ",{}", csv_text(&strings[*j])),
                    }
                    .map_err(output)?;
                }
            }
            if let Some(f) = sinks.csv.as_mut() {
                writeln!(f).map_err(output)?;
            }
            Ok(())
        };
        sample(&mut c, 0.0, 0.0, &mut sinks)?;
        let mut controller = self
            .adaptive
            .as_ref()
            .map(|a| a.controller())
            .transpose()
            .map_err(|reason| RunError::Refused { method, reason })?;
        let tolerances = self.adaptive.as_ref().map(|a| a.tolerances);
        // the step and the sampling after it both reach the system
        let cell = std::cell::RefCell::new(c);
        let totals = drive(
            &self.schedule,
            watcher,
            |time, reason| RunError::Stopped { method, time, reason },
            |r| {
                let mut c = cell.borrow_mut();
                let result = match (r, controller.as_mut(), tolerances) {
                    (Request::Adaptive { t_stop }, Some(ctl), Some(tol)) => {
                        c.step_adaptive(ctl, tol, t_stop).map(|s| (s.h, s.report, s.rejected))
                    }
                    (Request::Fixed { h, .. }, _, _) => {
                        // a kink at the start (as the description says): the first step in substeps
                        let kink = self.spec.kink_at_start && c.time() == 0.0;
                        let report = if kink { c.step_from_start(h) } else { c.step(h) };
                        report.map(|report| (h, report, 0))
                    }
                    (Request::Adaptive { .. }, _, _) => {
                        return Err(RunError::Refused { method, reason: "no adaptive step was prepared".into() });
                    }
                };
                match result {
                    Ok((h, report, rejected)) => Ok(Flow::Stepped(Step {
                        h,
                        rejected,
                        iterations: report.iterations,
                        residual: report.residual,
                        payload: (),
                    })),
                    Err(e) => match e.ended() {
                        Some((unit, why)) => Ok(Flow::Ended(format!("component `{unit}` {why}"))),
                        None => Err(RunError::stopped_by(method, &e)),
                    },
                }
            },
            |_, t, s| {
                if crate::cancel::requested() {
                    return Err(RunError::Interrupted { method, time: t });
                }
                sample(&mut cell.borrow_mut(), t, s.h, &mut sinks)
            },
        )?;
        let mut c = cell.into_inner();
        if let Some(f) = sinks.csv.as_mut() {
            f.flush().map_err(output)?;
        }
        // after an early stop a component may refuse fmi2Terminate; the run is over either way
        let terminated = c.units_mut().terminate();
        if totals.ended.is_none() {
            terminated.map_err(|e| setup(&e))?;
        }
        Ok(SystemOutcome {
            model_exchange: c.units().model_exchange_stats(),
            steps: totals.steps,
            rejected_steps: totals.rejected,
            h_min_used: totals.h_min,
            h_max_used: totals.h_max,
            mean_iterations: if totals.steps == 0 { 0.0 } else { totals.iterations as f64 / totals.steps as f64 },
            max_residual: totals.max_residual,
            t_end: self.schedule.t_end(),
            stopped_early: totals.ended,
            wall_time_s: start.elapsed().as_secs_f64(),
            columns,
        })
    }
}

/// A CSV field, quoted when it must be.
fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}
