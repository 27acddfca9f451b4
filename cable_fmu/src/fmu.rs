//! The cable–cabin model as an FMI 2.0 Co-Simulation FMU (`cable_fmu`): the FMU-facing
//! variables of [`crate::model::CableCabin`] with an external Stewart platform.
//!
//! Input: the wrench the Stewart platform exerts on the cabin (force; moment about the cabin
//! centre point; world frame). Its start values are the static wrench of the platform at its
//! starting pose, so that the FMU run alone with its inputs held stays at rest. Outputs: the
//! cabin centre point's motion and both end tensions of every cable. Parameters: the scene file
//! (relative paths resolve against `resources/`, which ships both reference scenes) and scalars
//! that override the scene when set to a positive value.
//!
//! `fmi2DoStep` integrates one step with the wrench held (or extrapolated with its first
//! derivative) to the end of the step. Directional derivatives are those of the step map: the
//! outputs after the last step with respect to the wrench used in it, exact (from the converged
//! iteration matrix); before the first step, the direct feedthrough to the accelerations.

use std::path::{Path, PathBuf};

use feedcore::Vec3;
use feedcore::scene::Scene;
use fmi2::export::Model;
use fmi2::state_bytes::{StateReader, StateWriter};
use fmi2::{Capabilities, DefaultExperiment, ModelDescription, Resource, Variable};
use nalgebra::Vector6;

use crate::dynamics::{CabinDelta, Dynamics};
use crate::model::{CableCabin, Payload};

/// Cables the FMU exposes (the LT50m net).
pub const CABLES: usize = 6;
/// The scene used unless the `scene` parameter names another one.
pub const DEFAULT_SCENE: &str = "lt50m_C.toml";

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

pub struct CableFmu {
    resources: Option<PathBuf>,
    settings: Settings,
    /// The scene file as loaded (before the scalar overrides); `None` until one was read.
    scene: Option<Scene>,
    /// The model built for `built_for`.
    model: Option<CableCabin>,
    built_for: Option<Settings>,
    dynamics: Option<Dynamics>,
    initialized: bool,
    wrench: Vector6<f64>,
    wrench_rate: Vector6<f64>,
    /// Which wrench components the importer has set (the others follow the scene's static wrench).
    wrench_set: [bool; 6],
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

impl CableFmu {
    /// The scene with the scalar overrides applied and validated.
    fn effective_scene(&self) -> Result<Scene, String> {
        let mut s = self.scene.clone().ok_or("no scene loaded")?;
        let st = &self.settings;
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
        s.validate(&st.scene_name).map_err(|e| e.to_string())?;
        if s.cable_count() != CABLES {
            return Err(format!("scene `{}` has {} cables; this FMU exposes {CABLES}", st.scene_name, s.cable_count()));
        }
        Ok(s)
    }

    /// The model and (before initialization ends) dynamics at rest under the current inputs.
    fn ensure_built(&mut self) -> Result<(), String> {
        if self.built_for.as_ref() != Some(&self.settings) || self.model.is_none() {
            let scene = self.effective_scene()?;
            let static_w = static_wrench(&scene);
            for k in 0..6 {
                if !self.wrench_set[k] {
                    self.wrench[k] = static_w[k];
                }
            }
            self.model = Some(CableCabin::build(&scene, 0).map_err(|e| e.to_string())?);
            self.built_for = Some(self.settings.clone());
            self.dynamics = None;
        }
        if self.dynamics.is_none() || !self.initialized {
            let model = self.model.as_ref().expect("built above");
            let dy = model.dynamics_with(Payload::External, 0.0, &self.wrench).map_err(|e| e.to_string())?;
            dy.end_tensions(&mut self.tensions);
            self.dynamics = Some(dy);
        }
        Ok(())
    }

    fn dynamics(&mut self) -> Result<&mut Dynamics, String> {
        self.ensure_built()?;
        Ok(self.dynamics.as_mut().expect("built"))
    }

    /// A change of the settings discards the model (it is rebuilt when next needed).
    fn settings_changed(&mut self) {
        self.model = None;
        self.dynamics = None;
        self.built_for = None;
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
    fn description() -> ModelDescription {
        let default = Scene::from_toml(feedcore::shipped::embedded(DEFAULT_SCENE).expect("shipped"), DEFAULT_SCENE)
            .expect("valid");
        let w0 = static_wrench(&default);
        let inputs = input_names();
        let mut variables: Vec<Variable> = inputs
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let unit = if k < 3 { "N" } else { "N.m" };
                let what = if k < 3 { "force" } else { "moment about the cabin centre point" };
                Variable::real_input(name.clone(), vr::WRENCH + k as u32, w0[k], unit)
                    .describe(format!("{what} the Stewart platform exerts on the cabin, world frame"))
            })
            .collect();
        for (k, (name, unit, what)) in outputs().into_iter().enumerate() {
            variables
                .push(Variable::real_output(name, vr::POSITION + k as u32, unit).describe(what).depends_on(&inputs));
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
            "scene file (TOML); relative paths resolve against resources/, which holds lt50m_B.toml and lt50m_C.toml",
        ));
        ModelDescription {
            model_name: "cable_fmu".into(),
            model_identifier: "cable_fmu".into(),
            guid: "{3c0b5e9a-7d41-4f8e-b2a6-1e9d4c7f6a02}".into(),
            description:
                "Six-cable finite-element net carrying the feed cabin (LT50m); input: the Stewart platform's wrench"
                    .into(),
            version: env!("CARGO_PKG_VERSION").into(),
            capabilities: Capabilities { provides_directional_derivative: true, can_interpolate_inputs: true },
            default_experiment: Some(DefaultExperiment {
                start_time: 0.0,
                stop_time: 100.0,
                step_size: 0.01,
                tolerance: None,
            }),
            extra_units: vec![],
            variables,
        }
    }

    fn resources() -> Vec<Resource> {
        feedcore::shipped::SCENES
            .iter()
            .map(|(n, text)| Resource { name: n.to_string(), bytes: text.as_bytes().to_vec() })
            .collect()
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, String> {
        let mut m = CableFmu {
            resources: resources.map(Path::to_owned),
            settings: Settings {
                scene_name: DEFAULT_SCENE.into(),
                elements: 0,
                damping_ratio: -1.0,
                rho_inf: -1.0,
                newton_tol: -1.0,
            },
            scene: None,
            model: None,
            built_for: None,
            dynamics: None,
            initialized: false,
            wrench: Vector6::zeros(),
            wrench_rate: Vector6::zeros(),
            wrench_set: [false; 6],
            tensions: [(0.0, 0.0); CABLES],
            scratch: std::cell::RefCell::new(Vec::new()),
        };
        let scene = feedcore::shipped::load_scene_parameter(DEFAULT_SCENE, m.resources.as_deref())?;
        m.wrench = static_wrench(&scene);
        m.scene = Some(scene);
        Ok(m)
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        match vr {
            vr::WRENCH..vr::POSITION => {
                let k = (vr - vr::WRENCH) as usize;
                self.wrench[k] = value;
                self.wrench_set[k] = true;
                if !self.initialized {
                    self.dynamics = None; // outputs before initialization follow the inputs
                }
            }
            vr::DAMPING_RATIO => {
                if !(value < 1.0) {
                    return Err(format!("damping_ratio = {value}: must be below 1 (negative: the scene's value)"));
                }
                self.settings.damping_ratio = value;
                self.settings_changed();
            }
            vr::RHO_INF => {
                if value > 1.0 {
                    return Err(format!("rho_inf = {value}: must lie in [0, 1] (negative: the scene's value)"));
                }
                self.settings.rho_inf = value;
                self.settings_changed();
            }
            vr::NEWTON_TOL => {
                self.settings.newton_tol = value;
                self.settings_changed();
            }
            _ => return Err(format!("value reference {vr} is not a settable Real")),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, String> {
        match vr {
            vr::WRENCH..vr::POSITION => return Ok(self.wrench[(vr - vr::WRENCH) as usize]),
            vr::DAMPING_RATIO => return Ok(self.settings.damping_ratio),
            vr::RHO_INF => return Ok(self.settings.rho_inf),
            vr::NEWTON_TOL => return Ok(self.settings.newton_tol),
            _ => {}
        }
        let tensions = self.tensions;
        let c = self.dynamics()?.cabin();
        let q = c.orientation.quaternion();
        let v3 = |v: &Vec3, base: u32| v[(vr - base) as usize];
        Ok(match vr {
            vr::POSITION..vr::ORIENTATION => v3(&c.position, vr::POSITION),
            vr::ORIENTATION..vr::VELOCITY => [q.w, q.i, q.j, q.k][(vr - vr::ORIENTATION) as usize],
            vr::VELOCITY..vr::ANGULAR_VELOCITY => v3(&c.velocity, vr::VELOCITY),
            vr::ANGULAR_VELOCITY..vr::ACCELERATION => v3(&c.angular_velocity, vr::ANGULAR_VELOCITY),
            vr::ACCELERATION..vr::ANGULAR_ACCELERATION => v3(&c.acceleration, vr::ACCELERATION),
            vr::ANGULAR_ACCELERATION..vr::TENSION_ANCHOR => v3(&c.angular_acceleration, vr::ANGULAR_ACCELERATION),
            vr::TENSION_ANCHOR..vr::TENSION_CABIN => tensions[(vr - vr::TENSION_ANCHOR) as usize].0,
            vr::TENSION_CABIN..vr::DAMPING_RATIO => tensions[(vr - vr::TENSION_CABIN) as usize].1,
            _ => return Err(format!("value reference {vr} is not a Real of this model")),
        })
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), String> {
        if vr != vr::ELEMENTS {
            return Err(format!("value reference {vr} is not a settable Integer"));
        }
        if value < 0 {
            return Err(format!("elements_per_cable = {value}: must be at least 1 (0: the scene's value)"));
        }
        self.settings.elements = value;
        self.settings_changed();
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, String> {
        if vr != vr::ELEMENTS {
            return Err(format!("value reference {vr} is not an Integer of this model"));
        }
        Ok(self.settings.elements)
    }

    fn set_string(&mut self, vr: u32, value: &str) -> Result<(), String> {
        if vr != vr::SCENE {
            return Err(format!("value reference {vr} is not a settable String"));
        }
        let scene = feedcore::shipped::load_scene_parameter(value, self.resources.as_deref())?;
        self.scene = Some(scene);
        self.settings.scene_name = value.to_string();
        self.settings_changed();
        Ok(())
    }

    fn get_string(&mut self, vr: u32) -> Result<String, String> {
        if vr != vr::SCENE {
            return Err(format!("value reference {vr} is not a String of this model"));
        }
        Ok(self.settings.scene_name.clone())
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), String> {
        self.ensure_built()?;
        let model = self.model.as_ref().expect("built");
        let dy = model.dynamics_with(Payload::External, start_time, &self.wrench).map_err(|e| e.to_string())?;
        dy.end_tensions(&mut self.tensions);
        self.dynamics = Some(dy);
        self.initialized = true;
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64) -> Result<(), String> {
        let w = self.wrench + self.wrench_rate * h;
        self.wrench_rate = Vector6::zeros(); // input derivatives apply to one step
        let dy = self.dynamics.as_mut().ok_or("the model is not initialized")?;
        dy.step(h, &w).map_err(|e| e.to_string())?;
        dy.end_tensions(&mut self.tensions);
        Ok(())
    }

    fn set_real_input_derivative(&mut self, vr: u32, _order: i32, value: f64) -> Result<(), String> {
        match vr {
            vr::WRENCH..vr::POSITION => {
                self.wrench_rate[(vr - vr::WRENCH) as usize] = value;
                Ok(())
            }
            _ => Err(format!("value reference {vr} is not an input")),
        }
    }

    fn directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        let mut dw = Vector6::zeros();
        for (k, s) in knowns.iter().zip(seed) {
            match *k {
                vr::WRENCH..vr::POSITION => dw[(*k - vr::WRENCH) as usize] += s,
                other => {
                    return Err(format!(
                        "derivatives with respect to value reference {other} are not provided (only the wrench inputs)"
                    ));
                }
            }
        }
        let dy = self.dynamics()?;
        let q = dy.cabin().orientation.into_inner();
        let d = dy.wrench_sensitivity(&dw).map_err(|e| e.to_string())?;
        for (o, u) in out.iter_mut().zip(unknowns) {
            *o = delta_output(&d, &q, *u).ok_or_else(|| format!("value reference {u} is not an output"))?;
        }
        Ok(())
    }

    fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = StateWriter::new(out);
        let s = &self.settings;
        w.str(&s.scene_name)
            .i32(s.elements)
            .f64(s.damping_ratio)
            .f64(s.rho_inf)
            .f64(s.newton_tol)
            .bool(self.initialized);
        for k in 0..6 {
            w.f64(self.wrench[k]).f64(self.wrench_rate[k]).bool(self.wrench_set[k]);
        }
        match &self.dynamics {
            Some(dy) if self.initialized => {
                let mut numbers = self.scratch.borrow_mut();
                numbers.clear();
                dy.encode_state(&mut numbers);
                w.bool(true).f64s(&numbers);
            }
            _ => {
                w.bool(false);
            }
        }
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = StateReader::new(bytes);
        let settings = Settings {
            scene_name: r.string()?,
            elements: r.i32()?,
            damping_ratio: r.f64()?,
            rho_inf: r.f64()?,
            newton_tol: r.f64()?,
        };
        // A state carries its parameters: an instance configured otherwise adopts them.
        if settings != self.settings {
            if settings.scene_name != self.settings.scene_name {
                self.scene =
                    Some(feedcore::shipped::load_scene_parameter(&settings.scene_name, self.resources.as_deref())?);
            }
            self.settings = settings;
            self.settings_changed();
        }
        let initialized = r.bool()?;
        let mut wrench = Vector6::zeros();
        let mut wrench_rate = Vector6::zeros();
        let mut wrench_set = [false; 6];
        for k in 0..6 {
            wrench[k] = r.f64()?;
            wrench_rate[k] = r.f64()?;
            wrench_set[k] = r.bool()?;
        }
        let has_dynamics = r.bool()?;
        let mut numbers = std::mem::take(&mut *self.scratch.borrow_mut());
        if has_dynamics {
            r.f64s_to_vec(&mut numbers)?;
        }
        r.finish()?;
        self.wrench = wrench;
        self.wrench_rate = wrench_rate;
        self.wrench_set = wrench_set;
        self.initialized = initialized;
        self.ensure_built()?;
        let result = if has_dynamics {
            let dy = self.dynamics.as_mut().expect("built");
            let r = dy.decode_state(&numbers).map_err(|e| e.to_string());
            dy.end_tensions(&mut self.tensions);
            r
        } else {
            Ok(())
        };
        *self.scratch.borrow_mut() = numbers;
        result
    }
}
