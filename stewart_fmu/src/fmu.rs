//! The Stewart platform as an FMI 2.0 Co-Simulation FMU (`stewart_fmu`).
//!
//! Inputs: the cabin's motion (centre point position, orientation quaternion body to world,
//! velocity, angular velocity, acceleration, angular acceleration; world frame). Their start
//! values are scene C's static pose at rest (an importer running another scene sets them).
//! Outputs at the current time: the wrench the
//! platform exerts on the cabin (force; moment about the cabin centre point), the six actuator
//! forces (tension positive) and the moving platform's pose. The model has no state but time:
//! `fmi2DoStep` advances the clock and the outputs follow from the inputs at the end of the step
//! (held, or extrapolated with their first derivatives).
//!
//! Every output is a function of the inputs at the same instant (direct feedthrough), so the
//! standard directional derivative and the step map (extension `feedsimGetStepMapDerivative`)
//! coincide. Dependencies, exactly: the wrench and the actuator forces on the orientation, the
//! angular velocity, the acceleration and the angular acceleration (not on the position, nor on
//! the velocity: uniform gravity and Galilean invariance) — the force component k only on a_k and
//! α_j (j ≠ k), the moment component k only on a_j (j ≠ k) and α, as the cross products of the
//! Newton–Euler equations have it; the platform's position component i
//! on the cabin's position component i and the orientation; its orientation on the cabin's.
//!
//! Directional derivatives are exact: the wrench's from the analytic Jacobians; the actuator
//! forces' from the linearity of the Newton–Euler equations in the cabin's accelerations
//! (uniform gravity acts like an acceleration −g) and their quadratic dependence on the angular
//! velocity (polarization); an orientation change acts through the cabin-frame components of
//! gravity, acceleration and angular velocity.

use std::path::{Path, PathBuf};

use feedcore::rigid::skew;
use feedcore::scene::{LEGS, Scene, Start};
use feedcore::{Quat, Vec3};
use fmi2::export::{Model, ModelError, StepOutcome};
use fmi2::state_bytes::{StateReader, StateWriter};
use fmi2::{Capabilities, ModelDescription, Resource, Variable};
use nalgebra::{Matrix3x6, Vector6};

use crate::{CabinMotion, Evaluation, Stewart, Wrench, WrenchJacobians};

pub const DEFAULT_SCENE: &str = "lt50m_C.toml";
/// Largest scene file the FMU reads.
pub const SCENE_LIMIT_BYTES: u64 = 1 << 20;

/// The scene file named by a `scene` parameter: inside `resources/` when relative, size-capped,
/// errors quoting at most an excerpt of the file.
pub fn load_scene(name: &str, resources: Option<&Path>) -> Result<Scene, fmi2::resources::ResourceError> {
    fmi2::resources::load_parsed(name, resources, &feedcore::shipped::SCENES, SCENE_LIMIT_BYTES, Scene::from_toml)
}
/// Number of Real inputs: r 3, q 4, v 3, ω 3, a 3, α 3.
pub const INPUTS: usize = 19;

/// Value references (separate spaces per type).
pub mod vr {
    pub const R: u32 = 0;
    pub const Q: u32 = 3;
    pub const V: u32 = 7;
    pub const W: u32 = 10;
    pub const A: u32 = 13;
    pub const ALPHA: u32 = 16;
    pub const FORCE: u32 = 19;
    pub const MOMENT: u32 = 22;
    pub const ACTUATOR: u32 = 25;
    pub const PLATFORM_R: u32 = 31;
    pub const PLATFORM_Q: u32 = 34;
    pub const RADIUS: u32 = 38;
    pub const SPEED: u32 = 39;
    pub const RAMP_TIME: u32 = 40;
    /// Integer.
    pub const START: u32 = 0;
    /// String.
    pub const SCENE: u32 = 0;
}

#[derive(Clone, Debug, PartialEq)]
struct Settings {
    scene_name: String,
    /// Negative: the scene's value.
    radius: f64,
    speed: f64,
    ramp_time: f64,
    /// 0: the scene's, 1: abrupt, 2: ramp.
    start: i32,
}

/// Rates of the actuator forces: row k is ∂/∂(component k), column j actuator j; world frame.
#[derive(Clone, Copy, Debug)]
struct ActuatorRates {
    acceleration: Matrix3x6<f64>,
    angular_acceleration: Matrix3x6<f64>,
    angular_velocity: Matrix3x6<f64>,
}

/// Outputs at the current time and inputs, computed when first asked for.
#[derive(Default)]
struct Cache {
    wrench: Option<(Wrench, WrenchJacobians)>,
    evaluation: Option<Evaluation>,
    actuator_rates: Option<ActuatorRates>,
}

pub struct StewartFmu {
    resources: Option<PathBuf>,
    settings: Settings,
    scene: Scene,
    model: Option<Stewart>,
    /// The settings the model was built for, and whether in step mode (in initialization mode
    /// the platform rests at its start pose).
    built_for: Option<(Settings, bool)>,
    initialized: bool,
    time: f64,
    inputs: [f64; INPUTS],
    rates: [f64; INPUTS],
    cache: Cache,
}

/// The scene's static pose at rest, as input values.
fn rest_inputs(scene: &Scene) -> [f64; INPUTS] {
    let mut u = [0.0; INPUTS];
    let (p, q) = (scene.target_position(), scene.target_orientation());
    u[0..3].copy_from_slice(p.as_slice());
    u[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
    u
}

fn input_names() -> Vec<String> {
    let mut v = Vec::new();
    for (p, n) in [("cabin.r", 3), ("cabin.q", 4), ("cabin.v", 3), ("cabin.w", 3), ("cabin.a", 3), ("cabin.alpha", 3)] {
        v.extend((1..=n).map(|k| format!("{p}[{k}]")));
    }
    v
}

/// The unit quaternion of the input components and the world rotation `δθ` a change `dq` of
/// them makes (after normalization): δθ = 2 vec(δn ⊗ n*), δn = (dq − n (n·dq)) / |q|.
fn rotation_of(q: &[f64], dq: &[f64]) -> Vec3 {
    let raw = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
    let s = raw.norm();
    let n = raw / s;
    let d = nalgebra::Quaternion::new(dq[0], dq[1], dq[2], dq[3]);
    let dn = (d - n * n.coords.dot(&d.coords)) / s;
    (dn * n.conjugate()).imag() * 2.0
}

impl StewartFmu {
    fn model(&mut self) -> Result<&Stewart, ModelError> {
        let key = (self.settings.clone(), self.initialized);
        if self.model.is_none() || self.built_for.as_ref() != Some(&key) {
            let mut s = self.scene.clone();
            let st = &self.settings;
            if st.radius >= 0.0 {
                s.motion.radius_m = st.radius;
            }
            if st.speed >= 0.0 {
                s.motion.speed_m_s = st.speed;
            }
            if st.ramp_time > 0.0 {
                s.motion.ramp_time_s = st.ramp_time;
            }
            match st.start {
                1 => s.motion.start = Start::Abrupt,
                2 => s.motion.start = Start::Ramp,
                _ => {}
            }
            s.validate(&st.scene_name)?;
            // Before the start the platform rests at its start pose: the motion (and an abrupt
            // start's jump) begins at the start time, so that a consistent initialization puts
            // the cable net in its static equilibrium under the platform's weight.
            let mut held = s.clone();
            held.motion.speed_m_s = 0.0;
            self.model = Some(Stewart::from_scene(if self.initialized { &s } else { &held })?);
            self.built_for = Some(key);
            self.cache = Cache::default();
        }
        Ok(self.model.as_ref().expect("built"))
    }

    fn cabin(&self) -> Result<CabinMotion, ModelError> {
        let u = &self.inputs;
        let q = nalgebra::Quaternion::new(u[3], u[4], u[5], u[6]);
        if q.norm() < 0.5 {
            return Err(format!("cabin.q = {:?} is not a rotation (norm {:.3}, expected 1)", &u[3..7], q.norm()).into());
        }
        let v3 = |i: usize| Vec3::new(u[i], u[i + 1], u[i + 2]);
        Ok(CabinMotion {
            position: v3(0),
            orientation: Quat::from_quaternion(q),
            velocity: v3(7),
            angular_velocity: v3(10),
            acceleration: v3(13),
            angular_acceleration: v3(16),
        })
    }

    fn wrench(&mut self) -> Result<(Wrench, WrenchJacobians), ModelError> {
        if self.cache.wrench.is_none() {
            let t = self.time;
            let cabin = self.cabin()?;
            let w = self.model()?.wrench_with_jacobians(&cabin, t).map_err(|e| e.to_string())?;
            self.cache.wrench = Some(w);
        }
        Ok(self.cache.wrench.expect("computed"))
    }

    fn evaluation(&mut self) -> Result<&Evaluation, ModelError> {
        if self.cache.evaluation.is_none() {
            let t = self.time;
            let cabin = self.cabin()?;
            let e = self.model()?.evaluate(&cabin, t).map_err(|e| e.to_string())?;
            self.cache.evaluation = Some(e);
        }
        Ok(self.cache.evaluation.as_ref().expect("computed"))
    }

    /// ∂(actuator forces)/∂(a, α, ω) (world frame), exact: the forces are linear in (a, α) and
    /// quadratic in ω, so unit differences (central for ω) give the derivatives exactly.
    fn actuator_rates(&mut self) -> Result<ActuatorRates, ModelError> {
        if let Some(r) = self.cache.actuator_rates {
            return Ok(r);
        }
        let t = self.time;
        let cabin = self.cabin()?;
        let model = self.model()?;
        let forces = |c: &CabinMotion| model.evaluate(c, t).map(|e| e.actuator_forces).map_err(|e| e.to_string());
        let base = forces(&cabin)?;
        let mut r = ActuatorRates {
            acceleration: Matrix3x6::zeros(),
            angular_acceleration: Matrix3x6::zeros(),
            angular_velocity: Matrix3x6::zeros(),
        };
        for k in 0..3 {
            let mut c = cabin;
            c.acceleration[k] += 1.0;
            let fa = forces(&c)?;
            let mut c = cabin;
            c.angular_acceleration[k] += 1.0;
            let fal = forces(&c)?;
            let (mut cp, mut cm) = (cabin, cabin);
            cp.angular_velocity[k] += 1.0;
            cm.angular_velocity[k] -= 1.0;
            let (fp, fm) = (forces(&cp)?, forces(&cm)?);
            for j in 0..LEGS {
                r.acceleration[(k, j)] = fa[j] - base[j];
                r.angular_acceleration[(k, j)] = fal[j] - base[j];
                r.angular_velocity[(k, j)] = 0.5 * (fp[j] - fm[j]);
            }
        }
        self.cache.actuator_rates = Some(r);
        Ok(r)
    }

    fn settings_changed(&mut self) {
        self.model = None;
        self.built_for = None;
        self.cache = Cache::default();
    }
}

impl Model for StewartFmu {
    fn description() -> Result<ModelDescription, ModelError> {
        let default = load_scene(DEFAULT_SCENE, None)?;
        let rest = rest_inputs(&default);
        let inputs = input_names();
        let units = |i: usize| match i {
            0..3 => "m",
            3..7 => "",
            7..10 => "m/s",
            10..13 => "rad/s",
            13..16 => "m/s2",
            _ => "rad/s2",
        };
        let what = |i: usize| match i {
            0..3 => "position of the cabin centre point, world frame",
            3..7 => "orientation of the cabin, quaternion (w, x, y, z) body to world (normalized)",
            7..10 => "velocity of the cabin centre point, world frame",
            10..13 => "angular velocity of the cabin, world frame",
            13..16 => "acceleration of the cabin centre point, world frame",
            _ => "angular acceleration of the cabin, world frame",
        };
        let mut variables: Vec<Variable> = inputs
            .iter()
            .enumerate()
            .map(|(i, n)| Variable::real_input(n.clone(), i as u32, rest[i], units(i)).describe(what(i)))
            .collect();
        // Direct feedthrough, exactly (see the module documentation); in initialization mode
        // the parameters that shape the platform's motion at the start count as well.
        let name = |i: usize| inputs[i].as_str();
        let orientation: Vec<&str> = (3..7).map(name).collect();
        // q and ω always; the force component k on a_k and on α_j (j ≠ k) (the inertial force
        // is linear in a + α × ρ), the moment component k on a_j (j ≠ k) (ρ × a) and on α.
        let (a, alpha) = (13, 16);
        let rotating: Vec<&str> = (3..7).chain(10..13).map(name).collect();
        let force = |k: usize| -> Vec<&str> {
            let mut d = rotating.clone();
            d.push(name(a + k));
            d.extend((0..3).filter(|&j| j != k).map(|j| name(alpha + j)));
            d
        };
        let moment = |k: usize| -> Vec<&str> {
            let mut d = rotating.clone();
            d.extend((0..3).filter(|&j| j != k).map(|j| name(a + j)));
            d.extend((0..3).map(|j| name(alpha + j)));
            d
        };
        let all_but_position: Vec<&str> = (3..7).chain(10..19).map(name).collect();
        // in initialization mode the platform rests at its start pose: speed and start do not count
        let params = ["scene", "radius"];
        let deps = |vr: u32| -> Vec<&str> {
            match vr {
                vr::FORCE..vr::MOMENT => force((vr - vr::FORCE) as usize),
                vr::MOMENT..vr::ACTUATOR => moment((vr - vr::MOMENT) as usize),
                vr::ACTUATOR..vr::PLATFORM_R => all_but_position.clone(),
                vr::PLATFORM_R..vr::PLATFORM_Q => {
                    let mut d = vec![inputs[(vr - vr::PLATFORM_R) as usize].as_str()];
                    d.extend(&orientation);
                    d
                }
                _ => orientation.clone(),
            }
        };
        let mut out = |name: String, vr: u32, unit: &str, text: String| {
            let d = deps(vr);
            let initially: Vec<&str> = d.iter().copied().chain(params).collect();
            variables.push(
                Variable::real_output(name, vr, unit).describe(text).depends_on(&d).initially_depends_on(&initially),
            );
        };
        for k in 0..3 {
            out(
                format!("wrench.f[{}]", k + 1),
                vr::FORCE + k,
                "N",
                "force the platform exerts on the cabin, world frame".into(),
            );
        }
        for k in 0..3 {
            out(
                format!("wrench.m[{}]", k + 1),
                vr::MOMENT + k,
                "N.m",
                "moment on the cabin about its centre point, world frame".into(),
            );
        }
        for k in 0..LEGS as u32 {
            out(
                format!("actuator.force[{}]", k + 1),
                vr::ACTUATOR + k,
                "N",
                format!("tension of actuator {} (positive: pulls the platform up)", k + 1),
            );
        }
        for k in 0..3 {
            out(
                format!("platform.r[{}]", k + 1),
                vr::PLATFORM_R + k,
                "m",
                "position of the moving platform's centre, world frame".into(),
            );
        }
        for (k, c) in ["w", "x", "y", "z"].iter().enumerate() {
            out(
                format!("platform.q[{}]", k + 1),
                vr::PLATFORM_Q + k as u32,
                "",
                format!("orientation of the moving platform ({c}), body to world"),
            );
        }
        variables.push(
            Variable::parameter("radius", vr::RADIUS, -1.0, false)
                .unit("m")
                .describe("radius of the platform's circle; negative: the scene's value"),
        );
        variables.push(
            Variable::parameter("speed", vr::SPEED, -1.0, false)
                .unit("m/s")
                .describe("speed of the platform on the circle (0: held still); negative: the scene's value"),
        );
        variables.push(
            Variable::parameter("ramp_time", vr::RAMP_TIME, -1.0, false)
                .unit("s")
                .describe("duration of the smooth start (with start = 2); non-positive: the scene's value"),
        );
        variables.push(
            Variable::parameter("start", vr::START, 0, false)
                .describe("0: the scene's start, 1: abrupt (full speed at t = 0), 2: smooth ramp"),
        );
        variables.push(Variable::parameter("scene", vr::SCENE, DEFAULT_SCENE, false).describe(
            "scene file (TOML); relative paths resolve against resources/, which holds lt50m_B.toml and lt50m_C.toml",
        ));
        Ok(ModelDescription::co_simulation(
            "stewart_fmu",
            "{9a47c3e1-52b8-4d0f-a6e3-7c1b2d8f4e96}",
            "Stewart platform (13 rigid bodies) hanging in the feed cabin, platform on a circle; output: its wrench on the cabin",
            env!("CARGO_PKG_VERSION"),
            Capabilities {
                provides_directional_derivative: true,
                can_interpolate_inputs: true,
                provides_step_map_derivative: true,
            },
            variables,
        ))
    }

    fn resources() -> Vec<Resource> {
        Resource::texts(&feedcore::shipped::SCENES)
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let scene = load_scene(DEFAULT_SCENE, resources)?;
        Ok(StewartFmu {
            resources: resources.map(Path::to_owned),
            settings: Settings {
                scene_name: DEFAULT_SCENE.into(),
                radius: -1.0,
                speed: -1.0,
                ramp_time: -1.0,
                start: 0,
            },
            // Inputs start at their declared start values (FMI 2.0): scene C's pose at rest.
            inputs: rest_inputs(&scene),
            scene,
            model: None,
            built_for: None,
            initialized: false,
            time: 0.0,
            rates: [0.0; INPUTS],
            cache: Cache::default(),
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            0..19 => {
                self.inputs[vr as usize] = value;
                self.cache = Cache::default();
                return Ok(());
            }
            vr::RADIUS => self.settings.radius = value,
            vr::SPEED => self.settings.speed = value,
            vr::RAMP_TIME => self.settings.ramp_time = value,
            _ => return Err(format!("value reference {vr} is not a settable Real").into()),
        }
        self.settings_changed();
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            0..19 => Ok(self.inputs[vr as usize]),
            vr::FORCE..vr::ACTUATOR => {
                let (w, _) = self.wrench()?;
                Ok(w.to_vector()[(vr - vr::FORCE) as usize])
            }
            vr::ACTUATOR..vr::PLATFORM_R => Ok(self.evaluation()?.actuator_forces[(vr - vr::ACTUATOR) as usize]),
            vr::PLATFORM_R..vr::PLATFORM_Q => Ok(self.evaluation()?.platform.position[(vr - vr::PLATFORM_R) as usize]),
            vr::PLATFORM_Q..vr::RADIUS => {
                let q = self.evaluation()?.platform.orientation;
                Ok([q.w, q.i, q.j, q.k][(vr - vr::PLATFORM_Q) as usize])
            }
            vr::RADIUS => Ok(self.settings.radius),
            vr::SPEED => Ok(self.settings.speed),
            vr::RAMP_TIME => Ok(self.settings.ramp_time),
            _ => Err(format!("value reference {vr} is not a Real of this model").into()),
        }
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        if vr != vr::START {
            return Err(format!("value reference {vr} is not a settable Integer").into());
        }
        if !(0..=2).contains(&value) {
            return Err(format!("start = {value}: must be 0 (the scene's), 1 (abrupt) or 2 (ramp)").into());
        }
        self.settings.start = value;
        self.settings_changed();
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        if vr != vr::START {
            return Err(format!("value reference {vr} is not an Integer of this model").into());
        }
        Ok(self.settings.start)
    }

    fn set_string(&mut self, vr: u32, value: &str) -> Result<(), ModelError> {
        if vr != vr::SCENE {
            return Err(format!("value reference {vr} is not a settable String").into());
        }
        self.scene = load_scene(value, self.resources.as_deref())?;
        self.settings.scene_name = value.to_string();
        self.settings_changed();
        Ok(())
    }

    fn get_string(&mut self, vr: u32) -> Result<String, ModelError> {
        if vr != vr::SCENE {
            return Err(format!("value reference {vr} is not a String of this model").into());
        }
        Ok(self.settings.scene_name.clone())
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.initialized = true;
        self.model()?;
        self.time = start_time;
        self.cache = Cache::default();
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        self.model()?;
        for k in 0..INPUTS {
            self.inputs[k] += self.rates[k] * h;
        }
        self.rates = [0.0; INPUTS]; // input derivatives apply to one step
        self.time = t + h;
        self.cache = Cache::default();
        // evaluate now, so that a leg leaving its stroke, or a non-finite result, is reported
        // by this step
        let (w, _) = self.wrench()?;
        let w = w.to_vector();
        if let Some(k) = w.iter().position(|x| !x.is_finite()) {
            let name = if k < 3 { format!("wrench.f[{}]", k + 1) } else { format!("wrench.m[{}]", k - 2) };
            return Err(format!("`{name}` = {} at t = {}: the cabin inputs are {:?}", w[k], t + h, self.inputs).into());
        }
        Ok(StepOutcome::Complete)
    }

    fn set_real_input_derivative(&mut self, vr: u32, _order: i32, value: f64) -> Result<(), ModelError> {
        if vr as usize >= INPUTS {
            return Err(format!("value reference {vr} is not an input").into());
        }
        self.rates[vr as usize] = value;
        Ok(())
    }

    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        let mut du = [0.0; INPUTS];
        for (k, s) in knowns.iter().zip(seed) {
            if *k as usize >= INPUTS {
                return Err(format!(
                    "derivatives with respect to value reference {k} are not provided (only the cabin inputs)"
                )
                .into());
            }
            du[*k as usize] += s;
        }
        let v3 = |i: usize| Vec3::new(du[i], du[i + 1], du[i + 2]);
        let (dr, dv, dw, da, dal) = (v3(0), v3(7), v3(10), v3(13), v3(16));
        let dth = rotation_of(&self.inputs[3..7], &du[3..7]);
        let stack = |a: Vec3, b: Vec3| Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z);
        let needs_wrench = unknowns.iter().any(|u| (vr::FORCE..vr::ACTUATOR).contains(u));
        let needs_actuators = unknowns.iter().any(|u| (vr::ACTUATOR..vr::PLATFORM_R).contains(u));
        let needs_platform = unknowns.iter().any(|u| (vr::PLATFORM_R..vr::RADIUS).contains(u));
        let dwrench = if needs_wrench {
            let (_, j) = self.wrench()?;
            j.pose * stack(dr, dth) + j.velocity * stack(dv, dw) + j.acceleration * stack(da, dal)
        } else {
            Vector6::zeros()
        };
        let dact = if needs_actuators {
            let r = self.actuator_rates()?;
            let c = self.cabin()?;
            let g = self.model()?.gravity();
            // a rotation turns the cabin-frame components of (a − g), α and ω
            let th_a = skew(&(c.acceleration - g)) * dth;
            let th_al = skew(&c.angular_acceleration) * dth;
            let th_w = skew(&c.angular_velocity) * dth;
            r.acceleration.transpose() * (da + th_a)
                + r.angular_acceleration.transpose() * (dal + th_al)
                + r.angular_velocity.transpose() * (dw + th_w)
        } else {
            nalgebra::Vector6::zeros()
        };
        let (dp, dq) = if needs_platform {
            let cabin_r = Vec3::new(self.inputs[0], self.inputs[1], self.inputs[2]);
            let e = self.evaluation()?;
            let arm = e.platform.position - cabin_r;
            let q = e.platform.orientation.into_inner();
            (dr + dth.cross(&arm), nalgebra::Quaternion::from_imag(dth * 0.5) * q)
        } else {
            (Vec3::zeros(), nalgebra::Quaternion::identity())
        };
        for (o, u) in out.iter_mut().zip(unknowns) {
            *o = match *u {
                vr::FORCE..vr::ACTUATOR => dwrench[(*u - vr::FORCE) as usize],
                vr::ACTUATOR..vr::PLATFORM_R => dact[(*u - vr::ACTUATOR) as usize],
                vr::PLATFORM_R..vr::PLATFORM_Q => dp[(*u - vr::PLATFORM_R) as usize],
                vr::PLATFORM_Q..vr::RADIUS => [dq.w, dq.i, dq.j, dq.k][(*u - vr::PLATFORM_Q) as usize],
                other => return Err(format!("value reference {other} is not an output").into()),
            };
        }
        Ok(())
    }

    /// The outputs follow the inputs at the end of the step: the step map's derivative is the
    /// instantaneous one at the current time.
    fn step_map_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        self.directional_derivative(unknowns, knowns, seed, out)
    }

    fn save_state(&self, out: &mut Vec<u8>) -> Result<(), ModelError> {
        let mut w = StateWriter::new(out);
        let s = &self.settings;
        w.str(&s.scene_name)
            .f64(s.radius)
            .f64(s.speed)
            .f64(s.ramp_time)
            .i32(s.start)
            .f64(self.time)
            .bool(self.initialized);
        for k in 0..INPUTS {
            w.f64(self.inputs[k]).f64(self.rates[k]);
        }
        Ok(())
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError> {
        let mut r = StateReader::new(bytes);
        let settings = Settings {
            scene_name: r.string()?,
            radius: r.f64()?,
            speed: r.f64()?,
            ramp_time: r.f64()?,
            start: r.i32()?,
        };
        let time = r.f64()?;
        let initialized = r.bool()?;
        let mut inputs = [0.0; INPUTS];
        let mut rates = [0.0; INPUTS];
        for k in 0..INPUTS {
            inputs[k] = r.f64()?;
            rates[k] = r.f64()?;
        }
        r.finish()?;
        if settings != self.settings {
            if settings.scene_name != self.settings.scene_name {
                self.scene = load_scene(&settings.scene_name, self.resources.as_deref())?;
            }
            self.settings = settings;
            self.settings_changed();
        }
        self.initialized = initialized;
        self.model()?;
        self.time = time;
        self.inputs = inputs;
        self.rates = rates;
        self.cache = Cache::default();
        Ok(())
    }
}
