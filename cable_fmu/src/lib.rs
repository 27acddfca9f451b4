//! The cable–cabin model as an FMI 2.0 Co-Simulation FMU (`cable_fmu`): the FMU-facing
//! variables of [``cable::model::CableCabin` with an external Stewart platform.
//!
//! Input: the wrench the Stewart platform exerts on the cabin (force; moment about the cabin
//! centre point; world frame). Outputs: the cabin centre point's motion and both end tensions of
//! every cable. Parameters: the scene file (relative paths resolve inside `resources/`, which
//! ships both reference scenes) and scalars that override the scene when set to a positive value.
//!
//! Initialization: the FMU starts at rest at the scene's target pose under the wrench it holds
//! at `fmi2ExitInitializationMode` — the unstretched cable lengths are form-found for that
//! wrench. In initialization mode the outputs are that start: the target pose, zero velocities
//! and accelerations, and the end tensions of the equilibrium under the current wrench. With the
//! scene's `[motion] start = "consistent"` the cabin leaves initialization mode with the velocity
//! that keeps the momentum of cabin and platform at zero (`CableCabin::start_twist`).
//!
//! `fmi2DoStep` integrates one step with the wrench held (or extrapolated with its first
//! derivative) to the end of the step. No output responds to the wrench at a communication
//! point (the accelerations reported are those of the state reached, under the wrench held
//! during the step): `<Outputs>` declares no dependency and `fmi2GetDirectionalDerivative` is
//! zero in step mode. In initialization mode the tensions depend on the wrench through the form
//! finding, exactly. The step map (outputs after a step with respect to the wrench held during
//! it) is the extension `feedsimGetStepMapDerivative`, exact from the converged iteration matrix.

use std::any::Any;
use std::path::Path;

use feedcore::Vec3;
use feedcore::scene::{SceneError, ValidScene};
use fmi::description::Causality;
use fmi::export::{Derivative, Model, ModelError, Reals, Seeds, StepOutcome};
use fmi::resources::{FileKind, FileParameter, KeptFile, SavedFile};
use fmi::{CoSimulationFlags, ModelDescription, Resource, Variable};
use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

use cable::dynamics::{CabinDelta, Dynamics};
use cable::model::{CableCabin, Payload};

/// Cables the FMU exposes (the LT50m net).
pub(crate) const CABLES: usize = 6;
/// The scene used unless the `scene` parameter names another one.
pub const DEFAULT_SCENE: &str = "lt50m_C.toml";
/// Identifies the variable table: change it whenever the table changes.
pub const GUID: &str = "{3c0b5e9a-7d41-4f8e-b2a6-1e9d4c7f6a03}";
/// Number of Real outputs.
const OUTPUTS: usize = fmi::table::count(vr::TABLE, Causality::Output);

/// The variables: value references (separate spaces per type) and, for the Real ones, the table
/// the description and the names come from.
pub mod vr {
    use super::CABLES;
    use fmi::table::Block;

    const XYZ: &[&str] = &["x", "y", "z"];
    const WXYZ: &[&str] = &["w", "x", "y", "z"];
    /// Cables are numbered from 0, as the statics and the scenes number them.
    const CABLE_NUMBERS: &[&str; CABLES] = &["0", "1", "2", "3", "4", "5"];
    /// 1e7 N (N·m): thirty times the weight of FAST's 30 t cabin; only a mistaken or hostile
    /// value lies beyond.
    const WRENCH_BOUND: f64 = 1e7;

    fmi::variable_table! {
        /// Real inputs: the wrench on the cabin, force then moment.
        FORCE = Block::input("wrench.f", 3, "N",
            "force the Stewart platform exerts on the cabin, world frame (start: scene C's static value)")
            .range(-WRENCH_BOUND, WRENCH_BOUND),
        MOMENT = Block::input("wrench.m", 3, "N.m",
            "moment about the cabin centre point the Stewart platform exerts on the cabin, world frame (start: scene C's static value)")
            .range(-WRENCH_BOUND, WRENCH_BOUND),
        /// Real outputs: the cabin's motion; the tensions next to the anchors and next to the cabin.
        POSITION = Block::output("cabin.r", 3, "m", "position of the cabin centre point, world {k}").labels(XYZ),
        ORIENTATION = Block::output("cabin.q", 4, "", "orientation of the cabin, unit quaternion body to world ({k}), world frame").labels(WXYZ),
        VELOCITY = Block::output("cabin.v", 3, "m/s", "velocity of the cabin centre point, world {k}").labels(XYZ),
        ANGULAR_VELOCITY = Block::output("cabin.w", 3, "rad/s", "angular velocity of the cabin, world {k}").labels(XYZ),
        ACCELERATION = Block::output("cabin.a", 3, "m/s2", "acceleration of the cabin centre point, world {k}").labels(XYZ),
        ANGULAR_ACCELERATION = Block::output("cabin.alpha", 3, "rad/s2", "angular acceleration of the cabin, world {k}").labels(XYZ),
        TENSION_ANCHOR = Block::output("cable.tension_anchor", CABLES as u32, "N", "axial force of the element next to the tower, cable {k}")
            .labels(CABLE_NUMBERS),
        TENSION_CABIN = Block::output("cable.tension_cabin", CABLES as u32, "N", "axial force of the element next to the cabin, cable {k}")
            .labels(CABLE_NUMBERS),
        /// Real parameters.
        DAMPING_RATIO = Block::parameter("damping_ratio", -1.0, "",
            "Rayleigh damping ratio of the cable structure; negative: the scene's value"),
        RHO_INF = Block::parameter("rho_inf", -1.0, "",
            "spectral radius at infinity of the generalized-alpha integrator, in [0, 1]; negative: the scene's value"),
        NEWTON_TOL = Block::parameter("newton_tol", -1.0, "m",
            "Newton tolerance on the largest position correction (rad for rotations); non-positive: the scene's value"),
    }
    /// The wrench inputs, force then moment, as one 6-vector.
    pub const WRENCH: u32 = FORCE;
    /// Integer `elements_per_cable`.
    pub const ELEMENTS: u32 = 0;
    /// String `scene`.
    pub const SCENE: u32 = 0;
}

/// The momentum of the platform's start relative to the cabin, for a momentum-consistent
/// start ([`CableCabin::start_twist`]); the other starts do not need the platform's model.
fn platform_start_momentum(scene: &ValidScene) -> Result<Vector6<f64>, ModelError> {
    if scene.motion.start != feedcore::scene::Start::Consistent {
        return Ok(Vector6::zeros());
    }
    let momentum = stewart::Stewart::from_scene(scene).and_then(|s| s.start_momentum());
    momentum.map_err(|e| ModelError::from(format!("the momentum-consistent start: {e}")))
}

/// Scene files: shipped in `resources/` and compiled in; at most 1 MiB.
static SCENES: FileKind<ValidScene, SceneError> =
    FileKind::new(&feedcore::shipped::SCENES, 1 << 20, feedcore::scene::Scene::from_toml);

/// The scalar parameters that modify the scene; each is the scene's value when not positive
/// (`damping_ratio`, `rho_inf`: when negative).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Settings {
    elements: i32,
    damping_ratio: f64,
    rho_inf: f64,
    newton_tol: f64,
}

/// The model at rest under one wrench.
struct Balanced {
    wrench: Vector6<f64>,
    /// `None`: the nominal model is in equilibrium under this wrench (the platform's weight).
    model: Option<Box<CableCabin>>,
    tensions: [(f64, f64); CABLES],
}

pub struct CableFmu {
    /// The scene file as loaded (before the scalar overrides).
    scene: FileParameter<ValidScene, SceneError>,
    settings: Settings,
    /// The model for the current scene and settings, in equilibrium under the platform's own
    /// weight (built when first needed, dropped when they change).
    nominal: Option<CableCabin>,
    /// Initialization mode: the equilibrium under the wrench last asked about.
    balanced: Option<Balanced>,
    /// Step mode, and the wrench the model was form-found for (it fixes the cable lengths).
    dynamics: Option<Dynamics>,
    start_wrench: Vector6<f64>,
    wrench: Vector6<f64>,
    wrench_rate: Vector6<f64>,
    tensions: [(f64, f64); CABLES],
    /// Reused buffer for saving and restoring the dynamics state (no allocation per rollback).
    scratch: Vec<f64>,
}

/// A saved state: the parameters, the inputs and, in step mode, the motion.
#[derive(Serialize, Deserialize)]
pub struct SavedCable<'a> {
    #[serde(borrow)]
    scene: SavedFile<'a>,
    settings: Settings,
    wrench: [f64; 6],
    wrench_rate: [f64; 6],
    #[serde(borrow)]
    motion: Option<SavedMotion<'a>>,
}

/// The wrench the cable lengths were form-found for, and [`Dynamics::encode_state`].
#[derive(Serialize, Deserialize)]
struct SavedMotion<'a> {
    start_wrench: [f64; 6],
    #[serde(borrow)]
    numbers: Reals<'a>,
}

/// The static wrench of the scene's Stewart platform at its starting pose (the input start).
fn static_wrench(scene: &ValidScene) -> Vector6<f64> {
    let net = cable::net::CableNet::from_scene(scene);
    net.payload.weight_wrench(&scene.target_orientation(), &net.spec.gravity)
}

/// The motion of a saved state: the numbers of its bytes, or a state kept in memory.
enum Kept<'a> {
    Numbers(Reals<'a>),
    Memory(&'a cable::dynamics::State),
}

/// A state of the cable FMU kept in memory ([`Model::save_in_memory`]).
#[derive(Default)]
struct InMemory {
    scene: KeptFile,
    settings: Settings,
    wrench: Vector6<f64>,
    wrench_rate: Vector6<f64>,
    /// In step mode: the wrench the cable lengths were form-found for.
    start_wrench: Option<Vector6<f64>>,
    motion: Option<cable::dynamics::State>,
}

/// The names of the inputs, in value-reference order from 0.
pub fn input_names() -> Vec<String> {
    fmi::table::names(vr::TABLE, Causality::Input)
}

/// The names of the outputs, in value-reference order from [`vr::POSITION`].
pub fn output_names() -> Vec<String> {
    fmi::table::names(vr::TABLE, Causality::Output)
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

/// The scene with the scalar overrides `st` applied and validated.
fn effective_scene(scene: &FileParameter<ValidScene, SceneError>, st: &Settings) -> Result<ValidScene, ModelError> {
    let mut s = scene.value().to_scene();
    if st.elements > 0 {
        s.cables.elements = st.elements as usize;
    }
    for (value, target) in [(st.damping_ratio, &mut s.damping.ratio), (st.rho_inf, &mut s.solver.rho_inf)] {
        if value >= 0.0 {
            *target = value;
        }
    }
    if st.newton_tol > 0.0 {
        s.solver.newton_tol = st.newton_tol;
    }
    let name = scene.label();
    let s = s.validated(name)?;
    if s.cable_count() != CABLES {
        return Err(format!("scene `{name}` has {} cables; this FMU exposes {CABLES}", s.cable_count()).into());
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

/// The nominal model in `slot`, built for the scene and settings if it is not there.
fn nominal<'a>(
    slot: &'a mut Option<CableCabin>,
    scene: &FileParameter<ValidScene, SceneError>,
    settings: &Settings,
) -> Result<&'a CableCabin, ModelError> {
    let model = match slot.take() {
        Some(m) => m,
        None => CableCabin::build(&effective_scene(scene, settings)?, 0)?,
    };
    Ok(slot.insert(model))
}

impl CableFmu {
    /// Restores a saved state from its parts: the parameters (adopted when they differ), the
    /// inputs, and (in step mode) the wrench the cable lengths were form-found for with the motion.
    fn restore_parts(
        &mut self,
        scene: SavedFile<'_>,
        settings: Settings,
        wrenches: (Vector6<f64>, Vector6<f64>),
        motion: Option<(Vector6<f64>, Kept<'_>)>,
    ) -> Result<(), ModelError> {
        // A state carries its parameters: an instance configured otherwise adopts them (the
        // scene is looked up under the same rules as the parameter).
        if self.scene.restore(scene)? || settings != self.settings {
            effective_scene(&self.scene, &settings)?;
            self.settings = settings;
            self.settings_changed();
            self.dynamics = None;
        }
        (self.wrench, self.wrench_rate) = wrenches;
        let Some((start_wrench, kept)) = motion else {
            self.dynamics = None;
            self.balanced = None;
            return Ok(());
        };
        let dy = match self.dynamics.take() {
            Some(dy) if start_wrench == self.start_wrench => dy,
            _ => {
                // The cable lengths follow from the wrench the state started under: rebuild the
                // model for it (the state then replaces the motion).
                let nominal = nominal(&mut self.nominal, &self.scene, &self.settings)?;
                let under = if start_wrench == nominal.static_payload_wrench() {
                    None
                } else {
                    Some(nominal.under_wrench(&start_wrench)?)
                };
                self.start_wrench = start_wrench;
                under.as_ref().unwrap_or(nominal).dynamics_with(Payload::External, 0.0, &start_wrench)?
            }
        };
        let dy = self.dynamics.insert(dy);
        let result = match kept {
            Kept::Numbers(numbers) => {
                numbers.copy_into(&mut self.scratch);
                dy.decode_state(&self.scratch)
            }
            Kept::Memory(state) => dy.restore_from(state),
        };
        dy.end_tensions(&mut self.tensions);
        result.map_err(ModelError::from)
    }

    /// The equilibrium at the target pose under the current wrench (initialization mode): the
    /// model form-found for it, its end tensions, and the nominal model.
    fn balanced(&mut self) -> Result<(&CableCabin, &Balanced, &CableCabin), ModelError> {
        let w = self.wrench;
        let had_nominal = self.nominal.is_some();
        let nominal = nominal(&mut self.nominal, &self.scene, &self.settings)?;
        let balanced = match self.balanced.take() {
            Some(b) if had_nominal && b.wrench == w => b,
            _ => {
                // Bit for bit the platform's own weight: the nominal equilibrium is the one.
                let model =
                    if w == nominal.static_payload_wrench() { None } else { Some(Box::new(nominal.under_wrench(&w)?)) };
                let m = model.as_deref().unwrap_or(nominal);
                let mut tensions = [(0.0, 0.0); CABLES];
                m.system(Payload::External).end_tensions(&m.equilibrium_config(), &mut tensions);
                Balanced { wrench: w, model, tensions }
            }
        };
        let b = self.balanced.insert(balanced);
        Ok((b.model.as_deref().unwrap_or(nominal), b, nominal))
    }

    /// A change of the scene or the settings discards the models (rebuilt when next needed).
    fn settings_changed(&mut self) {
        self.nominal = None;
        self.balanced = None;
    }

    /// All outputs now, in value-reference order.
    fn output_values(&mut self) -> Result<[f64; OUTPUTS], ModelError> {
        let mut y = [0.0; OUTPUTS];
        let (motion, tensions) = match &self.dynamics {
            Some(dy) => (dy.cabin(), self.tensions),
            None => {
                let (_, balanced, nominal) = self.balanced()?;
                let eq = &nominal.equilibrium;
                let rest = feedcore::rigid::RigidMotion {
                    position: eq.position,
                    orientation: eq.orientation,
                    velocity: Vec3::zeros(),
                    angular_velocity: Vec3::zeros(),
                    acceleration: Vec3::zeros(),
                    angular_acceleration: Vec3::zeros(),
                };
                (rest, balanced.tensions)
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

    /// At an instant: in step mode nothing responds to the wrench; in initialization mode the
    /// tensions do, through the form finding.
    fn instant_derivative(&mut self, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        let dw = Self::wrench_seed(at.knowns, at.seed)?;
        out.fill(0.0);
        if self.dynamics.is_some() || !at.unknowns.iter().any(|u| is_tension(*u)) {
            return Ok(());
        }
        let (m, _, _) = self.balanced()?;
        let s = cable::statics::tension_wrench_sensitivity(&m.net, &m.equilibrium)?;
        for (o, u) in out.iter_mut().zip(at.unknowns) {
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

    /// Of the last step's map, exactly, from its converged iteration matrix.
    fn step_map_derivative(&mut self, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        let dw = Self::wrench_seed(at.knowns, at.seed)?;
        let dy = match &mut self.dynamics {
            Some(dy) if dy.state().last_step.is_some() => dy,
            _ => return Err("no step has been taken yet: the step map is defined after fmi2DoStep".into()),
        };
        let q = dy.cabin().orientation.into_inner();
        let d = dy.wrench_sensitivity(&dw, at.unknowns.iter().any(|u| is_tension(*u)))?;
        for (o, u) in out.iter_mut().zip(at.unknowns) {
            *o = delta_output(&d, &q, *u).ok_or_else(|| format!("value reference {u} is not an output"))?;
        }
        Ok(())
    }
}

/// The variables, inputs starting at the wrench `w0`.
fn variables(w0: &Vector6<f64>) -> Vec<Variable> {
    let mut variables = fmi::table::variables(vr::TABLE, |v| w0[(v - vr::WRENCH) as usize]);
    // No output responds to the wrench at a communication point. The start pose depends on the
    // scene only; the equilibrium's tensions also on the wrench and the discretisation.
    let tension_knowns: Vec<String> =
        input_names().into_iter().chain(["scene", "elements_per_cable"].map(String::from)).collect();
    for v in variables.iter_mut().filter(|v| v.causality == Causality::Output) {
        let initially = if is_tension(v.value_reference) {
            tension_knowns.clone()
        } else if v.value_reference < vr::VELOCITY {
            vec!["scene".to_owned()]
        } else {
            vec![]
        };
        (v.depends_on, v.initial_depends_on) = (Some(vec![]), Some(initially));
    }
    variables.push(
        Variable::parameter("elements_per_cable", vr::ELEMENTS, 0, false)
            .describe("finite elements per cable; 0: the scene's value"),
    );
    variables.push(Variable::parameter("scene", vr::SCENE, DEFAULT_SCENE, false).describe(
        "scene file (TOML); relative paths resolve inside resources/, which holds lt50m_B.toml and lt50m_C.toml; or the \
         scene itself, data:application/toml;name=NAME,TEXT (TEXT percent-encoded)",
    ));
    variables
}

/// The output `vr` of a motion delta (for directional derivatives), with `q` the orientation.
fn delta_output(d: &CabinDelta, q: &nalgebra::Quaternion<f64>, vr: u32) -> Option<f64> {
    let v3 = |v: &Vec3, base: u32| v[(vr - base) as usize];
    let m = &d.motion;
    Some(match vr {
        vr::POSITION..vr::ORIENTATION => v3(&m.position, vr::POSITION),
        vr::ORIENTATION..vr::VELOCITY => {
            let dq = feedcore::rigid::quaternion_change(&m.rotation, q);
            [dq.w, dq.i, dq.j, dq.k][(vr - vr::ORIENTATION) as usize]
        }
        vr::VELOCITY..vr::ANGULAR_VELOCITY => v3(&m.velocity, vr::VELOCITY),
        vr::ANGULAR_VELOCITY..vr::ACCELERATION => v3(&m.angular_velocity, vr::ANGULAR_VELOCITY),
        vr::ACCELERATION..vr::ANGULAR_ACCELERATION => v3(&m.acceleration, vr::ACCELERATION),
        vr::ANGULAR_ACCELERATION..vr::TENSION_ANCHOR => v3(&m.angular_acceleration, vr::ANGULAR_ACCELERATION),
        vr::TENSION_ANCHOR..vr::TENSION_CABIN => d.tensions[(vr - vr::TENSION_ANCHOR) as usize].0,
        vr::TENSION_CABIN..vr::DAMPING_RATIO => d.tensions[(vr - vr::TENSION_CABIN) as usize].1,
        _ => return None,
    })
}

impl Model for CableFmu {
    type State<'a> = SavedCable<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let w0 = static_wrench(SCENES.open(None, DEFAULT_SCENE)?.value());
        Ok(ModelDescription::co_simulation(
            "cable_fmu",
            GUID,
            "Six-cable finite-element net carrying the feed cabin (LT50m); input: the Stewart platform's wrench",
            env!("CARGO_PKG_VERSION"),
            CoSimulationFlags::EXPORTED_WITH_DERIVATIVES,
            variables(&w0),
        ))
    }

    fn resources() -> Vec<Resource> {
        SCENES.resources()
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let scene = SCENES.open(resources, DEFAULT_SCENE)?;
        Ok(CableFmu {
            // Inputs start at their declared start values (FMI 2.0): scene C's static wrench.
            wrench: static_wrench(scene.value()),
            scene,
            settings: Settings { elements: 0, damping_ratio: -1.0, rho_inf: -1.0, newton_tol: -1.0 },
            nominal: None,
            balanced: None,
            dynamics: None,
            start_wrench: Vector6::zeros(),
            wrench_rate: Vector6::zeros(),
            tensions: [(0.0, 0.0); CABLES],
            scratch: Vec::new(),
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

    /// The outputs computed once for all of them.
    fn get_reals(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), (usize, ModelError)> {
        let y = match vrs.iter().position(|&r| (vr::POSITION..vr::DAMPING_RATIO).contains(&r)) {
            Some(k) => Some(self.output_values().map_err(|e| (k, e))?),
            None => None,
        };
        for (k, (&r, o)) in vrs.iter().zip(out.iter_mut()).enumerate() {
            *o = match (r, &y) {
                (vr::POSITION..vr::DAMPING_RATIO, Some(y)) => y[(r - vr::POSITION) as usize],
                _ => self.get_real(r).map_err(|e| (k, e))?,
            };
        }
        Ok(())
    }

    /// `elements_per_cable`, the only Integer (the layer has checked the value reference).
    fn set_integer(&mut self, _vr: u32, value: i32) -> Result<(), ModelError> {
        if value < 0 {
            return Err(format!("elements_per_cable = {value}: must be at least 1 (0: the scene's value)").into());
        }
        let settings = Settings { elements: value, ..self.settings };
        effective_scene(&self.scene, &settings)?; // refuses what would not fit, before anything is built
        self.settings = settings;
        self.settings_changed();
        Ok(())
    }

    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Ok(self.settings.elements)
    }

    /// `scene`, the only String.
    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        if self.scene.set(value)? {
            self.settings_changed();
        }
        Ok(())
    }

    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Ok(self.scene.name().to_owned())
    }

    /// At rest at the target pose under the wrench held now.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        let w = self.wrench;
        let (model, _, _) = self.balanced()?;
        let twist = model.start_twist(&platform_start_momentum(&model.scene)?)?;
        let dy = model.dynamics_from(Payload::External, start_time, &w, &twist)?;
        dy.end_tensions(&mut self.tensions);
        self.dynamics = Some(dy);
        self.start_wrench = w;
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
            let name = &output_names()[k];
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

    /// A wrench input (the only inputs).
    fn set_real_input_derivative(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let rate = self.wrench_rate.get_mut((vr - vr::WRENCH) as usize);
        *rate.ok_or_else(|| format!("value reference {vr} is not an input"))? = value;
        Ok(())
    }

    fn derivative(&mut self, kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        match kind {
            Derivative::Instant => self.instant_derivative(at, out),
            Derivative::StepMap => self.step_map_derivative(at, out),
        }
    }

    fn save(&mut self) -> Result<SavedCable<'_>, ModelError> {
        let motion = match &self.dynamics {
            Some(dy) => {
                self.scratch.clear();
                dy.encode_state(&mut self.scratch);
                Some(SavedMotion { start_wrench: self.start_wrench.into(), numbers: Reals::new(&self.scratch) })
            }
            None => None,
        };
        Ok(SavedCable {
            scene: self.scene.saved(),
            settings: self.settings,
            wrench: self.wrench.into(),
            wrench_rate: self.wrench_rate.into(),
            motion,
        })
    }

    fn restore(&mut self, saved: SavedCable<'_>) -> Result<(), ModelError> {
        let wrenches = (saved.wrench.into(), saved.wrench_rate.into());
        let motion = saved.motion.map(|m| (Vector6::from(m.start_wrench), Kept::Numbers(m.numbers)));
        self.restore_parts(saved.scene, saved.settings, wrenches, motion)
    }

    /// The state kept in memory: the motion copied, the cable model's factorization shared.
    fn save_in_memory(&mut self, saved: &mut Option<Box<dyn Any + Send>>) -> Result<bool, ModelError> {
        if !saved.as_ref().is_some_and(|b| b.is::<InMemory>()) {
            *saved = Some(Box::new(InMemory::default()));
        }
        let Some(kept) = saved.as_mut().and_then(|b| b.downcast_mut::<InMemory>()) else {
            return Ok(false);
        };
        kept.scene.keep(self.scene.saved());
        (kept.settings, kept.wrench, kept.wrench_rate) = (self.settings, self.wrench, self.wrench_rate);
        match &self.dynamics {
            Some(dy) => {
                kept.start_wrench = Some(self.start_wrench);
                dy.save_into(&mut kept.motion);
            }
            None => kept.start_wrench = None,
        }
        Ok(true)
    }

    fn restore_in_memory(&mut self, saved: &(dyn Any + Send)) -> Result<(), ModelError> {
        let kept = saved.downcast_ref::<InMemory>().ok_or("not a state of the cable FMU")?;
        let motion = match (kept.start_wrench, &kept.motion) {
            (Some(w), Some(state)) => Some((w, Kept::Memory(state))),
            _ => None,
        };
        self.restore_parts(kept.scene.saved(), kept.settings, (kept.wrench, kept.wrench_rate), motion)
    }
}
