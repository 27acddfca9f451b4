//! Systems of FMUs as the master runs them: the scene's `[system]` table as a
//! [`SystemSpec`], and a run of any system (`master run --system`) that records every output of
//! every component.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cosim::step_control::{Controller, Limits, Tolerances};
use cosim::system::spec::{Component, Connection, Endpoint, Matching, Parameter, Value};
use cosim::{Coupled, FmuSystem, Needs, Options, SystemSpec};
use feedcore::scene::Scene;
use fmi2::{Causality, VarType};

use crate::progress::Progress;

/// Resolves a scene-relative path.
fn relative_to(scene_file: &Path, path: &str) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() { p.to_owned() } else { scene_file.parent().unwrap_or(Path::new(".")).join(p) }
}

/// The scene's `[system]` as a system description: FMU paths relative to the scene file,
/// connections by name prefix, parameters as text (`"@scene"`: the scene file's absolute path).
pub fn scene_spec(scene: &Scene, scene_file: &Path) -> Result<SystemSpec, Box<dyn std::error::Error>> {
    let sys = scene.system.as_ref().ok_or_else(|| {
        format!("{}: the scene has no [system] section (FMUs and their connections)", scene_file.display())
    })?;
    let scene_abs = std::fs::canonicalize(scene_file).map_err(|e| format!("{}: {e}", scene_file.display()))?;
    let endpoint = |text: &str| {
        let (component, variable) = text.split_once('.').expect("validated scene");
        Endpoint { component: component.into(), variable: variable.into() }
    };
    Ok(SystemSpec {
        origin: format!("{} [system]", scene_file.display()),
        components: sys
            .fmus
            .iter()
            .map(|f| Component { name: f.name.clone(), source: relative_to(scene_file, &f.path) })
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
                value: Value::Text(if value == "@scene" { scene_abs.display().to_string() } else { value.clone() }),
            })
            .collect(),
        connectors: Vec::new(),
    })
}

/// What a scheme needs from every FMU.
pub fn needs(options: &Options, adaptive: bool) -> Needs {
    let what = if adaptive {
        format!("the adaptive step with scheme {}", options.scheme.name())
    } else {
        format!("scheme {}", options.scheme.name())
    };
    Needs { what, rollback: options.scheme.is_implicit() || adaptive }
}

/// Step-size settings of an adaptive run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    pub tolerances: Tolerances,
    pub h_min: f64,
    pub h_max: f64,
}

impl Adaptive {
    /// The controller. The first steps cannot be judged (no history), so they are small: ten
    /// times the smallest step.
    pub fn controller(&self) -> Result<Controller, String> {
        let h_init = (10.0 * self.h_min).min(self.h_max);
        Controller::new(Limits { h_min: self.h_min, h_max: self.h_max, h_init })
    }
}

/// Every output variable of one component, by type.
struct Outputs {
    component: usize,
    real: Vec<u32>,
    integer: Vec<u32>,
    boolean: Vec<u32>,
    string: Vec<u32>,
}

/// Summary of a run of a system.
#[derive(Clone, Debug, Default)]
pub struct SystemRun {
    pub steps: usize,
    pub rejected_steps: usize,
    pub h_min_used: f64,
    pub h_max_used: f64,
    pub mean_iterations: f64,
    pub max_residual: f64,
    pub t_end: f64,
    /// Set when a component ended the run (fmi2Discard): the last time all components reached,
    /// and what the component said.
    pub stopped_early: Option<(f64, String)>,
    pub wall_time_s: f64,
    pub columns: Vec<String>,
}

/// Runs `spec` with `options` from 0 to `t_end` at step `dt` (or adaptively from `dt`), writing
/// `time` and every output of every component to `csv` (in a temporary file renamed at the end,
/// so a failed run leaves no file that looks complete).
pub fn run_system(
    spec: &SystemSpec,
    options: Options,
    adaptive: Option<Adaptive>,
    dt: f64,
    t_end: f64,
    csv: Option<&Path>,
    quiet: bool,
) -> Result<SystemRun, Box<dyn std::error::Error>> {
    if !(dt > 0.0 && dt.is_finite() && t_end > 0.0 && t_end.is_finite()) {
        return Err(format!("the step ({dt} s) and the end time ({t_end} s) must be positive").into());
    }
    let start = Instant::now();
    let system = FmuSystem::load(spec, &needs(&options, adaptive.is_some()))?;
    let mut c = Coupled::new(system, options)?;
    let mut outputs = Vec::new();
    let mut columns = vec!["time".to_string()];
    for (k, (name, inst)) in c.units_mut().instances().enumerate() {
        let mut o = Outputs { component: k, real: vec![], integer: vec![], boolean: vec![], string: vec![] };
        for v in inst.fmu().description().variables.iter().filter(|v| v.causality == Causality::Output) {
            columns.push(format!("{name}.{}", v.name));
            match v.var_type {
                VarType::Real => o.real.push(v.value_reference),
                VarType::Integer => o.integer.push(v.value_reference),
                VarType::Boolean => o.boolean.push(v.value_reference),
                VarType::String => o.string.push(v.value_reference),
            }
        }
        outputs.push(o);
    }
    // the CSV columns follow the description order of each component's outputs
    let order: Vec<Vec<(VarType, usize)>> = c
        .units_mut()
        .instances()
        .map(|(_, inst)| {
            let mut counters = [0usize; 4];
            inst.fmu()
                .description()
                .variables
                .iter()
                .filter(|v| v.causality == Causality::Output)
                .map(|v| {
                    let slot = match v.var_type {
                        VarType::Real => 0,
                        VarType::Integer => 1,
                        VarType::Boolean => 2,
                        VarType::String => 3,
                    };
                    counters[slot] += 1;
                    (v.var_type, counters[slot] - 1)
                })
                .collect()
        })
        .collect();
    let part = csv.map(|p| {
        let mut name = p.file_name().unwrap_or_default().to_os_string();
        name.push(".part");
        p.with_file_name(name)
    });
    let mut file = match &part {
        Some(p) => Some(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: cannot create: {e}", p.display()))?,
        )),
        None => None,
    };
    if let Some(f) = file.as_mut() {
        writeln!(f, "{}", columns.iter().map(|c| csv_text(c)).collect::<Vec<_>>().join(","))?;
    }
    let mut buf = (Vec::new(), Vec::new(), Vec::new());
    let mut write_row = |c: &mut Coupled<FmuSystem>,
                         f: &mut Option<std::io::BufWriter<std::fs::File>>|
     -> Result<(), Box<dyn std::error::Error>> {
        let Some(f) = f.as_mut() else { return Ok(()) };
        write!(f, "{}", c.time())?;
        for (o, order) in outputs.iter().zip(&order) {
            let inst = c.units_mut().instances().nth(o.component).expect("a component").1;
            buf.0.resize(o.real.len(), 0.0);
            buf.1.resize(o.integer.len(), 0);
            buf.2.resize(o.boolean.len(), false);
            inst.get_real(&o.real, &mut buf.0)?;
            inst.get_integer(&o.integer, &mut buf.1)?;
            inst.get_boolean(&o.boolean, &mut buf.2)?;
            let strings = if o.string.is_empty() { Vec::new() } else { inst.get_string(&o.string)? };
            for (t, j) in order {
                match t {
                    VarType::Real => write!(f, ",{:e}", buf.0[*j])?,
                    VarType::Integer => write!(f, ",{}", buf.1[*j])?,
                    VarType::Boolean => write!(f, ",{}", u8::from(buf.2[*j]))?,
                    VarType::String => write!(f, ",{}", csv_text(&strings[*j]))?,
                }
            }
        }
        writeln!(f)?;
        Ok(())
    };
    write_row(&mut c, &mut file)?;
    let mut run = SystemRun { t_end, columns, h_min_used: f64::INFINITY, ..Default::default() };
    let mut iterations = 0usize;
    let fixed_steps = (t_end / dt).round() as usize;
    let mut bar = Progress::stderr(fixed_steps as u64, t_end, quiet);
    let mut controller = adaptive.map(|a| a.controller()).transpose()?;
    loop {
        let (done, k) = match &controller {
            Some(_) => (c.time() >= t_end * (1.0 - 1e-12), run.steps),
            None => (run.steps >= fixed_steps, run.steps),
        };
        if done {
            break;
        }
        let result = match (controller.as_mut(), adaptive) {
            (Some(ctl), Some(a)) => c.step_adaptive(ctl, a.tolerances, t_end).map(|s| {
                run.rejected_steps += s.rejected;
                run.h_min_used = run.h_min_used.min(s.h);
                run.h_max_used = run.h_max_used.max(s.h);
                s.report
            }),
            _ => c.step(dt).inspect(|_| {
                run.h_min_used = dt;
                run.h_max_used = dt;
            }),
        };
        match result {
            Ok(report) => {
                run.steps += 1;
                iterations += report.iterations;
                run.max_residual = run.max_residual.max(report.residual);
            }
            Err(e) if e.ended().is_some() => {
                let (unit, why) = e.ended().expect("checked");
                run.stopped_early = Some((c.time(), format!("component `{unit}` {why}")));
                break;
            }
            Err(e) => return Err(e.into()),
        }
        write_row(&mut c, &mut file)?;
        bar.update((k + 1).min(fixed_steps) as u64, c.time());
    }
    bar.finish();
    if let (Some(mut f), Some(part), Some(csv)) = (file, part, csv) {
        f.flush()?;
        drop(f);
        std::fs::rename(&part, csv)
            .map_err(|e| format!("{}: cannot rename to {}: {e}", part.display(), csv.display()))?;
    }
    run.mean_iterations = if run.steps == 0 { 0.0 } else { iterations as f64 / run.steps as f64 };
    if run.steps == 0 {
        run.h_min_used = 0.0;
    }
    // after an early stop a component may refuse fmi2Terminate; the run is over either way
    let terminated = c.units_mut().terminate();
    if run.stopped_early.is_none() {
        terminated?;
    }
    run.wall_time_s = start.elapsed().as_secs_f64();
    Ok(run)
}

/// A CSV field, quoted when it must be.
fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}
