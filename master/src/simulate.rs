//! One run of the LT50m system with a chosen method, recorded as a [`Trace`]: the cabin-centre
//! displacement and rotation from the static equilibrium and the Stewart wrench, sampled at the
//! scene's output interval, and a [`Summary`] (peaks, iterations, residuals) taken at every
//! step. Methods: the monolithic eq. (7) model, a co-simulation scheme on the FMUs, the
//! decoupled model of the paper's ref. \[3\] (the Stewart FMU with its cabin held at the static
//! pose, its wrench applied to the cable FMU), or the cable–cabin model alone.
//!
//! A run is checked whole before its first step ([`Run::prepare`]): the steps reach the end
//! time exactly, their number is capped, the memory the models need fits, the scene has what
//! the method needs. Any non-finite value seen while stepping stops the run with the time and
//! the quantity.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use feedcore::Vec3;
use feedcore::scene::{Quantity, Scene, StewartMode};

use crate::cosim::{CosimError, Coupled, Options, Scheme};
use crate::limits::{Footprint, Limits, Plan, PlanError, check_memory};
use crate::monolithic::{Monolithic, MonolithicError};
use crate::progress::Progress;

/// How the system is solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// The cable–cabin model alone (platform locked or absent) under the scene's disturbance;
    /// in-process, no FMU.
    CableOnly,
    Monolithic,
    Cosim(Options),
    Decoupled(Options),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::CableOnly => "cable",
            Method::Monolithic => "monolithic",
            Method::Cosim(o) => o.scheme.name(),
            Method::Decoupled(_) => "decoupled",
        }
    }
}

/// Why a run did not give a result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Refused before anything was built (steps, caps, memory, what the method needs).
    #[error("the {method} run cannot start: {reason}")]
    Refused { method: &'static str, reason: String },
    /// The model or the FMUs could not be set up (missing FMU, failed form-finding, ...).
    #[error("setting up the {method} run")]
    Setup {
        method: &'static str,
        #[source]
        source: Detached,
    },
    /// A step failed or gave a non-finite value.
    #[error("the {method} run stopped at t = {time:.6} s: {reason}")]
    Stopped { method: &'static str, time: f64, reason: String },
}

/// An error's message chain, kept as text so that it can cross threads (`Send + Sync`) whatever
/// the error it came from.
#[derive(Debug)]
pub struct Detached {
    message: String,
    source: Option<Box<Detached>>,
}

impl Detached {
    pub fn of(e: &(dyn std::error::Error + 'static)) -> Detached {
        Detached { message: e.to_string(), source: e.source().map(|s| Box::new(Detached::of(s))) }
    }
}

impl std::fmt::Display for Detached {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Detached {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source.as_deref().map(|s| s as _)
    }
}

/// Figures of a whole run, taken at every step (not from the samples).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Largest |displacement| of the cabin centre per world axis, mm.
    pub max_abs_disp_mm: [f64; 3],
    /// Largest distance of the cabin centre from its static position, mm, and when.
    pub peak_mm: f64,
    pub peak_time_s: f64,
    /// Steps taken and iterations (system evaluations, or Newton iterations) over all of them.
    pub steps: u64,
    pub iterations: u64,
    /// Largest scaled interface residual at the end of a step (co-simulation).
    pub max_interface_residual: f64,
    /// Largest position-constraint residual (monolithic), m.
    pub max_constraint_residual_m: f64,
}

/// Time histories of one run, sampled at the scene's output interval, and its summary.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub method: String,
    pub dt: f64,
    pub t_end: f64,
    pub steps: u64,
    /// Interval of the samples actually taken (a whole number of steps), s.
    pub sample_interval_s: f64,
    pub t: Vec<f64>,
    /// Cabin-centre displacement from the static equilibrium, mm (world x, y, z).
    pub disp_mm: Vec<[f64; 3]>,
    /// Cabin rotation from the static orientation, world rotation vector, mrad.
    pub rot_mrad: Vec<[f64; 3]>,
    /// What the Stewart platform exerts on the cabin (force N; moment about the centre point
    /// N·m); zero unless the scene asks for the wrench or the method prescribes it.
    pub wrench: Vec<[f64; 6]>,
    pub summary: Summary,
    pub wall_time_s: f64,
}

impl Trace {
    pub fn max_abs_disp_mm(&self) -> [f64; 3] {
        self.summary.max_abs_disp_mm
    }

    /// Largest distance of the cabin centre from its static position over every step, mm.
    pub fn peak_mm(&self) -> f64 {
        self.summary.peak_mm
    }

    pub fn mean_iterations(&self) -> f64 {
        if self.summary.steps == 0 { 0.0 } else { self.summary.iterations as f64 / self.summary.steps as f64 }
    }

    pub fn max_residual(&self) -> f64 {
        self.summary.max_interface_residual
    }

    pub fn constraint_residual(&self) -> f64 {
        self.summary.max_constraint_residual_m
    }

    /// Largest and RMS distance (mm) of the cabin centre from another run's at the common
    /// sample times (the traces must share their sampling).
    pub fn error_against(&self, reference: &Trace) -> (f64, f64) {
        let n = self.t.len().min(reference.t.len());
        let (mut max, mut sum) = (0.0f64, 0.0);
        for i in 0..n {
            debug_assert!((self.t[i] - reference.t[i]).abs() < 1e-9);
            let d: f64 = (0..3).map(|k| (self.disp_mm[i][k] - reference.disp_mm[i][k]).powi(2)).sum::<f64>().sqrt();
            max = max.max(d);
            sum += d * d;
        }
        (max, (sum / n.max(1) as f64).sqrt())
    }

    /// Writes the time histories the scene asks for (`outputs.quantities`): `t`, then
    /// `dx_mm, dy_mm, dz_mm` (cabin displacement), `rx_mrad, ry_mrad, rz_mrad` (rotation),
    /// `fx_n … mz_nm` (Stewart wrench), each group only if asked for.
    pub fn write_csv(&self, out: &mut dyn Write, quantities: &[Quantity]) -> std::io::Result<()> {
        type Column<'a> = &'a dyn Fn(usize) -> &'a [f64];
        let groups: [(Quantity, &str, Column); 3] = [
            (Quantity::CabinDisplacement, "dx_mm,dy_mm,dz_mm", &|i| &self.disp_mm[i]),
            (Quantity::CabinRotation, "rx_mrad,ry_mrad,rz_mrad", &|i| &self.rot_mrad[i]),
            (Quantity::Wrench, "fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm", &|i| &self.wrench[i]),
        ];
        let chosen: Vec<_> = groups.iter().filter(|g| quantities.contains(&g.0)).collect();
        let mut f = std::io::BufWriter::new(out);
        write!(f, "t")?;
        for g in &chosen {
            write!(f, ",{}", g.1)?;
        }
        writeln!(f)?;
        for i in 0..self.t.len() {
            write!(f, "{}", self.t[i])?;
            for g in &chosen {
                for x in (g.2)(i) {
                    write!(f, ",{x:e}")?;
                }
            }
            writeln!(f)?;
        }
        f.flush()
    }
}

/// The cabin pose and the wrench now.
struct Probe {
    position: Vec3,
    orientation: feedcore::Quat,
    wrench: [f64; 6],
}

/// Watches every step: refuses non-finite values, keeps the summary, samples every `every`
/// steps.
struct Recorder {
    trace: Trace,
    every: u64,
    origin: Option<(Vec3, feedcore::Quat)>,
    method: &'static str,
}

impl Recorder {
    fn stopped(&self, time: f64, reason: impl Into<String>) -> RunError {
        RunError::Stopped { method: self.method, time, reason: reason.into() }
    }

    /// The state after step `k` (0: the start) at time `t`.
    fn observe(&mut self, k: u64, t: f64, p: &Probe) -> Result<(), RunError> {
        let names = ["x", "y", "z"];
        for i in 0..3 {
            if !p.position[i].is_finite() {
                return Err(self.stopped(t, format!("the cabin position {} is {}", names[i], p.position[i])));
            }
        }
        if !p.orientation.coords.iter().all(|x| x.is_finite()) {
            return Err(self.stopped(t, "the cabin orientation is not finite"));
        }
        const WRENCH: [&str; 6] = ["Fx", "Fy", "Fz", "Mx", "My", "Mz"];
        if let Some(i) = p.wrench.iter().position(|x| !x.is_finite()) {
            return Err(self.stopped(t, format!("the wrench on the cabin {} is {}", WRENCH[i], p.wrench[i])));
        }
        let (p0, q0) = *self.origin.get_or_insert((p.position, p.orientation));
        let d = (p.position - p0) * 1e3;
        let s = &mut self.trace.summary;
        for i in 0..3 {
            s.max_abs_disp_mm[i] = s.max_abs_disp_mm[i].max(d[i].abs());
        }
        let distance = d.norm();
        if !distance.is_finite() {
            return Err(self.stopped(t, format!("the cabin displacement is {distance} mm")));
        }
        if distance > s.peak_mm {
            s.peak_mm = distance;
            s.peak_time_s = t;
        }
        if k.is_multiple_of(self.every) {
            let r = (p.orientation * q0.inverse()).scaled_axis() * 1e3;
            self.trace.t.push(t);
            self.trace.disp_mm.push([d.x, d.y, d.z]);
            self.trace.rot_mrad.push([r.x, r.y, r.z]);
            self.trace.wrench.push(p.wrench);
        }
        Ok(())
    }

    /// What step `k` (ending at `t`) cost.
    fn cost(&mut self, t: f64, iterations: usize, interface_residual: f64) -> Result<(), RunError> {
        if !interface_residual.is_finite() {
            return Err(self.stopped(t, format!("the interface residual is {interface_residual}")));
        }
        let s = &mut self.trace.summary;
        s.steps += 1;
        s.iterations += iterations as u64;
        s.max_interface_residual = s.max_interface_residual.max(interface_residual);
        Ok(())
    }
}

/// Value references of the probed FMU variables.
struct CosimProbe {
    r: [u32; 3],
    q: [u32; 4],
    w: [u32; 6],
    /// Read the wrench only when the scene asks for it.
    read_wrench: bool,
}

impl CosimProbe {
    fn new(c: &mut Coupled, read_wrench: bool) -> Result<CosimProbe, Box<dyn std::error::Error>> {
        let mut vr = |fmu: &str, name: &str| -> Result<u32, Box<dyn std::error::Error>> {
            let inst = c.instance(fmu).ok_or_else(|| format!("the system has no FMU named `{fmu}`"))?;
            Ok(inst.fmu().value_reference(name)?)
        };
        Ok(CosimProbe {
            r: [vr("cable", "cabin.r[1]")?, vr("cable", "cabin.r[2]")?, vr("cable", "cabin.r[3]")?],
            q: [
                vr("cable", "cabin.q[1]")?,
                vr("cable", "cabin.q[2]")?,
                vr("cable", "cabin.q[3]")?,
                vr("cable", "cabin.q[4]")?,
            ],
            w: [
                vr("stewart", "wrench.f[1]")?,
                vr("stewart", "wrench.f[2]")?,
                vr("stewart", "wrench.f[3]")?,
                vr("stewart", "wrench.m[1]")?,
                vr("stewart", "wrench.m[2]")?,
                vr("stewart", "wrench.m[3]")?,
            ],
            read_wrench,
        })
    }

    fn read(&self, c: &mut Coupled) -> Result<Probe, fmi2::import::Error> {
        let (mut r, mut q, mut w) = ([0.0; 3], [0.0; 4], [0.0; 6]);
        let cable = c.instance("cable").expect("checked in new");
        cable.get_real(&self.r, &mut r)?;
        cable.get_real(&self.q, &mut q)?;
        if self.read_wrench {
            c.instance("stewart").expect("checked in new").get_real(&self.w, &mut w)?;
        }
        Ok(Probe {
            position: Vec3::from(r),
            // a non-finite quaternion normalizes to NaN, which the recorder refuses
            orientation: feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3])),
            wrench: w,
        })
    }
}

/// A run checked whole, ready to start.
#[derive(Clone, Debug)]
pub struct Run<'a> {
    scene: &'a Scene,
    scene_file: &'a Path,
    method: Method,
    plan: Plan,
    every: u64,
}

impl<'a> Run<'a> {
    /// Checks everything the run needs before anything is built: the steps against the end time
    /// and the step cap, the memory the models need, and what the method needs from the scene.
    pub fn prepare(
        scene: &'a Scene,
        scene_file: &'a Path,
        method: Method,
        dt: f64,
        t_end: f64,
        limits: &Limits,
    ) -> Result<Run<'a>, RunError> {
        let refused = |reason: String| RunError::Refused { method: method.name(), reason };
        let plan = Plan::new(dt, t_end, limits).map_err(|e| refused(e.to_string()))?;
        let footprint = if method == Method::CableOnly { Footprint::CableModel } else { Footprint::Coupled };
        check_memory(scene, footprint, scene.damping.fit_modes.is_some(), limits)
            .map_err(|e: PlanError| refused(format!("{}: {e}", scene_file.display())))?;
        let coupled = scene.analyses.stewart == StewartMode::Coupled;
        match method {
            Method::CableOnly => {
                if scene.disturbance.is_none() && coupled {
                    return Err(refused(format!(
                        "{}: `--scheme cable` runs the cable–cabin model under the scene's [disturbance], and this \
                         scene has none (its platform is coupled: run it with a coupling scheme or monolithic)",
                        scene_file.display()
                    )));
                }
            }
            _ if !coupled => {
                return Err(refused(format!(
                    "{}: the scene has no moving platform (analyses.stewart = {:?}); only `--scheme cable` runs it",
                    scene_file.display(),
                    scene.analyses.stewart
                )));
            }
            Method::Monolithic => {}
            Method::Cosim(_) | Method::Decoupled(_) => {
                if scene.system.is_none() {
                    return Err(refused(format!(
                        "{}: the scene has no [system] section (the FMUs and their connections)",
                        scene_file.display()
                    )));
                }
                // The FMUs get the scene's path as an FMI string, which is UTF-8.
                let absolute =
                    std::fs::canonicalize(scene_file).map_err(|e| refused(format!("{}: {e}", scene_file.display())))?;
                if absolute.to_str().is_none() {
                    return Err(refused(format!(
                        "{}: the scene's path is not UTF-8, and the FMUs receive it as an FMI (UTF-8) string; \
                         rename the file or link it under a UTF-8 name",
                        scene_file.display()
                    )));
                }
            }
        }
        let every = ((scene.outputs.sample_interval_s / dt).round() as u64).clamp(1, plan.steps);
        Ok(Run { scene, scene_file, method, plan, every })
    }

    /// Runs it; `quiet`: no progress bar.
    pub fn execute(&self, quiet: bool) -> Result<Trace, RunError> {
        let (scene, plan, method) = (self.scene, self.plan, self.method);
        let name = method.name();
        let mut rec = Recorder {
            trace: Trace {
                method: name.into(),
                dt: plan.dt,
                t_end: plan.t_end,
                steps: plan.steps,
                sample_interval_s: self.every as f64 * plan.dt,
                ..Default::default()
            },
            every: self.every,
            origin: None,
            method: name,
        };
        let setup = |e: &(dyn std::error::Error + 'static)| RunError::Setup { method: name, source: Detached::of(e) };
        let bar = Progress::new(plan.steps, plan.dt, plan.t_end, quiet);
        let start = Instant::now();
        let stopped = |time: f64, reason: String| RunError::Stopped { method: name, time, reason };
        match method {
            Method::CableOnly => {
                let model = cable_fmu::model::CableCabin::build(scene, 0).map_err(|e| setup(&e))?;
                let disturbance =
                    |t: f64| nalgebra::Vector6::from(scene.disturbance.as_ref().map_or([0.0; 6], |d| d.wrench(t)));
                let mut dy = model
                    .dynamics_with(cable_fmu::model::Payload::Locked, 0.0, &disturbance(0.0))
                    .map_err(|e| setup(&e))?;
                let probe = |dy: &cable_fmu::dynamics::Dynamics, t: f64| {
                    let c = dy.cabin();
                    Probe { position: c.position, orientation: c.orientation, wrench: vec6(&disturbance(t)) }
                };
                let first = probe(&dy, 0.0);
                self.drive(&mut rec, &bar, first, |t| {
                    let s = dy.step(plan.dt, &disturbance(t)).map_err(|e| stopped(e.time, e.reason))?;
                    Ok(Stepped {
                        iterations: s.iterations,
                        interface_residual: 0.0,
                        constraint_residual: 0.0,
                        probe: probe(&dy, t),
                    })
                })?;
            }
            Method::Monolithic => {
                let mut m = Monolithic::new(scene).map_err(|e| setup(&*e))?;
                let probe = |s: &crate::monolithic::Sample| Probe {
                    position: s.cabin.position,
                    orientation: s.cabin.orientation,
                    wrench: vec6(&s.wrench),
                };
                let first = probe(&m.sample());
                self.drive(&mut rec, &bar, first, |_| {
                    let iterations = m.step(plan.dt).map_err(|e: MonolithicError| stopped(e.time, e.reason))?;
                    let s = m.sample();
                    Ok(Stepped {
                        iterations,
                        interface_residual: 0.0,
                        constraint_residual: s.constraint_residual,
                        probe: probe(&s),
                    })
                })?;
            }
            Method::Cosim(options) | Method::Decoupled(options) => {
                let mut sc = scene.clone();
                let mut options = options;
                if matches!(method, Method::Decoupled(_)) {
                    // ref. [3]: the platform's wrench with the cabin held at its static pose, fed
                    // forward to the cable model: cut the connections into the Stewart FMU
                    let sys = sc.system.as_mut().expect("checked in prepare");
                    sys.connections.retain(|c| !c.to.starts_with("stewart."));
                    options.scheme = Scheme::Sequential;
                }
                let mut c = Coupled::new(&sc, self.scene_file, options).map_err(|e| setup(&*e))?;
                let read_wrench = scene.outputs.quantities.contains(&Quantity::Wrench);
                let probe = CosimProbe::new(&mut c, read_wrench).map_err(|e| setup(&*e))?;
                let first = probe.read(&mut c).map_err(|e| stopped(0.0, e.to_string()))?;
                self.drive(&mut rec, &bar, first, |t| {
                    let report = c.step(plan.dt).map_err(|e: CosimError| stopped(e.time, e.reason))?;
                    Ok(Stepped {
                        iterations: report.iterations,
                        interface_residual: report.residual,
                        constraint_residual: 0.0,
                        probe: probe.read(&mut c).map_err(|e| stopped(t, e.to_string()))?,
                    })
                })?;
            }
        }
        bar.finish();
        rec.trace.wall_time_s = start.elapsed().as_secs_f64();
        Ok(rec.trace)
    }
}

/// What one step gave.
struct Stepped {
    iterations: usize,
    interface_residual: f64,
    constraint_residual: f64,
    probe: Probe,
}

impl Run<'_> {
    /// Observes the start, then takes every step with `step` (given the time at its end),
    /// refusing non-finite values and keeping the summary.
    fn drive(
        &self,
        rec: &mut Recorder,
        bar: &Progress,
        first: Probe,
        mut step: impl FnMut(f64) -> Result<Stepped, RunError>,
    ) -> Result<(), RunError> {
        rec.observe(0, 0.0, &first)?;
        for k in 1..=self.plan.steps {
            let t = self.plan.time(k);
            let s = step(t)?;
            rec.cost(t, s.iterations, s.interface_residual)?;
            if !s.constraint_residual.is_finite() {
                return Err(rec.stopped(t, format!("the constraint residual is {}", s.constraint_residual)));
            }
            let c = &mut rec.trace.summary.max_constraint_residual_m;
            *c = c.max(s.constraint_residual);
            rec.observe(k, t, &s.probe)?;
            bar.update(k);
        }
        Ok(())
    }
}

/// Runs `scene` (read from `scene_file`) with `method` at step `dt` to `t_end`, within the
/// default [`Limits`].
pub fn simulate(
    scene: &Scene,
    scene_file: &Path,
    method: Method,
    dt: f64,
    t_end: f64,
    quiet: bool,
) -> Result<Trace, RunError> {
    Run::prepare(scene, scene_file, method, dt, t_end, &Limits::default())?.execute(quiet)
}

fn vec6(v: &nalgebra::Vector6<f64>) -> [f64; 6] {
    [v[0], v[1], v[2], v[3], v[4], v[5]]
}

/// Writes `scene` (a variant of the one read from `scene_file`) to a private file, with the FMU
/// paths of its `[system]` made absolute, so that the FMUs read this variant; returns the variant
/// and its file.
pub fn write_variant(scene: &Scene, scene_file: &Path, tag: &str) -> std::io::Result<(Scene, std::path::PathBuf)> {
    let mut s = scene.clone();
    if let Some(sys) = s.system.as_mut() {
        let base = scene_file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        for f in &mut sys.fmus {
            let p = Path::new(&f.path);
            if !p.is_absolute() {
                f.path = std::fs::canonicalize(base)?.join(p).display().to_string();
            }
        }
    }
    let dir = std::env::temp_dir().join(format!("master-variants-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let file = dir.join(format!("{tag}.toml"));
    std::fs::write(&file, s.to_toml())?;
    Ok((s, file))
}
