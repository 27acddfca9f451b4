//! A co-simulation of the scene's FMUs with a scheme (fixed or adaptive macro step), and the
//! decoupled model of ref. [3] on the same FMUs.

use std::path::Path;

use cosim::step_control::{Controller, Tolerances};
use cosim::{Coupled, FmuSystem, Options, Scheme};
use feedcore::Vec3;
use feedcore::scene::{LEGS, Quantity, Scene, ValidScene};
use stewart::Compensation;

use super::{Stepper, fixed, stopped};
use crate::feed::FeedSample;
use crate::simulate::RunError;
use crate::simulate::record::{Observed, Probe, stepped};
use crate::stepping::{Request, Step};
use crate::system::{Adaptive, needs, scene_spec};

/// What a co-simulation of a scene watches by default: the cabin's pose as the Stewart FMU
/// receives it, as the monolithic model watches its own (so both are judged alike).
pub const CABIN_POSE: [&str; 2] = ["stewart.cabin.r", "stewart.cabin.q"];

/// How the co-simulation is coupled.
pub(in crate::simulate) enum Coupling<'a> {
    /// A scheme with a fixed macro step.
    Fixed(Options),
    /// A scheme with the adaptive macro step.
    Adaptive(Options, &'a Adaptive),
    /// Ref. [3]: the platform's wrench with the cabin held at its static pose, fed forward to
    /// the cable model (the connections into the Stewart FMU cut).
    Decoupled(Options),
}

pub(in crate::simulate) struct CosimStepper {
    coupled: Coupled<FmuSystem>,
    probe: CosimProbe,
    /// The adaptive step's controller and tolerances (a fixed step: none).
    adaptive: Option<(Controller, Tolerances)>,
    /// A motion that starts at full speed: the first macro step is taken in substeps.
    kink_at_start: bool,
    method: &'static str,
}

impl CosimStepper {
    pub(in crate::simulate) fn new(
        scene: &ValidScene,
        scene_file: &Path,
        coupling: Coupling<'_>,
        compensation: Option<Compensation>,
        method: &'static str,
    ) -> Result<CosimStepper, RunError> {
        let setup = |e: &(dyn std::error::Error + 'static)| RunError::setup(method, e);
        let refused = |reason: String| RunError::Refused { method, reason };
        let mut sc = scene.clone();
        let (options, adaptive) = match coupling {
            Coupling::Fixed(o) => (o, None),
            Coupling::Adaptive(o, a) => (o, Some(a)),
            Coupling::Decoupled(mut o) => {
                if scene.system.is_none() {
                    return Err(refused("the scene has no [system]".into()));
                }
                let one_way = |s: &mut Scene| {
                    if let Some(sys) = s.system.as_mut() {
                        sys.connections.retain(|c| !c.to.starts_with("stewart."));
                    }
                };
                sc = scene.edited(one_way).map_err(|e| setup(&e))?;
                o.scheme = Scheme::Sequential;
                (o, None)
            }
        };
        let mut spec = scene_spec(&sc, scene_file).map_err(|e| setup(&e))?;
        // outputs named to be watched are read after every step too
        spec.observed = adaptive.map(|a| a.watch.clone()).unwrap_or_default();
        let system = FmuSystem::load(&spec, &needs(&options, adaptive.is_some())).map_err(|e| setup(&e))?;
        let mut c = Coupled::new(system, options).map_err(|e| setup(&e))?;
        if let Some(a) = &adaptive {
            let pose = || CABIN_POSE.map(String::from).to_vec();
            let watch = if a.watch.is_empty() { pose() } else { a.watch.clone() };
            c.watch(&watch).map_err(|e| refused(format!("--watch: {e}")))?;
            c.estimate_by(a.estimate);
        }
        let adaptive = match adaptive {
            Some(a) => Some((a.controller().map_err(refused)?, a.tolerances)),
            None => None,
        };
        let read_wrench = scene.outputs.quantities.contains(&Quantity::Wrench);
        let mut probe = CosimProbe::new(&mut c, read_wrench).map_err(|e| setup(&*e))?;
        if let Some(comp) = compensation {
            probe = probe.with_feed(&mut c, comp).map_err(|e| setup(&*e))?;
        }
        Ok(CosimStepper { coupled: c, probe, adaptive, kink_at_start: spec.kink_at_start, method })
    }
}

impl Stepper for CosimStepper {
    fn compensation(&self) -> Option<&Compensation> {
        self.probe.feed.as_ref().map(|(_, c)| c)
    }

    fn probe(&mut self) -> Result<Probe, RunError> {
        let t = self.coupled.time();
        self.probe.read(&mut self.coupled).map_err(|e| stopped(self.method, t, e.to_string()))
    }

    fn step(&mut self, request: Request) -> Result<Step<Observed>, RunError> {
        let (method, c) = (self.method, &mut self.coupled);
        let (h, report, rejected) = match (request, self.adaptive.as_mut()) {
            (Request::Adaptive { t_stop }, Some((ctl, tol))) => {
                let s = c.step_adaptive(ctl, *tol, t_stop).map_err(|e| RunError::stopped_by(method, &e))?;
                (s.h, s.report, s.rejected)
            }
            _ => {
                let (h, _) = fixed(method, request)?;
                // a motion that starts at full speed is a kink the FMUs were not initialized
                // for: the first step in substeps
                let kink = self.kink_at_start && c.time() == 0.0;
                let report = if kink { c.step_from_start(h) } else { c.step(h) };
                (h, report.map_err(|e| RunError::stopped_by(method, &e))?, 0)
            }
        };
        let mut step = stepped(h, report.iterations, report.residual, self.probe()?);
        step.rejected = rejected;
        Ok(step)
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
        names.extend((1..=4).map(|i| format!("platform.q[{i}]")));
        // the filter's estimate, with an inertial unit
        if comp.estimates() {
            names.extend((1..=3).map(|i| format!("estimate.r[{i}]")));
            names.extend((1..=4).map(|i| format!("estimate.q[{i}]")));
        }
        let vrs = names.iter().map(|n| inst.fmu().value_reference(n)).collect::<Result<Vec<_>, _>>()?;
        self.feed = Some((vrs, comp));
        Ok(self)
    }

    fn read(&self, c: &mut Coupled<FmuSystem>) -> Result<Probe, fmi::import::Error> {
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
                let mut v = [0.0; 33];
                let read = &mut v[..vrs.len()];
                c.units_mut().instance("stewart").expect("checked in new").get_real(vrs, read)?;
                // the platform relative to the cabin the Stewart FMU saw, placed on the cabin
                // of the cable model (the same one at convergence)
                let quat = |i: usize| {
                    feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(v[i], v[i + 1], v[i + 2], v[i + 3]))
                };
                let seen = quat(6);
                let relative =
                    seen.inverse_transform_vector(&(Vec3::new(v[0], v[1], v[2]) - Vec3::new(v[3], v[4], v[5])));
                let turn = seen.inverse() * quat(22);
                let six = |i: usize| std::array::from_fn(|k| v[i + k]);
                let now = c.time();
                let estimate = comp.estimates().then(|| (Vec3::new(v[26], v[27], v[28]), quat(29)));
                let cabin = (&position, &orientation);
                Some(FeedSample::place(comp, now, cabin, (&relative, &turn), six(10), six(16), estimate))
            }
            None => None,
        };
        Ok(Probe { position, orientation, wrench: w, feed })
    }
}
