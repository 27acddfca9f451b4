//! One run of the LT50m system with a chosen method, recorded as a [`Trace`]: the cabin-centre
//! displacement and rotation from the static equilibrium, the Stewart wrench, and what each step
//! cost. Methods: the monolithic eq. (7) model, a co-simulation scheme on the FMUs, or the
//! decoupled model of the paper's ref. [3] (the Stewart FMU with its cabin held at the static
//! pose, its wrench applied to the cable FMU).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use feedcore::Vec3;
use feedcore::scene::{Quantity, Scene};

use crate::cosim::{Coupled, Options};
use crate::monolithic::Monolithic;
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

/// Time histories of one run, sampled at the scene's output interval.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub method: String,
    pub dt: f64,
    pub t_end: f64,
    pub steps: usize,
    pub t: Vec<f64>,
    /// Cabin-centre displacement from the static equilibrium, mm (world x, y, z).
    pub disp_mm: Vec<[f64; 3]>,
    /// Cabin rotation from the static orientation, world rotation vector, mrad.
    pub rot_mrad: Vec<[f64; 3]>,
    /// What the Stewart platform exerts on the cabin (force N; moment about the centre point N·m).
    pub wrench: Vec<[f64; 6]>,
    /// Iterations (system evaluations) per macro step, and the interface residual at its end.
    pub iterations: Vec<usize>,
    pub residual: Vec<f64>,
    /// Largest position-constraint residual (monolithic only), m.
    pub constraint_residual: f64,
    pub wall_time_s: f64,
}

impl Trace {
    pub fn max_abs_disp_mm(&self) -> [f64; 3] {
        let mut m = [0.0f64; 3];
        for d in &self.disp_mm {
            for k in 0..3 {
                m[k] = m[k].max(d[k].abs());
            }
        }
        m
    }

    pub fn mean_iterations(&self) -> f64 {
        if self.iterations.is_empty() {
            0.0
        } else {
            self.iterations.iter().sum::<usize>() as f64 / self.iterations.len() as f64
        }
    }

    pub fn max_residual(&self) -> f64 {
        self.residual.iter().cloned().fold(0.0, f64::max)
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

    /// Largest distance of the cabin centre from its static position, mm.
    pub fn peak_mm(&self) -> f64 {
        self.disp_mm.iter().map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()).fold(0.0, f64::max)
    }

    /// Writes the time histories the scene asks for (`outputs.quantities`): `t`, then
    /// `dx_mm, dy_mm, dz_mm` (cabin displacement), `rx_mrad, ry_mrad, rz_mrad` (rotation),
    /// `fx_n … mz_nm` (Stewart wrench), each group only if asked for.
    pub fn write_csv(&self, path: &Path, quantities: &[Quantity]) -> std::io::Result<()> {
        type Column<'a> = &'a dyn Fn(usize) -> Vec<f64>;
        let groups: [(Quantity, &str, Column); 3] = [
            (Quantity::CabinDisplacement, "dx_mm,dy_mm,dz_mm", &|i| self.disp_mm[i].to_vec()),
            (Quantity::CabinRotation, "rx_mrad,ry_mrad,rz_mrad", &|i| self.rot_mrad[i].to_vec()),
            (Quantity::Wrench, "fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm", &|i| self.wrench[i].to_vec()),
        ];
        let chosen: Vec<_> = groups.iter().filter(|g| quantities.contains(&g.0)).collect();
        let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
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
        Ok(())
    }
}

/// The cabin pose and the wrench now.
struct Probe {
    position: Vec3,
    orientation: feedcore::Quat,
    wrench: [f64; 6],
}

/// Records a sample every `every` steps.
struct Recorder {
    trace: Trace,
    every: usize,
    origin: Option<(Vec3, feedcore::Quat)>,
}

impl Recorder {
    fn record(&mut self, t: f64, p: &Probe) {
        let (p0, q0) = *self.origin.get_or_insert((p.position, p.orientation));
        let d = (p.position - p0) * 1e3;
        let r = (p.orientation * q0.inverse()).scaled_axis() * 1e3;
        self.trace.t.push(t);
        self.trace.disp_mm.push([d.x, d.y, d.z]);
        self.trace.rot_mrad.push([r.x, r.y, r.z]);
        self.trace.wrench.push(p.wrench);
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
    fn new(c: &mut Coupled) -> Result<CosimProbe, Box<dyn std::error::Error>> {
        let vr = |c: &mut Coupled, fmu: &str, name: String| -> Result<u32, Box<dyn std::error::Error>> {
            let inst = c.instance(fmu).ok_or_else(|| format!("the system has no FMU named `{fmu}`"))?;
            Ok(inst.fmu().value_reference(&name)?)
        };
        Ok(CosimProbe {
            r: [
                vr(c, "cable", "cabin.r[1]".into())?,
                vr(c, "cable", "cabin.r[2]".into())?,
                vr(c, "cable", "cabin.r[3]".into())?,
            ],
            q: [
                vr(c, "cable", "cabin.q[1]".into())?,
                vr(c, "cable", "cabin.q[2]".into())?,
                vr(c, "cable", "cabin.q[3]".into())?,
                vr(c, "cable", "cabin.q[4]".into())?,
            ],
            w: [
                vr(c, "stewart", "wrench.f[1]".into())?,
                vr(c, "stewart", "wrench.f[2]".into())?,
                vr(c, "stewart", "wrench.f[3]".into())?,
                vr(c, "stewart", "wrench.m[1]".into())?,
                vr(c, "stewart", "wrench.m[2]".into())?,
                vr(c, "stewart", "wrench.m[3]".into())?,
            ],
            read_wrench: true,
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
            orientation: feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3])),
            wrench: w,
        })
    }
}

/// Runs `scene` (read from `scene_file`) with `method` at step `dt` to `t_end`.
pub fn simulate(
    scene: &Scene,
    scene_file: &Path,
    method: Method,
    dt: f64,
    t_end: f64,
    quiet: bool,
) -> Result<Trace, Box<dyn std::error::Error>> {
    if !(dt > 0.0 && dt.is_finite() && t_end > 0.0 && t_end.is_finite()) {
        return Err(format!("the step ({dt} s) and the end time ({t_end} s) must be positive").into());
    }
    let steps = (t_end / dt).round() as usize;
    let every = ((scene.outputs.sample_interval_s / dt).round() as usize).max(1);
    let mut rec = Recorder {
        trace: Trace { method: method.name().into(), dt, t_end, steps, ..Default::default() },
        every,
        origin: None,
    };
    let mut bar = Progress::stderr(steps as u64, t_end, quiet);
    let start = Instant::now();
    let coupled = scene.analyses.stewart == feedcore::scene::StewartMode::Coupled;
    if !coupled && method != Method::CableOnly {
        return Err(format!(
            "{}: the scene has no moving platform (analyses.stewart = {:?}); only `--scheme cable` runs it",
            scene_file.display(),
            scene.analyses.stewart
        )
        .into());
    }
    match method {
        Method::CableOnly => {
            let model = cable_fmu::model::CableCabin::build(scene, 0)?;
            let disturbance =
                |t: f64| nalgebra::Vector6::from(scene.disturbance.as_ref().map_or([0.0; 6], |d| d.wrench(t)));
            let mut dy = model.dynamics_with(cable_fmu::model::Payload::Locked, 0.0, &disturbance(0.0))?;
            let probe = |dy: &cable_fmu::dynamics::Dynamics, t: f64| {
                let c = dy.cabin();
                Probe { position: c.position, orientation: c.orientation, wrench: vec6(&disturbance(t)) }
            };
            rec.record(0.0, &probe(&dy, 0.0));
            for k in 1..=steps {
                let t = k as f64 * dt;
                let s = dy.step(dt, &disturbance(t))?;
                rec.trace.iterations.push(s.iterations);
                rec.trace.residual.push(0.0);
                if k % rec.every == 0 {
                    rec.record(t, &probe(&dy, t));
                }
                bar.update(k as u64, t);
            }
        }
        Method::Monolithic => {
            let mut m = Monolithic::new(scene)?;
            let s = m.sample();
            rec.record(
                0.0,
                &Probe { position: s.cabin.position, orientation: s.cabin.orientation, wrench: vec6(&s.wrench) },
            );
            for k in 1..=steps {
                let iterations = m.step(dt)?.iterations;
                rec.trace.iterations.push(iterations);
                rec.trace.residual.push(0.0);
                let s = m.sample();
                rec.trace.constraint_residual = rec.trace.constraint_residual.max(s.constraint_residual);
                if k % rec.every == 0 {
                    rec.record(
                        k as f64 * dt,
                        &Probe {
                            position: s.cabin.position,
                            orientation: s.cabin.orientation,
                            wrench: vec6(&s.wrench),
                        },
                    );
                }
                bar.update(k as u64, k as f64 * dt);
            }
        }
        Method::Cosim(options) | Method::Decoupled(options) => {
            let mut sc = scene.clone();
            let mut options = options;
            if matches!(method, Method::Decoupled(_)) {
                // ref. [3]: the platform's wrench with the cabin held at its static pose, fed
                // forward to the cable model: cut the connections into the Stewart FMU
                let sys = sc.system.as_mut().ok_or_else(|| format!("{}: no [system] section", scene_file.display()))?;
                sys.connections.retain(|c| !c.to.starts_with("stewart."));
                options.scheme = crate::cosim::Scheme::Sequential;
            }
            let mut c = Coupled::new(&sc, scene_file, options)?;
            let mut probe = CosimProbe::new(&mut c)?;
            probe.read_wrench = scene.outputs.quantities.contains(&Quantity::Wrench);
            rec.record(0.0, &probe.read(&mut c)?);
            for k in 1..=steps {
                let report = c.step(dt)?;
                rec.trace.iterations.push(report.iterations);
                rec.trace.residual.push(report.residual);
                if k % rec.every == 0 {
                    rec.record(k as f64 * dt, &probe.read(&mut c)?);
                }
                bar.update(k as u64, k as f64 * dt);
            }
        }
    }
    bar.finish();
    rec.trace.wall_time_s = start.elapsed().as_secs_f64();
    Ok(rec.trace)
}

fn vec6(v: &nalgebra::Vector6<f64>) -> [f64; 6] {
    [v[0], v[1], v[2], v[3], v[4], v[5]]
}

/// Writes `scene` (a variant of the one read from `scene_file`) to a private file, with the FMU
/// paths of its [system] made absolute, so that the FMUs read this variant; returns the variant
/// and its file.
pub fn write_variant(scene: &Scene, scene_file: &Path, tag: &str) -> std::io::Result<(Scene, std::path::PathBuf)> {
    let mut s = scene.clone();
    if let Some(sys) = s.system.as_mut() {
        let base = scene_file.parent().unwrap_or(Path::new("."));
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
