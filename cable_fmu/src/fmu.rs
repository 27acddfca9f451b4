//! The cable–cabin model as an FMI 2.0 Co-Simulation FMU (`cable_fmu`): the FMU-facing
//! variables of [`crate::model::CableCabin`] with an external Stewart platform.
//!
//! Input: the wrench the Stewart platform exerts on the cabin (force; moment about the cabin
//! centre point; world frame). Outputs: the cabin centre point's motion and both end tensions of
//! every cable. Parameters: the scene file (relative paths resolve inside `resources/`, which
//! ships both reference scenes) and scalars that override the scene when set to a positive value.
//!
//! Initialization: the FMU starts at rest at the scene's target pose under the wrench it holds
//! at `fmi2ExitInitializationMode` — the unstretched cable lengths are form-found for that
//! wrench. In initialization mode the outputs are that start: the target pose, zero velocities
//! and accelerations, and the end tensions of the equilibrium under the current wrench.
//!
//! `fmi2DoStep` integrates one step with the wrench held (or extrapolated with its first
//! derivative) to the end of the step. No output responds to the wrench at a communication
//! point (the accelerations reported are those of the state reached, under the wrench held
//! during the step): `<Outputs>` declares no dependency and `fmi2GetDirectionalDerivative` is
//! zero in step mode. In initialization mode the tensions depend on the wrench through the form
//! finding, exactly. The step map (outputs after a step with respect to the wrench held during
//! it) is the extension `feedsimGetStepMapDerivative`, exact from the converged iteration matrix.

use std::path::{Path, PathBuf};

use feedcore::Vec3;
use feedcore::scene::Scene;
use fmi2::export::{Model, ModelError, StepOutcome};
use fmi2::state_bytes::{StateReader, StateWriter};
use fmi2::{Capabilities, ModelDescription, Resource, Variable};
use nalgebra::Vector6;

use crate::dynamics::{CabinDelta, Dynamics};
use crate::model::{CableCabin, Payload};

/// Cables the FMU exposes (the LT50m net).
pub const CABLES: usize = 6;
/// The scene used unless the `scene` parameter names another one.
pub const DEFAULT_SCENE: &str = "lt50m_C.toml";
/// Largest scene file the FMU reads.
pub const SCENE_LIMIT_BYTES: u64 = 1 << 20;
/// Outputs: r 3, q 4, v 3, ω 3, a 3, α 3, tensions 2 × 6.
const OUTPUTS: usize = 31;

/// Value references (separate spaces per type).
pub mod vr {
    /// Wrench on the cabin: force x, y, z, then moment x, y, z (Real inputs).
    pub const WRENCH: u32 = 0;
    pub const POSITION: u32 = 6;
    pub const ORIENTATION: u32 = 9;
    pub const VELOCITY: u32 = 13;
    pub const ANGULAR_VELOCITY: u32 = 16;
    pub const ACCELERATION: u32 = 19;
    pub const ANGULAR_ACCELERATION: u32 = 22;
    pub const TENSION_ANCHOR: u32 = 25;
    pub const TENSION_CABIN: u32 = 31;
    pub const DAMPING_RATIO: u32 = 37;
    pub const RHO_INF: u32 = 38;
    pub const NEWTON_TOL: u32 = 39;
    /// Number of Real value references.
    pub const REALS: u32 = 40;
    /// Integer.
    pub const ELEMENTS: u32 = 0;
    /// String.
    pub const SCENE: u32 = 0;
}

/// Parameters that select and modify the scene.
#[derive(Clone, Debug, PartialEq)]
struct Settings {
    scene_name: String,
    /// ≤ 0: the scene's value.
    elements: i32,
    damping_ratio: f64,
    rho_inf: f64,
    newton_tol: f64,
}

/// The scene file named by a `scene` parameter: inside `resources/` when relative, size-capped,
/// errors quoting at most an excerpt of the file.
pub fn load_scene(name: &str, resources: Option<&Path>) -> Result<Scene, fmi2::resources::ResourceError> {
    fmi2::resources::load_parsed(name, resources, &feedcore::shipped::SCENES, SCENE_LIMIT_BYTES, Scene::from_toml)
}

/// The model at rest under one wrench.
struct Balanced {
    wrench: Vector6<f64>,
    /// `None`: the nominal model is in equilibrium under this wrench (the platform's weight).
    model: Option<Box<CableCabin>>,
    tensions: [(f64, f64); CABLES],
}

pub struct CableFmu {
    resources: Option<PathBuf>,
    settings: Settings,
    /// The scene file as loaded (before the scalar overrides).
    scene: Scene,
    /// The model built for `built_for`, in equilibrium under the platform's own weight.
    nominal: Option<CableCabin>,
    built_for: Option<Settings>,
    /// Initialization mode: the equilibrium under the wrench last asked about.
    balanced: Option<Balanced>,
    /// Step mode, and the wrench the model was form-found for (it fixes the cable lengths).
    dynamics: Option<Dynamics>,
    start_wrench: Vector6<f64>,
    wrench: Vector6<f64>,
    wrench_rate: Vector6<f64>,
    tensions: [(f64, f64); CABLES],
    /// Reused buffer for saving and restoring the dynamics state (no allocation per rollback).
    scratch: std::cell::RefCell<Vec<f64>>,
}

/// The static wrench of the scene's Stewart platform at its starting pose (the input start).
fn static_wrench(scene: &Scene) -> Vector6<f64> {
    let net = crate::net::CableNet::from_scene(scene);
    let f = net.spec.gravity * net.payload.mass;
    let m = (scene.target_orientation() * net.payload.com).cross(&f);
    Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)
}

fn names3(prefix: &str) -> [String; 3] {
    std::array::from_fn(|k| format!("{prefix}[{}]", k + 1))
}

/// Output variables in value-reference order: (name, unit, description).
fn outputs() -> Vec<(String, &'static str, String)> {
    let mut v = Vec::new();
    let axes = ["x", "y", "z"];
    for (prefix, unit, what) in [
        ("cabin.r", "m", "position of the cabin centre point"),
        ("cabin.q", "", "orientation of the cabin, unit quaternion body to world"),
        ("cabin.v", "m/s", "velocity of the cabin centre point"),
        ("cabin.w", "rad/s", "angular velocity of the cabin"),
        ("cabin.a", "m/s2", "acceleration of the cabin centre point"),
        ("cabin.alpha", "rad/s2", "angular acceleration of the cabin"),
    ] {
        if prefix == "cabin.q" {
            for (k, c) in ["w", "x", "y", "z"].iter().enumerate() {
                v.push((format!("{prefix}[{}]", k + 1), unit, format!("{what} ({c}), world frame")));
            }
        } else {
            for (k, n) in names3(prefix).into_iter().enumerate() {
                v.push((n, unit, format!("{what}, world {}", axes[k])));
            }
        }
    }
    for (prefix, what) in [("cable.tension_anchor", "next to the tower"), ("cable.tension_cabin", "next to the cabin")]
    {
        for i in 0..CABLES {
            v.push((format!("{prefix}[{}]", i + 1), "N", format!("axial force of the element {what}, cable {i}")));
        }
    }
    v
}

fn input_names() -> Vec<String> {
    names3("wrench.f").into_iter().chain(names3("wrench.m")).collect()
}

fn is_tension(vr: u32) -> bool {
    (vr::TENSION_ANCHOR..vr::DAMPING_RATIO).contains(&vr)
}

/// Memory the machine can give (MemAvailable), if it says.
fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

impl CableFmu {
    /// The scene with the scalar overrides `st` applied and validated.
    fn effective_scene(&self, st: &Settings) -> Result<Scene, ModelError> {
        let mut s = self.scene.clone();
        if st.elements > 0 {
            s.cables.elements = st.elements as usize;
        }
        if st.damping_ratio >= 0.0 {
            s.damping.ratio = st.damping_ratio;
        }
        if st.rho_inf >= 0.0 {
            s.solver.rho_inf = st.rho_inf;
        }
        if st.newton_tol > 0.0 {
            s.solver.newton_tol = st.newton_tol;
        }
        s.validate(&st.scene_name)?;
        if s.cable_count() != CABLES {
            return Err(
                format!("scene `{}` has {} cables; this FMU exposes {CABLES}", st.scene_name, s.cable_count()).into()
            );
        }
        // Refuse a model that would not fit before allocating it: an allocation failure aborts
        // the importing process, which no error handling can catch.
        let need = CableCabin::memory_estimate(&s, 0);
        let avail = available_memory().unwrap_or(8.0 * 1024.0 * 1024.0 * 1024.0);
        if !(need <= 0.5 * avail) {
            return Err(format!(
                "{} elements per cable would need about {:.1} GB (this machine has {:.1} GB available); \
                 use fewer elements_per_cable",
                s.cables.elements,
                need / 1e9,
                avail / 1e9
            )
            .into());
        }
        Ok(s)
    }

    /// The nominal model for the current settings.
    fn nominal(&mut self) -> Result<&CableCabin, ModelError> {
        if self.built_for.as_ref() != Some(&self.settings) || self.nominal.is_none() {
            let scene = self.effective_scene(&self.settings)?;
            self.nominal = Some(CableCabin::build(&scene, 0)?);
            self.built_for = Some(self.settings.clone());
            self.balanced = None;
        }
        Ok(self.nominal.as_ref().expect("built above"))
    }

    /// The equilibrium at the target pose under the current wrench (initialization mode).
    fn balanced(&mut self) -> Result<&Balanced, ModelError> {
        let w = self.wrench;
        let fresh = self.built_for.as_ref() == Some(&self.settings) && self.nominal.is_some();
        if !(fresh && self.balanced.as_ref().is_some_and(|b| b.wrench == w)) {
            let nominal = self.nominal()?;
            // Bit for bit the platform's own weight: the nominal equilibrium is the one.
            let model =
                if w == nominal.static_payload_wrench() { None } else { Some(Box::new(nominal.under_wrench(&w)?)) };
            let m = model.as_deref().unwrap_or(nominal);
            let mut tensions = [(0.0, 0.0); CABLES];
            m.system(Payload::External).end_tensions(&m.equilibrium_config(), &mut tensions);
            self.balanced = Some(Balanced { wrench: w, model, tensions });
        }
        Ok(self.balanced.as_ref().expect("set above"))
    }

    /// A change of the settings discards the models (rebuilt when next needed).
    fn settings_changed(&mut self) {
        self.nominal = None;
        self.built_for = None;
        self.balanced = None;
    }

    /// All outputs now, in value-reference order.
    fn output_values(&mut self) -> Result<[f64; OUTPUTS], ModelError> {
        let mut y = [0.0; OUTPUTS];
        let (motion, tensions) = match &self.dynamics {
            Some(dy) => (dy.cabin(), self.tensions),
            None => {
                let tensions = self.balanced()?.tensions;
                let nominal = self.nominal.as_ref().expect("built with the equilibrium");
                let eq = &nominal.equilibrium;
                let rest = feedcore::rigid::RigidMotion {
                    position: eq.position,
                    orientation: eq.orientation,
                    velocity: Vec3::zeros(),
                    angular_velocity: Vec3::zeros(),
                    acceleration: Vec3::zeros(),
                    angular_acceleration: Vec3::zeros(),
                };
                (rest, tensions)
            }
        };
        let q = motion.orientation.quaternion();
        y[0..3].copy_from_slice(motion.position.as_slice());
        y[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        y[7..10].copy_from_slice(motion.velocity.as_slice());
        y[10..13].copy_from_slice(motion.angular_velocity.as_slice());
        y[13..16].copy_from_slice(motion.acceleration.as_slice());
        y[16..19].copy_from_slice(motion.angular_acceleration.as_slice());
        for (i, (a, c)) in tensions.iter().enumerate() {
            (y[19 + i], y[25 + i]) = (*a, *c);
        }
        Ok(y)
    }

    /// The wrench change a seed on the knowns makes; only the wrench inputs are knowns.
    fn wrench_seed(knowns: &[u32], seed: &[f64]) -> Result<Vector6<f64>, ModelError> {
        let mut dw = Vector6::zeros();
        for (k, s) in knowns.iter().zip(seed) {
            match *k {
                vr::WRENCH..vr::POSITION => dw[(*k - vr::WRENCH) as usize] += s,
                other => {
                    return Err(format!(
                        "derivatives with respect to value reference {other} are not provided (only the wrench inputs)"
                    )
                    .into());
                }
            }
        }
        Ok(dw)
    }
}

/// The output `vr` of a motion delta (for directional derivatives), with `q` the orientation.
fn delta_output(d: &CabinDelta, q: &nalgebra::Quaternion<f64>, vr: u32) -> Option<f64> {
    let v3 = |v: &Vec3, base: u32| v[(vr - base) as usize];
    Some(match vr {
        vr::POSITION..vr::ORIENTATION => v3(&d.position, vr::POSITION),
        vr::ORIENTATION..vr::VELOCITY => {
            let dq = nalgebra::Quaternion::from_imag(d.rotation * 0.5) * q;
            [dq.w, dq.i, dq.j, dq.k][(vr - vr::ORIENTATION) as usize]
        }
        vr::VELOCITY..vr::ANGULAR_VELOCITY => v3(&d.velocity, vr::VELOCITY),
        vr::ANGULAR_VELOCITY..vr::ACCELERATION => v3(&d.angular_velocity, vr::ANGULAR_VELOCITY),
        vr::ACCELERATION..vr::ANGULAR_ACCELERATION => v3(&d.acceleration, vr::ACCELERATION),
        vr::ANGULAR_ACCELERATION..vr::TENSION_ANCHOR => v3(&d.angular_acceleration, vr::ANGULAR_ACCELERATION),
        vr::TENSION_ANCHOR..vr::TENSION_CABIN => d.tensions[(vr - vr::TENSION_ANCHOR) as usize].0,
        vr::TENSION_CABIN..vr::DAMPING_RATIO => d.tensions[(vr - vr::TENSION_CABIN) as usize].1,
        _ => return None,
    })
}

impl Model for CableFmu {
    fn description() -> Result<ModelDescription, ModelError> {
        let default = load_scene(DEFAULT_SCENE, None)?;
        let w0 = static_wrench(&default);
        let inputs = input_names();
        let mut variables: Vec<Variable> = inputs
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let unit = if k < 3 { "N" } else { "N.m" };
                let what = if k < 3 { "force" } else { "moment about the cabin centre point" };
                Variable::real_input(name.clone(), vr::WRENCH + k as u32, w0[k], unit).describe(format!(
                    "{what} the Stewart platform exerts on the cabin, world frame (start: scene C's static value)"
                ))
            })
            .collect();
        // The start pose depends on the scene only; the equilibrium's tensions also on the
        // wrench and the discretisation.
        let pose_knowns = ["scene"];
        let tension_knowns: Vec<String> =
            inputs.iter().cloned().chain(["scene", "elements_per_cable"].map(String::from)).collect();
        for (k, (name, unit, what)) in outputs().into_iter().enumerate() {
            let vr = vr::POSITION + k as u32;
            let initially: Vec<String> = if is_tension(vr) {
                tension_knowns.clone()
            } else if vr < vr::VELOCITY {
                pose_knowns.map(String::from).to_vec()
            } else {
                vec![]
            };
            variables.push(
                Variable::real_output(name, vr, unit)
                    .describe(what)
                    .depends_on::<&str>(&[])
                    .initially_depends_on(&initially),
            );
        }
        variables.push(
            Variable::parameter("damping_ratio", vr::DAMPING_RATIO, -1.0, false)
                .describe("Rayleigh damping ratio of the cable structure; negative: the scene's value"),
        );
        variables.push(Variable::parameter("rho_inf", vr::RHO_INF, -1.0, false).describe(
            "spectral radius at infinity of the generalized-alpha integrator, in [0, 1]; negative: the scene's value",
        ));
        variables.push(Variable::parameter("newton_tol", vr::NEWTON_TOL, -1.0, false).unit("m").describe(
            "Newton tolerance on the largest position correction (rad for rotations); non-positive: the scene's value",
        ));
        variables.push(
            Variable::parameter("elements_per_cable", vr::ELEMENTS, 0, false)
                .describe("finite elements per cable; 0: the scene's value"),
        );
        variables.push(Variable::parameter("scene", vr::SCENE, DEFAULT_SCENE, false).describe(
            "scene file (TOML); relative paths resolve inside resources/, which holds lt50m_B.toml and lt50m_C.toml",
        ));
        Ok(ModelDescription::co_simulation(
            "cable_fmu",
            "{3c0b5e9a-7d41-4f8e-b2a6-1e9d4c7f6a03}",
            "Six-cable finite-element net carrying the feed cabin (LT50m); input: the Stewart platform's wrench",
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
        Ok(CableFmu {
            resources: resources.map(Path::to_owned),
            settings: Settings {
                scene_name: DEFAULT_SCENE.into(),
                elements: 0,
                damping_ratio: -1.0,
                rho_inf: -1.0,
                newton_tol: -1.0,
            },
            // Inputs start at their declared start values (FMI 2.0): scene C's static wrench.
            wrench: static_wrench(&scene),
            scene,
            nominal: None,
            built_for: None,
            balanced: None,
            dynamics: None,
            start_wrench: Vector6::zeros(),
            wrench_rate: Vector6::zeros(),
            tensions: [(0.0, 0.0); CABLES],
            scratch: std::cell::RefCell::new(Vec::new()),
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::WRENCH..vr::POSITION => self.wrench[(vr - vr::WRENCH) as usize] = value,
            vr::DAMPING_RATIO => {
                if !(value < 1.0) {
                    return Err(
                        format!("damping_ratio = {value}: must be below 1 (negative: the scene's value)").into()
                    );
                }
                self.settings.damping_ratio = value;
                self.settings_changed();
            }
            vr::RHO_INF => {
                if value > 1.0 {
                    return Err(format!("rho_inf = {value}: must lie in [0, 1] (negative: the scene's value)").into());
                }
                self.settings.rho_inf = value;
                self.settings_changed();
            }
            vr::NEWTON_TOL => {
                self.settings.newton_tol = value;
                self.settings_changed();
            }
            _ => return Err(format!("value reference {vr} is not a settable Real").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            vr::WRENCH..vr::POSITION => Ok(self.wrench[(vr - vr::WRENCH) as usize]),
            vr::DAMPING_RATIO => Ok(self.settings.damping_ratio),
            vr::RHO_INF => Ok(self.settings.rho_inf),
            vr::NEWTON_TOL => Ok(self.settings.newton_tol),
            vr::POSITION..vr::DAMPING_RATIO => Ok(self.output_values()?[(vr - vr::POSITION) as usize]),
            _ => Err(format!("value reference {vr} is not a Real of this model").into()),
        }
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), ModelError> {
        if vr != vr::ELEMENTS {
            return Err(format!("value reference {vr} is not a settable Integer").into());
        }
        if value < 0 {
            return Err(format!("elements_per_cable = {value}: must be at least 1 (0: the scene's value)").into());
        }
        let settings = Settings { elements: value, ..self.settings.clone() };
        self.effective_scene(&settings)?; // refuses what would not fit, before anything is built
        self.settings = settings;
        self.settings_changed();
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        if vr != vr::ELEMENTS {
            return Err(format!("value reference {vr} is not an Integer of this model").into());
        }
        Ok(self.settings.elements)
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

    /// At rest at the target pose under the wrench held now.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.balanced()?;
        let balanced = self.balanced.as_ref().expect("built above");
        let model = balanced.model.as_deref().unwrap_or(self.nominal.as_ref().expect("built"));
        let dy = model.dynamics_with(Payload::External, start_time, &self.wrench)?;
        dy.end_tensions(&mut self.tensions);
        self.dynamics = Some(dy);
        self.start_wrench = self.wrench;
        self.balanced = None;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let w = self.wrench + self.wrench_rate * h;
        self.wrench_rate = Vector6::zeros(); // input derivatives apply to one step
        let dy = self.dynamics.as_mut().ok_or("the model is not initialized")?;
        dy.step(h, &w)?;
        dy.end_tensions(&mut self.tensions);
        // A non-finite state must not be reported as a successful step.
        let y = self.output_values()?;
        if let Some(k) = y.iter().position(|x| !x.is_finite()) {
            let name = &outputs()[k].0;
            return Err(format!(
                "`{name}` = {} at t = {}: the motion diverged (wrench {:?})",
                y[k],
                t + h,
                w.as_slice()
            )
            .into());
        }
        Ok(StepOutcome::Complete)
    }

    fn set_real_input_derivative(&mut self, vr: u32, _order: i32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::WRENCH..vr::POSITION => {
                self.wrench_rate[(vr - vr::WRENCH) as usize] = value;
                Ok(())
            }
            _ => Err(format!("value reference {vr} is not an input").into()),
        }
    }

    /// At an instant: in step mode nothing responds to the wrench; in initialization mode the
    /// tensions do, through the form finding.
    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        let dw = Self::wrench_seed(knowns, seed)?;
        out.fill(0.0);
        if self.dynamics.is_some() || !unknowns.iter().any(|u| is_tension(*u)) {
            return Ok(());
        }
        self.balanced()?;
        let b = self.balanced.as_ref().expect("built above");
        let m = b.model.as_deref().unwrap_or(self.nominal.as_ref().expect("built"));
        let s = crate::statics::tension_wrench_sensitivity(&m.net, &m.equilibrium)?;
        for (o, u) in out.iter_mut().zip(unknowns) {
            if is_tension(*u) {
                let (cable, end) = if *u < vr::TENSION_CABIN {
                    ((u - vr::TENSION_ANCHOR) as usize, 0)
                } else {
                    ((u - vr::TENSION_CABIN) as usize, 1)
                };
                *o = (0..6).map(|k| s[cable][end][k] * dw[k]).sum();
            }
        }
        Ok(())
    }

    fn step_map_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), ModelError> {
        let dw = Self::wrench_seed(knowns, seed)?;
        let dy = match &mut self.dynamics {
            Some(dy) if dy.state.last_step.is_some() => dy,
            _ => return Err("no step has been taken yet: the step map is defined after fmi2DoStep".into()),
        };
        let q = dy.cabin().orientation.into_inner();
        let d = dy.wrench_sensitivity(&dw)?;
        for (o, u) in out.iter_mut().zip(unknowns) {
            *o = delta_output(&d, &q, *u).ok_or_else(|| format!("value reference {u} is not an output"))?;
        }
        Ok(())
    }

    fn save_state(&self, out: &mut Vec<u8>) -> Result<(), ModelError> {
        let mut w = StateWriter::new(out);
        let s = &self.settings;
        w.str(&s.scene_name).i32(s.elements).f64(s.damping_ratio).f64(s.rho_inf).f64(s.newton_tol);
        for k in 0..6 {
            w.f64(self.wrench[k]).f64(self.wrench_rate[k]);
        }
        match &self.dynamics {
            Some(dy) => {
                let mut numbers = self.scratch.borrow_mut();
                numbers.clear();
                dy.encode_state(&mut numbers);
                w.bool(true).f64s(self.start_wrench.as_slice()).f64s(&numbers);
            }
            None => {
                w.bool(false);
            }
        }
        Ok(())
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), ModelError> {
        let mut r = StateReader::new(bytes);
        let settings = Settings {
            scene_name: r.string()?,
            elements: r.i32()?,
            damping_ratio: r.f64()?,
            rho_inf: r.f64()?,
            newton_tol: r.f64()?,
        };
        let mut wrench = Vector6::zeros();
        let mut wrench_rate = Vector6::zeros();
        for k in 0..6 {
            wrench[k] = r.f64()?;
            wrench_rate[k] = r.f64()?;
        }
        let has_dynamics = r.bool()?;
        let mut start_wrench = Vector6::zeros();
        let mut numbers = std::mem::take(&mut *self.scratch.borrow_mut());
        if has_dynamics {
            r.f64s_into(start_wrench.as_mut_slice())?;
            r.f64s_to_vec(&mut numbers)?;
        }
        r.finish()?;
        // A state carries its parameters: an instance configured otherwise adopts them (the
        // scene is looked up under the same rules as the parameter).
        if settings != self.settings {
            if settings.scene_name != self.settings.scene_name {
                self.scene = load_scene(&settings.scene_name, self.resources.as_deref())?;
            }
            self.effective_scene(&settings)?;
            self.settings = settings;
            self.settings_changed();
            self.dynamics = None;
        }
        self.wrench = wrench;
        self.wrench_rate = wrench_rate;
        let result = if has_dynamics {
            if self.dynamics.is_none() || start_wrench != self.start_wrench {
                // The cable lengths follow from the wrench the state started under: rebuild the
                // model for it (the state then replaces the motion).
                let nominal = self.nominal()?;
                let under = if start_wrench == nominal.static_payload_wrench() {
                    None
                } else {
                    Some(nominal.under_wrench(&start_wrench)?)
                };
                let model = under.as_ref().unwrap_or(nominal);
                self.dynamics = Some(model.dynamics_with(Payload::External, 0.0, &start_wrench)?);
                self.start_wrench = start_wrench;
            }
            let dy = self.dynamics.as_mut().expect("built above");
            let r = dy.decode_state(&numbers);
            dy.end_tensions(&mut self.tensions);
            r.map_err(ModelError::from)
        } else {
            self.dynamics = None;
            self.balanced = None;
            Ok(())
        };
        *self.scratch.borrow_mut() = numbers;
        result
    }
}
