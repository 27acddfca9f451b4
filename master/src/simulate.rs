//! One run of the LT50m system with a chosen method, recorded as a [`Trace`]: the cabin-centre
//! displacement and rotation from the static equilibrium and the Stewart wrench, sampled at the
//! scene's output interval, and a [`Summary`] (peaks, iterations, residuals) taken at every
//! step. Methods: the monolithic eq. (7) model, a co-simulation scheme on the FMUs, the
//! decoupled model of the paper's ref. \[3\] (the Stewart FMU with its cabin held at the static
//! pose, its wrench applied to the cable FMU), or the cable–cabin model alone.
//!
//! A run is checked whole before its first step ([`Run::prepare`]): the steps reach the end
//! time exactly (fixed steps) or land on it (the adaptive step of a co-simulation), their number
//! is capped, the memory the models need fits, the scene has what the method needs. Every
//! method steps through the one loop of [`crate::stepping`]; any non-finite value seen while
//! stepping stops the run with the time and the quantity.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use feedcore::Vec3;
use feedcore::scene::{LEGS, Quantity, Scene, SensorKind, StewartMode};
use stewart::{Compensation, Stewart};

use cosim::{Coupled, FmuSystem, Options, Scheme, StepError};

use crate::feed::{FeedSample, FeedTrace};
use crate::limits::{Footprint, Limits, Plan, PlanError, Schedule, check_memory};
use crate::monolithic::{Monolithic, MonolithicError};
use crate::stepping::{Flow, Request, Step, drive};
use crate::system::{Adaptive, needs, scene_spec};
use cable::dynamics::DynamicsError;
use cosim::error_estimate::ErrorEstimate;
use feedcore::genalpha::StepError as IntegratorError;

/// How the system is solved.
#[derive(Clone, Debug, PartialEq)]
pub enum Method {
    /// The cable–cabin model alone (platform locked or absent) under the scene's disturbance;
    /// in-process, no FMU.
    CableOnly,
    Monolithic,
    /// The monolithic model with the adaptive step.
    MonolithicAdaptive(Adaptive),
    Cosim(Options),
    /// A co-simulation with the adaptive macro step (schemes that iterate).
    CosimAdaptive(Options, Adaptive),
    Decoupled(Options),
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::CableOnly => "cable",
            Method::Monolithic | Method::MonolithicAdaptive(_) => "monolithic",
            Method::Cosim(o) | Method::CosimAdaptive(o, _) => o.scheme.name(),
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
    /// Ctrl-C: the run stopped after the step in hand.
    #[error("the {method} run was interrupted at t = {time:.6} s (Ctrl-C)")]
    Interrupted { method: &'static str, time: f64 },
    /// The results could not be written.
    #[error("writing the results of the {method} run")]
    Output {
        method: &'static str,
        #[source]
        source: std::io::Error,
    },
}

impl RunError {
    /// A co-simulation step that failed: its time, and its message without the time it
    /// starts with.
    pub fn stopped_by(method: &'static str, e: &StepError) -> RunError {
        let text = e.to_string();
        let prefix = format!("co-simulation stopped at t = {:.6} s: ", e.time());
        let reason = text.strip_prefix(&prefix).map_or(text.clone(), str::to_string);
        RunError::Stopped { method, time: e.time(), reason }
    }

    /// A system that could not be set up.
    pub fn setup(method: &'static str, e: &(dyn std::error::Error + 'static)) -> RunError {
        RunError::Setup { method, source: Detached::of(e) }
    }
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
    /// Tries of the adaptive step rejected (and rolled back), and the smallest and largest
    /// step taken (the fixed step otherwise), s.
    pub rejected_steps: u64,
    pub h_min_used: f64,
    pub h_max_used: f64,
}

/// Time histories of one run, sampled at the scene's output interval (an adaptive run: at every
/// accepted step), and its summary.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub method: String,
    /// The fixed step, s (0 for an adaptive run: see `h`).
    pub dt: f64,
    pub t_end: f64,
    pub steps: u64,
    /// Interval of the samples actually taken (a whole number of steps), s; 0 for an adaptive
    /// run.
    pub sample_interval_s: f64,
    pub t: Vec<f64>,
    /// An adaptive run: the step that ended at each sample (0 for the start); empty otherwise.
    pub h: Vec<f64>,
    /// Cabin-centre displacement from the static equilibrium, mm (world x, y, z).
    pub disp_mm: Vec<[f64; 3]>,
    /// Cabin rotation from the static orientation, world rotation vector, mrad.
    pub rot_mrad: Vec<[f64; 3]>,
    /// What the Stewart platform exerts on the cabin (force N; moment about the centre point
    /// N·m); zero unless the scene asks for the wrench or the method prescribes it.
    pub wrench: Vec<[f64; 6]>,
    /// The feed, legs and limits (scenes with `[control]`).
    pub feed: Option<FeedTrace>,
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

    /// Whether the steps were chosen by the adaptive step.
    pub fn is_adaptive(&self) -> bool {
        !self.h.is_empty()
    }

    /// Largest and RMS distance (mm) of the cabin centre from another run's at this run's
    /// sample times within the other's span (the other run interpolated linearly between its
    /// samples: sample it at least as finely).
    pub fn error_against(&self, reference: &Trace) -> (f64, f64) {
        let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
        let mut j = 0;
        for i in 0..self.t.len() {
            let t = self.t[i];
            while j + 1 < reference.t.len() && reference.t[j + 1] <= t + 1e-9 {
                j += 1;
            }
            if reference.t.is_empty() || t > reference.t[reference.t.len() - 1] + 1e-9 {
                break;
            }
            let r = if (reference.t[j] - t).abs() <= 1e-9 || j + 1 == reference.t.len() {
                reference.disp_mm[j]
            } else {
                let w = (t - reference.t[j]) / (reference.t[j + 1] - reference.t[j]);
                let (a, b) = (reference.disp_mm[j], reference.disp_mm[j + 1]);
                [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])]
            };
            let d: f64 = (0..3).map(|k| (self.disp_mm[i][k] - r[k]).powi(2)).sum::<f64>().sqrt();
            max = max.max(d);
            sum += d * d;
            n += 1;
        }
        (max, (sum / n.max(1) as f64).sqrt())
    }

    /// Writes the time histories the scene asks for (`outputs.quantities`): `t` (and `h_s`, the
    /// step that ended there, in an adaptive run), then `dx_mm, dy_mm, dz_mm` (cabin
    /// displacement), `rx_mrad, ry_mrad, rz_mrad` (rotation), `fx_n … mz_nm` (Stewart wrench),
    /// each group only if asked for.
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
        if self.is_adaptive() {
            write!(f, ",h_s")?;
        }
        for g in &chosen {
            write!(f, ",{}", g.1)?;
        }
        if self.feed.is_some() {
            write!(f, ",{}", crate::feed::csv_header())?;
        }
        writeln!(f)?;
        for i in 0..self.t.len() {
            write!(f, "{}", self.t[i])?;
            if self.is_adaptive() {
                write!(f, ",{}", self.h[i])?;
            }
            for g in &chosen {
                for x in (g.2)(i) {
                    write!(f, ",{x:e}")?;
                }
            }
            if let Some(feed) = &self.feed {
                feed.write_row(&mut f, i)?;
            }
            writeln!(f)?;
        }
        f.flush()
    }
}

/// The cabin pose and the wrench now (and the feed, with `[control]`).
struct Probe {
    position: Vec3,
    orientation: feedcore::Quat,
    wrench: [f64; 6],
    feed: Option<FeedSample>,
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
        if crate::interrupt::interrupted() {
            return Err(RunError::Interrupted { method: self.method, time: t });
        }
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
        if let (Some(trace), Some(sample)) = (self.trace.feed.as_mut(), p.feed.as_ref()) {
            let names = ["x", "y", "z"];
            if let Some(i) = sample.err_mm.iter().position(|x| !x.is_finite()) {
                return Err(self.stopped(t, format!("the feed error {} is {}", names[i], sample.err_mm[i])));
            }
            trace.observe(t, sample, k.is_multiple_of(self.every));
            let rms = trace.summary.rms_mm;
            if !rms.is_finite() {
                return Err(self.stopped(t, format!("the feed error's RMS is {rms} mm")));
            }
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
}

/// Value references of the probed FMU variables.
struct CosimProbe {
    r: [u32; 3],
    q: [u32; 4],
    w: [u32; 6],
    /// Read the wrench only when the scene asks for it.
    read_wrench: bool,
    /// With `[control]`: the Stewart FMU's platform position and cabin inputs (r, q), leg
    /// lengths and actuator forces, and the compensation that places the feed.
    feed: Option<(Vec<u32>, Compensation)>,
}

impl CosimProbe {
    fn new(c: &mut Coupled<FmuSystem>, read_wrench: bool) -> Result<CosimProbe, Box<dyn std::error::Error>> {
        let mut vr = |fmu: &str, name: &str| -> Result<u32, Box<dyn std::error::Error>> {
            let inst = c.units_mut().instance(fmu).ok_or_else(|| format!("the system has no FMU named `{fmu}`"))?;
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
            feed: None,
        })
    }

    /// Also reads the feed (scenes with `[control]`).
    fn with_feed(mut self, c: &mut Coupled<FmuSystem>, comp: Compensation) -> Result<Self, Box<dyn std::error::Error>> {
        let inst = c.units_mut().instance("stewart").ok_or("the system has no FMU named `stewart`")?;
        let mut names: Vec<String> = (1..=3).map(|i| format!("platform.r[{i}]")).collect();
        names.extend((1..=3).map(|i| format!("cabin.r[{i}]")));
        names.extend((1..=4).map(|i| format!("cabin.q[{i}]")));
        names.extend((1..=LEGS).map(|i| format!("leg.length[{i}]")));
        names.extend((1..=LEGS).map(|i| format!("actuator.force[{i}]")));
        let vrs = names.iter().map(|n| inst.fmu().value_reference(n)).collect::<Result<Vec<_>, _>>()?;
        self.feed = Some((vrs, comp));
        Ok(self)
    }

    fn read(&self, c: &mut Coupled<FmuSystem>) -> Result<Probe, fmi2::import::Error> {
        let (mut r, mut q, mut w) = ([0.0; 3], [0.0; 4], [0.0; 6]);
        let cable = c.units_mut().instance("cable").expect("checked in new");
        cable.get_real(&self.r, &mut r)?;
        cable.get_real(&self.q, &mut q)?;
        if self.read_wrench {
            c.units_mut().instance("stewart").expect("checked in new").get_real(&self.w, &mut w)?;
        }
        let position = Vec3::from(r);
        // a non-finite quaternion normalizes to NaN, which the recorder refuses
        let orientation = feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let feed = match &self.feed {
            Some((vrs, comp)) => {
                let mut v = [0.0; 22];
                c.units_mut().instance("stewart").expect("checked in new").get_real(vrs, &mut v)?;
                // the platform relative to the cabin the Stewart FMU saw, placed on the cabin
                // of the cable model (the same one at convergence)
                let seen = feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(v[6], v[7], v[8], v[9]));
                let relative =
                    seen.inverse_transform_vector(&(Vec3::new(v[0], v[1], v[2]) - Vec3::new(v[3], v[4], v[5])));
                let six = |i: usize| std::array::from_fn(|k| v[i + k]);
                let now = c.time();
                Some(FeedSample::place(comp, now, (&position, &orientation), &relative, six(10), six(16)))
            }
            None => None,
        };
        Ok(Probe { position, orientation, wrench: w, feed })
    }
}

/// A run checked whole, ready to start.
#[derive(Clone, Debug)]
pub struct Run<'a> {
    scene: &'a Scene,
    scene_file: &'a Path,
    method: Method,
    schedule: Schedule,
    every: u64,
}

impl<'a> Run<'a> {
    /// Checks everything the run needs before anything is built: the steps against the end time
    /// and the step cap, the memory the models need, and what the method needs from the scene.
    /// `dt` is the fixed step; an adaptive run ([`Method::CosimAdaptive`]) chooses its own.
    pub fn prepare(
        scene: &'a Scene,
        scene_file: &'a Path,
        method: Method,
        dt: f64,
        t_end: f64,
        limits: &Limits,
    ) -> Result<Run<'a>, RunError> {
        let name = method.name();
        let refused = |reason: String| RunError::Refused { method: name, reason };
        let schedule = match &method {
            Method::CosimAdaptive(o, a) => {
                if !o.scheme.is_implicit() {
                    return Err(refused(format!(
                        "the adaptive step needs a scheme that iterates (iterative, ijcsa, iqn-ils), not {}",
                        o.scheme.name()
                    )));
                }
                a.controller().map_err(refused)?;
                Schedule::adaptive(t_end, a.h_min, a.h_max, limits).map_err(|e| refused(e.to_string()))?
            }
            Method::MonolithicAdaptive(a) => {
                a.controller().map_err(refused)?;
                Schedule::adaptive(t_end, a.h_min, a.h_max, limits).map_err(|e| refused(e.to_string()))?
            }
            _ => Schedule::Fixed(Plan::new(dt, t_end, limits).map_err(|e| refused(e.to_string()))?),
        };
        let footprint = if matches!(method, Method::CableOnly) { Footprint::CableModel } else { Footprint::Coupled };
        check_memory(scene, footprint, cable::model::CableCabin::modes_built(scene, 0), limits)
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
            Method::Decoupled(_) if scene.control.as_ref().is_some_and(|c| c.sensor != SensorKind::Off) => {
                return Err(refused(format!(
                    "{}: the scene's [control] compensates the cabin (sensor = {:?}), which the decoupled model \
                     does not have: run it with a coupling scheme (ijcsa, iqn-ils, ...) or monolithic, or set \
                     control.sensor = \"off\" for the uncompensated feed",
                    scene_file.display(),
                    scene.control.as_ref().map(|c| c.sensor).expect("matched"),
                )));
            }
            Method::Monolithic | Method::MonolithicAdaptive(_)
                if scene.control.as_ref().is_some_and(|c| c.sensor == SensorKind::Ideal) =>
            {
                return Err(refused(format!(
                    "{}: [control] sensor = \"ideal\" makes the legs' strokes follow the cabin's velocity and \
                     acceleration at the step's end, which the monolithic model's position-level driving \
                     constraints cannot express (it would need another formulation): use sensor = \"sampled\", \
                     or a coupling scheme (ijcsa, iqn-ils, ...) for the ideal sensor",
                    scene_file.display(),
                )));
            }
            Method::MonolithicAdaptive(a)
                if scene.control.as_ref().and_then(|c| c.sample_period()).is_some_and(|t| a.h_max > 0.25 * t) =>
            {
                let period = scene.control.as_ref().and_then(|c| c.sample_period()).expect("matched");
                return Err(refused(format!(
                    "{}: --h-max {} s is longer than a quarter of the sensor's sample period {period} s ([control] \
                     sample_rate_hz): a sample is taken at the first step start after its instant; set --h-max to \
                     at most {} s",
                    scene_file.display(),
                    a.h_max,
                    0.25 * period
                )));
            }
            Method::Monolithic | Method::MonolithicAdaptive(_) => {}
            _ if !scene.analyses.wrench.is_full() => {
                return Err(refused(format!(
                    "{}: `analyses.wrench = \"inertial_only\"` (a hypothesis for the paper's amplitudes) is \
                     implemented in the monolithic model only; run it with `--scheme monolithic`",
                    scene_file.display()
                )));
            }
            Method::Cosim(_) | Method::CosimAdaptive(..) | Method::Decoupled(_) => {
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
        let every = match schedule {
            Schedule::Fixed(plan) => ((scene.outputs.sample_interval_s / plan.dt).round() as u64).clamp(1, plan.steps),
            // every accepted step
            Schedule::Adaptive { .. } => 1,
        };
        Ok(Run { scene, scene_file, method, schedule, every })
    }

    /// Runs it; `quiet`: no progress bar.
    pub fn execute(&self, quiet: bool) -> Result<Trace, RunError> {
        let (scene, method) = (self.scene, self.method.clone());
        let name = method.name();
        let (dt, sample_interval_s) = match self.schedule {
            Schedule::Fixed(plan) => (plan.dt, self.every as f64 * plan.dt),
            Schedule::Adaptive { .. } => (0.0, 0.0),
        };
        let mut rec = Recorder {
            trace: Trace {
                method: name.into(),
                dt,
                t_end: self.schedule.t_end(),
                sample_interval_s,
                ..Default::default()
            },
            every: self.every,
            origin: None,
            method: name,
        };
        let setup = |e: &(dyn std::error::Error + 'static)| RunError::setup(name, e);
        // the feed (scenes with [control]): placed by the scene's compensation
        let comp = match &scene.control {
            Some(_) if method != Method::CableOnly => {
                Stewart::from_scene(scene).map_err(|e| setup(&e))?.compensation().cloned()
            }
            _ => None,
        };
        rec.trace.feed = comp.as_ref().map(FeedTrace::new);
        let start = Instant::now();
        let stopped = |time: f64, reason: String| RunError::Stopped { method: name, time, reason };
        // the fixed step of the methods without an adaptive one (prepare gives them no other)
        let fixed = |r: Request| match r {
            Request::Fixed { h, t } => Ok((h, t)),
            Request::Adaptive { .. } => {
                Err(RunError::Refused { method: name, reason: "this method has no adaptive step".into() })
            }
        };
        match method {
            Method::CableOnly => {
                let model = cable::model::CableCabin::build(scene, 0).map_err(|e| setup(&e))?;
                let disturbance =
                    |t: f64| nalgebra::Vector6::from(scene.disturbance.as_ref().map_or([0.0; 6], |d| d.wrench(t)));
                let mut dy = model
                    .dynamics_with(cable::model::Payload::Locked, 0.0, &disturbance(0.0))
                    .map_err(|e| setup(&e))?;
                let probe = |dy: &cable::dynamics::Dynamics, t: f64| {
                    let c = dy.cabin();
                    Probe {
                        position: c.position,
                        orientation: c.orientation,
                        wrench: vec6(&disturbance(t)),
                        feed: None,
                    }
                };
                let first = probe(&dy, 0.0);
                self.drive(&mut rec, quiet, first, |r| {
                    let (h, t) = fixed(r)?;
                    let s = dy.step(h, &disturbance(t)).map_err(|e| match e {
                        DynamicsError::Stopped { time, reason } => stopped(time, reason.to_string()),
                        e => stopped(e.time().unwrap_or(t - h), e.to_string()),
                    })?;
                    Ok(Flow::Stepped(stepped(h, s.iterations, 0.0, probe(&dy, t))))
                })?;
            }
            Method::Monolithic | Method::MonolithicAdaptive(_) => {
                let mut m = AdaptiveMonolithic::new(Monolithic::new(scene).map_err(|e| setup(&e))?);
                let mut adaptive = match method {
                    Method::MonolithicAdaptive(a) => {
                        let ctl = a.controller().map_err(|reason| RunError::Refused { method: name, reason })?;
                        Some((ctl, a.tolerances, ErrorEstimate::of_kind(a.estimate, WATCHED)))
                    }
                    _ => None,
                };
                let probe = |s: &crate::monolithic::Sample| Probe {
                    position: s.cabin.position,
                    orientation: s.cabin.orientation,
                    wrench: vec6(&s.wrench),
                    feed: comp.as_ref().map(|c| {
                        let cabin = (&s.cabin.position, &s.cabin.orientation);
                        FeedSample::place(c, s.time, cabin, &s.platform, s.leg_lengths, s.actuator_forces)
                    }),
                };
                let first = probe(&m.model.sample());
                let failed = |e: MonolithicError, t: f64| match e {
                    MonolithicError::Stopped { time, reason } => stopped(time, reason.to_string()),
                    e => stopped(e.time().unwrap_or(t), e.to_string()),
                };
                self.drive(&mut rec, quiet, first, |r| {
                    let (h, iterations, rejected) = match (r, adaptive.as_mut()) {
                        (Request::Adaptive { t_stop }, Some((ctl, tol, estimate))) => {
                            let t = m.model.time();
                            let a = cosim::adaptive::step(&mut m, estimate, ctl, *tol, t, t_stop)
                                .map_err(|e| failed(e, t))?;
                            (a.h, a.report.iterations, a.rejected)
                        }
                        _ => {
                            let (h, t) = fixed(r)?;
                            (h, m.model.step(h).map_err(|e| failed(e, t - h))?.iterations, 0)
                        }
                    };
                    let s = m.model.sample();
                    let mut step = stepped(h, iterations, 0.0, probe(&s));
                    step.payload.constraint_residual = s.constraint_residual;
                    step.rejected = rejected;
                    Ok(Flow::Stepped(step))
                })?;
            }
            Method::Cosim(options) | Method::CosimAdaptive(options, _) | Method::Decoupled(options) => {
                let mut sc = scene.clone();
                let mut options = options;
                if matches!(method, Method::Decoupled(_)) {
                    // ref. [3]: the platform's wrench with the cabin held at its static pose, fed
                    // forward to the cable model: cut the connections into the Stewart FMU
                    let sys = sc.system.as_mut().expect("checked in prepare");
                    sys.connections.retain(|c| !c.to.starts_with("stewart."));
                    options.scheme = Scheme::Sequential;
                }
                let adaptive = match &method {
                    Method::CosimAdaptive(_, a) => Some(a),
                    _ => None,
                };
                let mut spec = scene_spec(&sc, self.scene_file).map_err(|e| setup(&e))?;
                // outputs named to be watched are read after every step too
                spec.observed = adaptive.map(|a| a.watch.clone()).unwrap_or_default();
                let system = FmuSystem::load(&spec, &needs(&options, adaptive.is_some())).map_err(|e| setup(&e))?;
                let mut c = Coupled::new(system, options).map_err(|e| setup(&e))?;
                if let Some(a) = &adaptive {
                    let pose = || CABIN_POSE.map(String::from).to_vec();
                    let watch = if a.watch.is_empty() { pose() } else { a.watch.clone() };
                    c.watch(&watch).map_err(|e| RunError::Refused { method: name, reason: format!("--watch: {e}") })?;
                    c.estimate_by(a.estimate);
                }
                let tolerances = adaptive.map(|a| a.tolerances);
                let mut controller = adaptive
                    .map(|a| a.controller())
                    .transpose()
                    .map_err(|reason| RunError::Refused { method: name, reason })?;
                let read_wrench = scene.outputs.quantities.contains(&Quantity::Wrench);
                let mut probe = CosimProbe::new(&mut c, read_wrench).map_err(|e| setup(&*e))?;
                if let Some(comp) = comp.clone() {
                    probe = probe.with_feed(&mut c, comp).map_err(|e| setup(&*e))?;
                }
                let first = probe.read(&mut c).map_err(|e| stopped(0.0, e.to_string()))?;
                self.drive(&mut rec, quiet, first, |r| {
                    let (h, report, rejected) = match (r, controller.as_mut(), tolerances) {
                        (Request::Adaptive { t_stop }, Some(ctl), Some(tol)) => {
                            let s = c.step_adaptive(ctl, tol, t_stop).map_err(|e| RunError::stopped_by(name, &e))?;
                            (s.h, s.report, s.rejected)
                        }
                        _ => {
                            let (h, _) = fixed(r)?;
                            // a motion that starts at full speed is a kink the FMUs were not
                            // initialized for: the first step in substeps
                            let kink = spec.kink_at_start && c.time() == 0.0;
                            let report = if kink { c.step_from_start(h) } else { c.step(h) };
                            (h, report.map_err(|e| RunError::stopped_by(name, &e))?, 0)
                        }
                    };
                    let t = c.time();
                    let p = probe.read(&mut c).map_err(|e| stopped(t, e.to_string()))?;
                    let mut step = stepped(h, report.iterations, report.residual, p);
                    step.rejected = rejected;
                    Ok(Flow::Stepped(step))
                })?;
            }
        }
        rec.trace.wall_time_s = start.elapsed().as_secs_f64();
        Ok(rec.trace)
    }
}

/// Quantities the monolithic model's adaptive step watches: the cabin's position and
/// orientation (quaternion), the displacement the results are judged by. Not its velocities,
/// accelerations or the platform's wrench, as the co-simulation's interface does: in the index-3
/// model they carry a step-to-step oscillation of the multipliers that decays only by ρ∞ per
/// step, whose third differences the estimate reads as error (measured at C: with them the
/// steps stay at 1e-5…1e-4 s and the run reached the step cap at 10 s).
const WATCHED: usize = 7;

/// What a co-simulation of a scene watches by default: the cabin's pose as the Stewart FMU
/// receives it, as the monolithic model watches its own (so both are judged alike).
pub const CABIN_POSE: [&str; 2] = ["stewart.cabin.r", "stewart.cabin.q"];

/// The monolithic model as a stepper that can undo a step (for the adaptive step): a snapshot
/// before every step. The state is restored exactly; the kept factorization only steers Newton,
/// so a retaken step agrees with a first take to the Newton tolerance.
struct AdaptiveMonolithic {
    model: Monolithic,
    before: crate::monolithic::Snapshot,
    /// The state at the last checkpoint (step doubling goes back over two steps).
    checkpoint: crate::monolithic::Snapshot,
    group: Vec<usize>,
    scale: Vec<f64>,
}

impl AdaptiveMonolithic {
    fn new(mut model: Monolithic) -> AdaptiveMonolithic {
        let before = model.snapshot();
        let group: Vec<usize> = [3, 4].iter().enumerate().flat_map(|(g, &n)| [g].repeat(n)).collect();
        let mut start = [0.0; WATCHED];
        watched_of(&model.sample(), &mut start);
        let scale = cosim::Layout::group_scales(&start, &group);
        let checkpoint = model.snapshot();
        AdaptiveMonolithic { model, before, checkpoint, group, scale }
    }
}

fn watched_of(s: &crate::monolithic::Sample, out: &mut [f64]) {
    let c = &s.cabin;
    let q = c.orientation.quaternion();
    let parts: [&[f64]; 2] = [c.position.as_slice(), &[q.w, q.i, q.j, q.k]];
    for (o, v) in out.iter_mut().zip(parts.into_iter().flatten()) {
        *o = *v;
    }
}

impl cosim::adaptive::Retake for AdaptiveMonolithic {
    type Report = feedcore::genalpha::StepReport;
    type Error = MonolithicError;

    fn try_step(&mut self, h: f64) -> Result<Option<Self::Report>, MonolithicError> {
        self.model.save(&mut self.before);
        match self.model.step(h) {
            Ok(r) => Ok(Some(r)),
            // Newton failed even after halving, or settled on a wrong solution: retry smaller
            Err(MonolithicError::Stopped {
                reason: IntegratorError::NotConverged { .. } | IntegratorError::ConstraintResidual { .. },
                ..
            }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    fn undo(&mut self, _t: f64) -> Result<(), MonolithicError> {
        self.model.restore(&self.before);
        Ok(())
    }

    fn checkpoint(&mut self) -> Result<(), MonolithicError> {
        self.model.save(&mut self.checkpoint);
        Ok(())
    }

    fn back_to_checkpoint(&mut self) -> Result<(), MonolithicError> {
        self.model.restore(&self.checkpoint);
        Ok(())
    }

    fn then(first: Self::Report, next: Self::Report) -> Self::Report {
        first.then(next)
    }

    fn watched(&mut self, out: &mut [f64]) -> Result<(), MonolithicError> {
        watched_of(&self.model.sample(), out);
        Ok(())
    }

    fn groups(&self) -> (&[usize], &[f64]) {
        (&self.group, &self.scale)
    }

    /// Newton converges the configuration far below what the estimate can see.
    fn noise(&self, out: &mut [f64]) {
        out.fill(0.0);
    }

    fn too_small(&self, t: f64, error: f64, h_min: f64) -> MonolithicError {
        MonolithicError::StepTooSmall { time: t, error, h_min }
    }
}

/// What a step of a method leaves to observe.
struct Observed {
    probe: Probe,
    /// Largest position-constraint residual (monolithic), m.
    constraint_residual: f64,
}

/// A step of `h` with its cost and what it left.
fn stepped(h: f64, iterations: usize, residual: f64, probe: Probe) -> Step<Observed> {
    Step { h, rejected: 0, iterations, residual, payload: Observed { probe, constraint_residual: 0.0 } }
}

impl Run<'_> {
    /// Observes the start, then takes every step with `step` through the step loop, refusing
    /// non-finite values and keeping the summary.
    fn drive(
        &self,
        rec: &mut Recorder,
        quiet: bool,
        first: Probe,
        step: impl FnMut(Request) -> Result<Flow<Observed>, RunError>,
    ) -> Result<(), RunError> {
        let adaptive = matches!(self.schedule, Schedule::Adaptive { .. });
        rec.observe(0, 0.0, &first)?;
        if adaptive {
            rec.trace.h.push(0.0);
        }
        let method = rec.method;
        let totals = drive(
            &self.schedule,
            quiet,
            |time, reason| RunError::Stopped { method, time, reason },
            step,
            |k, t, s| {
                let c = s.payload.constraint_residual;
                if !c.is_finite() {
                    return Err(rec.stopped(t, format!("the constraint residual is {c}")));
                }
                let m = &mut rec.trace.summary.max_constraint_residual_m;
                *m = m.max(c);
                rec.observe(k, t, &s.payload.probe)?;
                if adaptive {
                    rec.trace.h.push(s.h);
                }
                Ok(())
            },
        )?;
        let summary = &mut rec.trace.summary;
        summary.steps = totals.steps;
        summary.iterations = totals.iterations;
        summary.max_interface_residual = totals.max_residual;
        summary.rejected_steps = totals.rejected;
        summary.h_min_used = totals.h_min;
        summary.h_max_used = totals.h_max;
        rec.trace.steps = totals.steps;
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

/// Where this process writes its scene variants.
fn variants_dir() -> std::path::PathBuf {
    std::env::temp_dir().join(format!("master-variants-{}", std::process::id()))
}

/// Removes the scene variants this process wrote (when its command ends, however it ends).
pub fn remove_variants() {
    let _ = std::fs::remove_dir_all(variants_dir());
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
    let dir = variants_dir();
    std::fs::create_dir_all(&dir)?;
    let file = dir.join(format!("{tag}.toml"));
    std::fs::write(&file, s.to_toml())?;
    Ok((s, file))
}
