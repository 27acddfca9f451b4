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

use std::any::Any;
use std::path::Path;

use feedcore::rigid::{MotionChange, rotation_of_quaternion_change};
use feedcore::scene::{Scene, SceneError, Start, ValidScene};
use feedcore::{Quat, Vec3};
use fmi::description::Causality;
use fmi::export::{Derivative, Model, ModelError, Seeds, StepOutcome};
use fmi::resources::{FileKind, FileParameter, KeptState, SavedFile};
use fmi::{CoSimulationFlags, ModelDescription, Resource, Variable};
use nalgebra::Vector6;
use serde::{Deserialize, Serialize};

use feedcore::scene::SensorKind;
use stewart::sensitivity::carried_pose_change;
use stewart::{
    ActuatorRates, CabinMotion, CommandState, Evaluation, PathPoint, RelativeState, Stewart, Wrench, WrenchJacobians,
};

/// The scene used unless the `scene` parameter names another one.
pub const DEFAULT_SCENE: &str = "lt50m_C.toml";
/// Identifies the variable table: change it whenever the table changes.
pub const GUID: &str = "{8e4b2d61-0f37-4c95-a1d8-6b2e9c7f3a15}";
/// Number of Real inputs of the cabin's motion (the command's follow the outputs in the table).
pub const INPUTS: usize = vr::FORCE as usize;
/// Number of Real inputs of the platform's command (with `command_input`).
pub const COMMAND_INPUTS: usize = (vr::RADIUS - vr::COMMAND_R) as usize;

/// Scene files: shipped in `resources/` and compiled in; at most 1 MiB.
static SCENES: FileKind<ValidScene, SceneError> = FileKind::new(&feedcore::shipped::SCENES, 1 << 20, Scene::from_toml);

/// The cabin's motion as Real inputs, in this order: the Stewart FMU's first inputs and the
/// control FMU's (the cable FMU's outputs of the same names feed both).
///
/// The ranges lie far beyond any cabin on cables (FAST's reflector is 500 m across), so that
/// only a mistaken or hostile value is refused: positions within 10 km, speeds 1 km/s, 1e5 in
/// the accelerations' units; quaternion components within ±1.5 (normalized).
pub mod cabin {
    use fmi::table::Block;

    pub const R: Block =
        Block::input("cabin.r", 3, "m", "position of the cabin centre point, world frame").range(-1e4, 1e4);
    pub const Q: Block =
        Block::input("cabin.q", 4, "", "orientation of the cabin, quaternion (w, x, y, z) body to world (normalized)")
            .range(-1.5, 1.5);
    pub const V: Block =
        Block::input("cabin.v", 3, "m/s", "velocity of the cabin centre point, world frame").range(-1e3, 1e3);
    pub const W: Block =
        Block::input("cabin.w", 3, "rad/s", "angular velocity of the cabin, world frame").range(-1e3, 1e3);
    pub const A: Block =
        Block::input("cabin.a", 3, "m/s2", "acceleration of the cabin centre point, world frame").range(-1e5, 1e5);
    pub const ALPHA: Block =
        Block::input("cabin.alpha", 3, "rad/s2", "angular acceleration of the cabin, world frame").range(-1e5, 1e5);
}

/// The variables: value references (separate spaces per type) and, for the Real ones, the table
/// the description and the names come from.
pub mod vr {
    use feedcore::scene::LEGS;
    use fmi::table::Block;

    const WXYZ: &[&str] = &["w", "x", "y", "z"];

    fmi::variable_table! {
        /// Real inputs, the cabin's motion.
        R = super::cabin::R,
        Q = super::cabin::Q,
        V = super::cabin::V,
        W = super::cabin::W,
        A = super::cabin::A,
        ALPHA = super::cabin::ALPHA,
        /// Real outputs: the wrench on the cabin (force, moment), the actuator forces, the
        /// moving platform's position and orientation.
        FORCE = Block::output("wrench.f", 3, "N", "force the platform exerts on the cabin, world frame"),
        MOMENT = Block::output("wrench.m", 3, "N.m", "moment on the cabin about its centre point, world frame"),
        ACTUATOR = Block::output("actuator.force", LEGS as u32, "N", "tension of actuator {k} (positive: pulls the platform up)"),
        PLATFORM_R = Block::output("platform.r", 3, "m", "position of the moving platform's centre, world frame"),
        PLATFORM_Q = Block::output("platform.q", 4, "", "orientation of the moving platform ({k}), body to world").labels(WXYZ),
        /// Real outputs: leg lengths, the feed's position error and its rotation from the start
        /// attitude (world rotation vector; its length is the feed's tilt error).
        LEG = Block::output("leg.length", LEGS as u32, "m", "length of leg {k}, joint centre to joint centre"),
        FEED_ERR = Block::output("feed.err", 3, "m",
            "feed point minus its target, world frame ([control]; else the platform centre minus its start)"),
        FEED_ROT = Block::output("feed.rot", 3, "rad",
            "rotation of the feed (the platform) from its start attitude, world rotation vector"),
        /// Real outputs: the cabin pose the compensation estimates (with [control.imu]: the
        /// Kalman filter's estimate now; otherwise the cabin's reference pose).
        ESTIMATE_R = Block::output("estimate.r", 3, "m",
            "cabin position the compensation estimates, world frame ([control.imu]; else the reference pose)"),
        ESTIMATE_Q = Block::output("estimate.q", 4, "",
            "cabin orientation the compensation estimates ({k}), body to world ([control.imu]; else the reference)").labels(WXYZ),
        /// Real inputs: the platform's command (with `command_input`), its pose relative to its
        /// home pose (centre at rest, attitude the cabin's).
        COMMAND_R = Block::input("command.r", 3, "m",
            "commanded displacement of the moving platform's centre from its home position, cabin frame (with command_input)")
            .range(-10.0, 10.0),
        COMMAND_ROT = Block::input("command.rot", 3, "rad",
            "commanded rotation of the moving platform from its home attitude, rotation vector in the cabin frame (with command_input)")
            .range(-4.0, 4.0),
        /// Real parameters.
        RADIUS = Block::parameter("radius", -1.0, "m", "radius of the platform's circle; negative: the scene's value")
            .range(-1.0, 10.0),
        SPEED = Block::parameter("speed", -1.0, "m/s",
            "speed of the platform on the circle (0: held still); negative: the scene's value").range(-1.0, 10.0),
        RAMP_TIME = Block::parameter("ramp_time", -1.0, "s",
            "duration of the smooth start (with start = 2); non-positive: the scene's value").range(-1.0, 1e4),
    }
    /// Integer `start`.
    pub const START: u32 = 0;
    /// Boolean `command_input`.
    pub const COMMAND_INPUT: u32 = 0;
    /// String `scene`.
    pub const SCENE: u32 = 0;
}

/// The scalar parameters that modify the scene's motion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Settings {
    /// Negative: the scene's value.
    radius: f64,
    speed: f64,
    ramp_time: f64,
    /// 0: the scene's, 1: abrupt, 2: ramp.
    start: i32,
    /// The platform follows the command inputs; the built-in controller is off.
    command_input: bool,
}

/// Outputs at the current time and inputs, computed when first asked for.
#[derive(Default)]
struct Cache {
    wrench: Option<Wrench>,
    /// Only when a derivative asks for them.
    jacobians: Option<WrenchJacobians>,
    evaluation: Option<Evaluation>,
    actuator_rates: Option<ActuatorRates>,
}

pub struct StewartFmu {
    scene: FileParameter<ValidScene, SceneError>,
    /// The settings, inputs and time, saved as they are.
    data: Data,
    model: Option<Stewart>,
    /// The settings the model was built for, and whether in step mode (in initialization mode
    /// the platform rests at its start pose).
    built_for: Option<(Settings, bool)>,
    cache: Cache,
    /// The last relative motion computed, with the time and command point it belongs to.
    relative: Option<KeptRelative>,
}

/// The platform's motion relative to the cabin depends on neither the cabin inputs nor the
/// state, only on the time and the commanded point: a step retaken from a restored state (an
/// iterating importer) finds it computed.
struct KeptRelative {
    time: f64,
    point: PathPoint,
    state: RelativeState,
}

/// Everything but the scene file: time, and with a sampled sensor its state.
#[derive(Debug, Serialize, Deserialize)]
struct Data {
    settings: Settings,
    initialized: bool,
    time: f64,
    inputs: [f64; INPUTS],
    rates: [f64; INPUTS],
    /// The cabin inputs at `time` as last stepped to: what a sample measures and an inertial
    /// unit reads (the inputs may meanwhile hold an importer's guess for the end of the next
    /// step).
    accepted: [f64; INPUTS],
    /// A sampled sensor's state (scene `[control]`, sensor = "sampled"), or with `command_input`
    /// the command followed.
    command: Option<CommandState>,
    /// The command inputs: held over a step, the platform follows them from its start.
    commanded: [f64; COMMAND_INPUTS],
}

impl Clone for Data {
    fn clone(&self) -> Self {
        let mut copy = Data { command: None, ..*self };
        copy.command.clone_from(&self.command);
        copy
    }

    /// Reuses the sensor's queues (a state saved at every step allocates nothing).
    fn clone_from(&mut self, source: &Self) {
        let Data { settings, initialized, time, inputs, rates, accepted, command, commanded } = source;
        (self.settings, self.initialized, self.time) = (*settings, *initialized, *time);
        (self.inputs, self.rates, self.accepted) = (*inputs, *rates, *accepted);
        self.commanded = *commanded;
        self.command.clone_from(command);
    }
}

/// A saved state: the scene file's name and the rest.
#[derive(Serialize, Deserialize)]
pub struct SavedStewart<'a> {
    #[serde(borrow)]
    scene: SavedFile<'a>,
    data: Data,
}

/// The scene's static pose at rest, as input values.
pub fn rest_inputs(scene: &ValidScene) -> [f64; INPUTS] {
    let mut u = [0.0; INPUTS];
    let (p, q) = (scene.target_position(), scene.target_orientation());
    u[0..3].copy_from_slice(p.as_slice());
    u[3..7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
    u
}

/// How far the cabin inputs may lie from the scene's pose (m, rad) before leaving initialization
/// mode warns: far above rounding and a pose printed to nine digits, far below any pose a
/// mistaken importer would hand over.
const POSE_WARNING_TOLERANCE: f64 = 1e-6;

/// Why the cabin pose held at the start does not look like the scene's: an importer that left
/// the cabin inputs at their declared start values (scene C's) while running another scene
/// computes the platform on a cabin where the scene does not put it.
fn pose_mismatch(scene_name: &str, scene: &ValidScene, u: &[f64; INPUTS]) -> Option<String> {
    let rest = rest_inputs(scene);
    let held = cabin_motion(u).ok()?;
    let target = cabin_motion(&rest).ok()?;
    let offset = (held.position - target.position).norm();
    let angle = held.orientation.angle_to(&target.orientation);
    (offset > POSE_WARNING_TOLERANCE || angle > POSE_WARNING_TOLERANCE).then(|| {
        format!(
            "the cabin inputs hold the pose cabin.r = {:?}, cabin.q = {:?}, {:.1} mm and {:.2} mrad from the pose of \
             scene `{scene_name}` (cabin.r = {:?}, cabin.q = {:?}); the platform is computed on the pose held. \
             Inputs never set keep their declared start values, scene C's pose: an importer running another \
             scene sets cabin.* in initialization mode, from the cable FMU's outputs or the scene's pose \
             (docs/fmus.md)",
            &u[0..3],
            &u[3..7],
            offset * 1e3,
            angle * 1e3,
            &rest[0..3],
            &rest[3..7],
        )
    })
}

/// The names of the outputs, in value-reference order.
pub fn output_names() -> Vec<String> {
    fmi::table::names(vr::TABLE, Causality::Output)
}

/// The names of the cabin inputs, in value-reference order from 0.
pub fn input_names() -> Vec<String> {
    let mut names = fmi::table::names(vr::TABLE, Causality::Input);
    names.truncate(INPUTS);
    names
}

/// The cabin's motion the input values `u` give (the orientation normalized); refused when
/// `cabin.q` is far from a rotation.
pub fn cabin_motion(u: &[f64; INPUTS]) -> Result<CabinMotion, ModelError> {
    let q = nalgebra::Quaternion::new(u[3], u[4], u[5], u[6]);
    if q.norm() < 0.5 {
        return Err(format!("cabin.q = {:?} is not a rotation (norm {:.3}, expected 1)", &u[3..7], q.norm()).into());
    }
    let v3 = |i: usize| Vec3::new(u[i], u[i + 1], u[i + 2]);
    Ok(CabinMotion {
        position: v3(vr::R as usize),
        orientation: Quat::from_quaternion(q),
        velocity: v3(vr::V as usize),
        angular_velocity: v3(vr::W as usize),
        acceleration: v3(vr::A as usize),
        angular_acceleration: v3(vr::ALPHA as usize),
    })
}

/// The (output, input) value-reference pairs <ModelStructure> declares for step mode.
fn step_dependencies() -> Result<&'static std::collections::HashSet<(u32, u32)>, ModelError> {
    static PAIRS: std::sync::OnceLock<std::collections::HashSet<(u32, u32)>> = std::sync::OnceLock::new();
    if let Some(p) = PAIRS.get() {
        return Ok(p);
    }
    let d = StewartFmu::description()?;
    let inputs = input_names();
    let mut pairs = std::collections::HashSet::new();
    for v in &d.variables {
        for name in v.depends_on.iter().flatten() {
            if let Some(k) = inputs.iter().position(|n| n == name) {
                pairs.insert((v.value_reference, k as u32));
            }
        }
    }
    Ok(PAIRS.get_or_init(|| pairs))
}

impl StewartFmu {
    fn model(&mut self) -> Result<&Stewart, ModelError> {
        let key = (self.data.settings, self.data.initialized);
        // checked in place: the model is large, and this runs at every call that needs it
        if self.built_for != Some(key) || self.model.is_none() {
            self.model = None;
            let mut s = self.scene.value().to_scene();
            let st = &self.data.settings;
            for (value, target) in [(st.radius, &mut s.motion.radius_m), (st.speed, &mut s.motion.speed_m_s)] {
                if value >= 0.0 {
                    *target = value;
                }
            }
            if st.ramp_time > 0.0 {
                s.motion.ramp_time_s = st.ramp_time;
            }
            match st.start {
                1 => s.motion.start = Start::Abrupt,
                2 => s.motion.start = Start::Ramp,
                _ => {}
            }
            // Before the start the platform rests at its start pose: the motion (and an
            // abrupt start's jump) begins at the start time, so that a consistent
            // initialization puts the cable net in its static equilibrium under the
            // platform's weight.
            let moving = s.validated(self.scene.label())?;
            let model = if self.data.initialized {
                Stewart::from_scene(&moving)?
            } else {
                Stewart::from_scene(&moving.edited(|held| held.motion.speed_m_s = 0.0)?)?
            };
            self.built_for = Some(key);
            self.cache = Cache::default();
            self.relative = None;
            self.model = Some(model);
        }
        self.model.as_ref().ok_or_else(|| "the platform model could not be built".into())
    }

    fn cabin(&self) -> Result<CabinMotion, ModelError> {
        cabin_motion(&self.data.inputs)
    }

    /// Whether the platform's motion follows the current cabin inputs (an ideal sensor, in
    /// step mode): then every output depends on every input and derivatives are differences.
    fn follows_inputs(&mut self) -> Result<bool, ModelError> {
        let on = self.data.initialized && !self.data.settings.command_input;
        Ok(on && self.model()?.compensation().is_some_and(|c| c.sensor() == SensorKind::Ideal))
    }

    /// Where the platform centre is commanded (cabin frame) at the current time.
    fn point(&mut self) -> Result<PathPoint, ModelError> {
        let (t, initialized, commanded) = (self.data.time, self.data.initialized, self.data.settings.command_input);
        let cabin = self.cabin()?;
        // the sensor's state lent out while the model is borrowed (moved, not copied: this runs
        // at every evaluation), and put back whatever happens
        let command = self.data.command.take();
        let point = self.model().map(|model| match model.compensation() {
            Some(c) if initialized => match (c.sensor(), &command) {
                (_, Some(state)) if commanded => state.at(c, t),
                (SensorKind::Ideal, _) => c.ideal(&cabin, t),
                (SensorKind::Sampled, Some(state)) => state.at(c, t),
                _ => model.path().at(t),
            },
            _ => model.path().at(t),
        });
        self.data.command = command;
        point
    }

    /// The platform's motion relative to the cabin now, with the model.
    fn relative(&mut self) -> Result<(&Stewart, &RelativeState), ModelError> {
        let (t, point) = (self.data.time, self.point()?);
        let kept = self.relative.as_ref().is_some_and(|k| k.time == t && k.point == point);
        if !kept {
            let state = self.model()?.relative_at(&point, t).map_err(|e| e.to_string())?;
            self.relative = Some(KeptRelative { time: t, point, state });
        }
        match (&self.model, &self.relative) {
            (Some(model), Some(kept)) => Ok((model, &kept.state)),
            _ => Err("the platform's relative motion could not be computed".into()),
        }
    }

    /// The wrench now, computed once per state.
    fn wrench(&mut self) -> Result<Wrench, ModelError> {
        if let Some(w) = self.cache.wrench {
            return Ok(w);
        }
        let cabin = self.cabin()?;
        let (model, rel) = self.relative()?;
        let w = model.wrench_of(rel, &cabin).map_err(|e| e.to_string())?;
        Ok(*self.cache.wrench.insert(w))
    }

    /// The wrench's Jacobians now, computed once per state (borrowed: they are large).
    fn wrench_jacobians(&mut self) -> Result<&WrenchJacobians, ModelError> {
        if self.cache.jacobians.is_none() {
            let cabin = self.cabin()?;
            let (model, rel) = self.relative()?;
            let (w, j) = model.wrench_with_jacobians_of(rel, &cabin).map_err(|e| e.to_string())?;
            self.cache.wrench = Some(w);
            self.cache.jacobians = Some(j);
        }
        self.cache.jacobians.as_ref().ok_or_else(|| "the wrench's Jacobians could not be computed".into())
    }

    fn evaluation(&mut self) -> Result<&Evaluation, ModelError> {
        if self.cache.evaluation.is_none() {
            let (t, cabin, point) = (self.data.time, self.cabin()?, self.point()?);
            let e = self.model()?.evaluate_at(&cabin, &point, t).map_err(|e| e.to_string())?;
            self.cache.evaluation = Some(e);
        }
        self.cache.evaluation.as_ref().ok_or_else(|| "the platform could not be evaluated".into())
    }

    /// The cabin pose the compensation estimates now: the fused estimate with an inertial unit,
    /// else the reference pose.
    fn estimate(&mut self) -> Result<(Vec3, feedcore::Quat), ModelError> {
        let t = self.data.time;
        // with command_input the filter is the controller's, outside
        let own = !self.data.settings.command_input;
        let command = self.data.command.take();
        let estimate = self.model().map(|model| {
            let c = model.compensation()?;
            Some(
                command
                    .as_ref()
                    .filter(|_| own)
                    .and_then(|state| state.estimate(c, t))
                    .unwrap_or_else(|| c.reference()),
            )
        });
        self.data.command = command;
        estimate?.ok_or_else(|| "the model has no compensation".into())
    }

    fn actuator_rates(&mut self) -> Result<ActuatorRates, ModelError> {
        if let Some(r) = self.cache.actuator_rates {
            return Ok(r);
        }
        let (t, cabin, point) = (self.data.time, self.cabin()?, self.point()?);
        let r = self.model()?.actuator_rates_at(&cabin, &point, t).map_err(|e| e.to_string())?;
        Ok(*self.cache.actuator_rates.insert(r))
    }

    /// Directional derivatives by central differences of the outputs (an ideal sensor: the
    /// platform's motion is a function of the cabin inputs, and the outputs of its relative
    /// motion; the analytic derivative of that chain is not written out).
    fn differences(&mut self, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        let Seeds { unknowns, knowns, seed } = at;
        let mut du = [0.0; INPUTS];
        for (k, s) in knowns.iter().zip(seed).filter(|(k, _)| !(vr::COMMAND_R..vr::RADIUS).contains(*k)) {
            let slot = du.get_mut(*k as usize).ok_or_else(|| {
                format!("derivatives with respect to value reference {k} are not provided (only the cabin inputs)")
            })?;
            *slot += s;
        }
        // each input apart, kept only where <ModelStructure> declares the dependence (elsewhere
        // the output is independent of it and the difference is rounding)
        let declared = step_dependencies()?;
        let (inputs, cache) = (self.data.inputs, std::mem::take(&mut self.cache));
        out.iter_mut().for_each(|o| *o = 0.0);
        let mut result = Ok(());
        for (k, &d) in du.iter().enumerate().filter(|(_, d)| **d != 0.0) {
            // fourth-order central differences: exact for the quadratic dependence on ω, error
            // O(ε⁴) elsewhere
            let eps = 1e-4 * inputs[k].abs().max(1.0);
            let mut at = |x: f64| -> Result<Vec<f64>, ModelError> {
                self.data.inputs[k] = x;
                self.cache = Cache::default();
                unknowns.iter().map(|&u| self.get_real(u)).collect()
            };
            let values: Result<Vec<Vec<f64>>, ModelError> =
                [1.0, -1.0, 2.0, -2.0].iter().map(|s| at(inputs[k] + s * eps)).collect();
            self.data.inputs = inputs;
            let values = match values {
                Ok(v) => v,
                Err(e) => {
                    result = Err(e);
                    break;
                }
            };
            for (j, o) in out.iter_mut().enumerate() {
                if declared.contains(&(unknowns[j], k as u32)) {
                    let (p1, m1, p2, m2) = (values[0][j], values[1][j], values[2][j], values[3][j]);
                    *o += d * (8.0 * (p1 - m1) - (p2 - m2)) / (12.0 * eps);
                }
            }
        }
        self.cache = cache;
        result
    }

    /// Restores a saved state from its parts (the scene and settings adopted where they differ).
    fn restore_parts(&mut self, scene: SavedFile<'_>, data: &Data) -> Result<(), ModelError> {
        if self.scene.restore(scene)? || data.settings != self.data.settings {
            self.settings_changed();
        }
        self.data.clone_from(data);
        self.model()?;
        self.cache = Cache::default();
        Ok(())
    }

    fn settings_changed(&mut self) {
        self.model = None;
        self.built_for = None;
        self.cache = Cache::default();
    }
}

impl Model for StewartFmu {
    type State<'a> = SavedStewart<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let inputs = input_names();
        let rest = rest_inputs(SCENES.open(None, DEFAULT_SCENE)?.value());
        let mut variables = fmi::table::variables(vr::TABLE, |v| rest.get(v as usize).copied().unwrap_or(0.0));
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
        let pose: Vec<&str> = (0..7).map(name).collect();
        let all: Vec<&str> = (0..INPUTS).map(name).collect();
        // in initialization mode the platform rests at its start pose: speed and start do not count
        let params = ["scene", "radius"];
        // The platform's own motion: with an ideal sensor ([control], step mode) it follows the
        // cabin's pose, velocity and acceleration, so the wrench and the actuator forces depend
        // on every input, the platform's position, the leg lengths and the feed on the pose.
        let deps = |vr: u32, initial: bool| -> Vec<&str> {
            match vr {
                vr::FORCE..vr::ACTUATOR if !initial => all.clone(),
                vr::FORCE..vr::MOMENT => force((vr - vr::FORCE) as usize),
                vr::MOMENT..vr::ACTUATOR => moment((vr - vr::MOMENT) as usize),
                vr::ACTUATOR..vr::PLATFORM_R if !initial => all.clone(),
                vr::ACTUATOR..vr::PLATFORM_R => all_but_position.clone(),
                vr::PLATFORM_R..vr::PLATFORM_Q => {
                    let mut d = vec![inputs[(vr - vr::PLATFORM_R) as usize].as_str()];
                    d.extend(&orientation);
                    d
                }
                vr::LEG..vr::FEED_ERR if initial => vec![],
                vr::LEG..vr::FEED_ERR => pose.clone(),
                vr::FEED_ERR..vr::FEED_ROT => {
                    let mut d = vec![inputs[(vr - vr::FEED_ERR) as usize].as_str()];
                    d.extend(&orientation);
                    d
                }
                // the estimate is made from earlier inputs only (the filter's state)
                vr::ESTIMATE_R..vr::COMMAND_R => vec![],
                _ => orientation.clone(),
            }
        };
        for v in variables.iter_mut().filter(|v| v.causality == Causality::Output) {
            let d = deps(v.value_reference, false);
            let initially: Vec<&str> = deps(v.value_reference, true).into_iter().chain(params).collect();
            v.depends_on = Some(d.iter().map(|n| n.to_string()).collect());
            v.initial_depends_on = Some(initially.iter().map(|n| n.to_string()).collect());
        }
        variables.push(Variable::parameter("command_input", vr::COMMAND_INPUT, false, false).describe(
            "true: the platform follows command.r and command.rot (a controller outside, e.g. control_fmu) through the \
             scene's [control] filter stages, the built-in second level off; the command held over a step acts from its start",
        ));
        variables.push(
            Variable::parameter("start", vr::START, 0, false)
                .describe("0: the scene's start, 1: abrupt (full speed at t = 0), 2: smooth ramp"),
        );
        variables.push(Variable::parameter("scene", vr::SCENE, DEFAULT_SCENE, false).describe(
            "scene file (TOML); relative paths resolve against resources/, which holds lt50m_B.toml and lt50m_C.toml; or \
             the scene itself, data:application/toml;name=NAME,TEXT (TEXT percent-encoded)",
        ));
        Ok(ModelDescription::co_simulation(
            "stewart_fmu",
            GUID,
            "Stewart platform (13 rigid bodies) hanging in the feed cabin, platform on a circle; output: its wrench on the cabin",
            env!("CARGO_PKG_VERSION"),
            CoSimulationFlags::EXPORTED_WITH_DERIVATIVES,
            variables,
        ))
    }

    fn resources() -> Vec<Resource> {
        SCENES.resources()
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let scene = SCENES.open(resources, DEFAULT_SCENE)?;
        // Inputs start at their declared start values (FMI 2.0): scene C's pose at rest.
        let inputs = rest_inputs(scene.value());
        let settings = Settings { radius: -1.0, speed: -1.0, ramp_time: -1.0, start: 0, command_input: false };
        let accepted = inputs;
        Ok(StewartFmu {
            data: Data {
                settings,
                initialized: false,
                time: 0.0,
                inputs,
                rates: [0.0; INPUTS],
                accepted,
                command: None,
                commanded: [0.0; COMMAND_INPUTS],
            },
            scene,
            model: None,
            built_for: None,
            cache: Cache::default(),
            relative: None,
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            0..19 => {
                self.data.inputs[vr as usize] = value;
                self.cache = Cache::default();
                return Ok(());
            }
            vr::COMMAND_R..vr::RADIUS => {
                // acts over the next step: nothing computed now changes
                self.data.commanded[(vr - vr::COMMAND_R) as usize] = value;
                return Ok(());
            }
            vr::RADIUS => self.data.settings.radius = value,
            vr::SPEED => self.data.settings.speed = value,
            vr::RAMP_TIME => self.data.settings.ramp_time = value,
            _ => return Err(format!("value reference {vr} is not a settable Real").into()),
        }
        self.settings_changed();
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            0..19 => Ok(self.data.inputs[vr as usize]),
            vr::LEG..vr::FEED_ERR => Ok(self.evaluation()?.leg_lengths[(vr - vr::LEG) as usize]),
            vr::COMMAND_R..vr::RADIUS => Ok(self.data.commanded[(vr - vr::COMMAND_R) as usize]),
            vr::ESTIMATE_R..vr::COMMAND_R => {
                let (p, q) = self.estimate()?;
                let q = q.into_inner();
                Ok(if vr < vr::ESTIMATE_Q {
                    p[(vr - vr::ESTIMATE_R) as usize]
                } else {
                    [q.w, q.i, q.j, q.k][(vr - vr::ESTIMATE_Q) as usize]
                })
            }
            vr::FEED_ERR..vr::ESTIMATE_R => {
                let t = self.data.time;
                let p = self.evaluation()?.platform;
                let c = self.model()?.compensation().ok_or("the model has no feed point")?;
                let (err, rot) = c.feed_error(&p.position, &p.orientation, t);
                Ok(if vr < vr::FEED_ROT {
                    err[(vr - vr::FEED_ERR) as usize]
                } else {
                    rot[(vr - vr::FEED_ROT) as usize]
                })
            }
            vr::FORCE..vr::ACTUATOR => Ok(self.wrench()?.to_vector()[(vr - vr::FORCE) as usize]),
            vr::ACTUATOR..vr::PLATFORM_R => Ok(self.evaluation()?.actuator_forces[(vr - vr::ACTUATOR) as usize]),
            vr::PLATFORM_R..vr::PLATFORM_Q => Ok(self.evaluation()?.platform.position[(vr - vr::PLATFORM_R) as usize]),
            vr::PLATFORM_Q..vr::LEG => {
                let q = self.evaluation()?.platform.orientation;
                Ok([q.w, q.i, q.j, q.k][(vr - vr::PLATFORM_Q) as usize])
            }
            vr::RADIUS => Ok(self.data.settings.radius),
            vr::SPEED => Ok(self.data.settings.speed),
            vr::RAMP_TIME => Ok(self.data.settings.ramp_time),
            _ => Err(format!("value reference {vr} is not a Real of this model").into()),
        }
    }

    /// `start`, the only Integer (the layer has checked the value reference).
    fn set_integer(&mut self, _vr: u32, value: i32) -> Result<(), ModelError> {
        if !(0..=2).contains(&value) {
            return Err(format!("start = {value}: must be 0 (the scene's), 1 (abrupt) or 2 (ramp)").into());
        }
        self.data.settings.start = value;
        self.settings_changed();
        Ok(())
    }

    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Ok(self.data.settings.start)
    }

    /// `scene`, the only String.
    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        self.scene.set(value)?;
        self.settings_changed();
        Ok(())
    }

    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Ok(self.scene.name().to_owned())
    }

    /// `command_input`, the only Boolean.
    fn set_boolean(&mut self, _vr: u32, value: bool) -> Result<(), ModelError> {
        self.data.settings.command_input = value;
        self.settings_changed();
        Ok(())
    }

    fn get_boolean(&mut self, _vr: u32) -> Result<bool, ModelError> {
        Ok(self.data.settings.command_input)
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.data.initialized = true;
        let commanded = self.data.settings.command_input;
        let label = self.scene.label().to_owned();
        let command = match self.model()?.compensation() {
            Some(c) if commanded && c.follows_commands() => Some(c.start_state()),
            _ if commanded => {
                return Err(format!(
                    "command_input: scene `{label}` gives the platform no response to follow commands with: its \
                     [control] needs bandwidth_hz (the filter's stages) or a sampled sensor's sample_rate_hz"
                )
                .into());
            }
            Some(c) if c.sensor() == SensorKind::Sampled => Some(c.start_state()),
            _ => None,
        };
        self.data.command = command;
        self.data.accepted = self.data.inputs;
        self.data.time = start_time;
        self.cache = Cache::default();
        Ok(())
    }

    fn initialization_warning(&mut self) -> Option<String> {
        pose_mismatch(self.scene.label(), self.scene.value(), &self.data.inputs)
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        self.model()?;
        if let Some(mut state) = self.data.command.take() {
            let (commanded, command, accepted) =
                (self.data.settings.command_input, self.data.commanded, self.data.accepted);
            let c = self.model()?.compensation().expect("a command state comes with a compensation");
            let result = if commanded {
                // the command held over the step, followed from its start
                state.follow(c, t, c.pose_of_relative(&command));
                Ok(())
            } else if h > c.max_step() * (1.0 + 1e-9) {
                let ((period, key), most) = (c.step_period(), c.max_step());
                Err(format!(
                    "communication step {h} s at t = {t} s is longer than a quarter of the sensor's sample period \
                     {period} s ([control] {key}): a sample is taken at the first communication point \
                     after its instant; take steps of at most {most} s or lower the sample rate"
                )
                .into())
            } else {
                // the sample at the start of the step measures the pose stepped to last
                cabin_motion(&accepted).map(|cabin| state.sample(c, t, &cabin))
            };
            self.data.command = Some(state);
            result?;
        }
        for k in 0..INPUTS {
            self.data.inputs[k] += self.data.rates[k] * h;
        }
        self.data.rates = [0.0; INPUTS]; // input derivatives apply to one step
        self.data.time = t + h;
        self.cache = Cache::default();
        // evaluate now, so that a leg leaving its stroke, or a non-finite result, is reported
        // by this step
        self.data.accepted = self.data.inputs;
        let w = self.wrench()?.to_vector();
        if let Some(k) = w.iter().position(|x| !x.is_finite()) {
            let name = if k < 3 { format!("wrench.f[{}]", k + 1) } else { format!("wrench.m[{}]", k - 2) };
            return Err(
                format!("`{name}` = {} at t = {}: the cabin inputs are {:?}", w[k], t + h, self.data.inputs).into()
            );
        }
        Ok(StepOutcome::Complete)
    }

    fn set_real_input_derivative(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let rate = self.data.rates.get_mut(vr as usize);
        *rate.ok_or_else(|| format!("value reference {vr} is not an input"))? = value;
        Ok(())
    }

    /// Every output follows the inputs at the same instant, and after a step the inputs at its
    /// end: the step map's derivative is the instantaneous one at the current time.
    fn derivative(&mut self, kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        // the command acts over a step, never at once
        let commanding =
            at.knowns.iter().zip(at.seed).any(|(k, s)| (vr::COMMAND_R..vr::RADIUS).contains(k) && *s != 0.0);
        if kind == Derivative::StepMap && commanding {
            return Err("the step map's derivative with respect to the command inputs is not provided: step the \
                 controller at a longer period than the platform (its command is then held over the platform's \
                 steps, not iterated), or couple by iqn-ils"
                .into());
        }
        if self.follows_inputs()? {
            return self.differences(at, out);
        }
        let Seeds { unknowns, knowns, seed } = at;
        let mut du = [0.0; INPUTS];
        for (k, s) in knowns.iter().zip(seed) {
            if (vr::COMMAND_R..vr::RADIUS).contains(k) {
                continue;
            }
            if *k as usize >= INPUTS {
                return Err(format!(
                    "derivatives with respect to value reference {k} are not provided (only the cabin inputs)"
                )
                .into());
            }
            du[*k as usize] += s;
        }
        let v3 = |u: &[f64], i: u32| Vec3::new(u[i as usize], u[i as usize + 1], u[i as usize + 2]);
        let q = |u: &[f64]| nalgebra::Quaternion::from_parts(u[vr::Q as usize], v3(u, vr::Q + 1));
        let inputs = self.data.inputs;
        let d = MotionChange {
            position: v3(&du, vr::R),
            rotation: rotation_of_quaternion_change(&q(&inputs), &q(&du)),
            velocity: v3(&du, vr::V),
            angular_velocity: v3(&du, vr::W),
            acceleration: v3(&du, vr::A),
            angular_acceleration: v3(&du, vr::ALPHA),
        };
        let cabin_r = v3(&inputs, vr::R);
        let needs = |outputs: std::ops::Range<u32>| unknowns.iter().any(|u| outputs.contains(u));
        let (df, dtilt) = if needs(vr::FEED_ERR..vr::ESTIMATE_R) {
            let t = self.data.time;
            let p = self.evaluation()?.platform;
            let c = self.model()?.compensation().ok_or("the model has no feed point")?;
            c.feed_error_change(&cabin_r, &p, t, &d).map_err(|e| e.to_string())?
        } else {
            (Vec3::zeros(), Vec3::zeros())
        };
        let dwrench =
            if needs(vr::FORCE..vr::ACTUATOR) { self.wrench_jacobians()?.change(&d) } else { Vector6::zeros() };
        let dact = if needs(vr::ACTUATOR..vr::PLATFORM_R) {
            let (r, c) = (self.actuator_rates()?, self.cabin()?);
            r.change(&c, &self.model()?.gravity(), &d)
        } else {
            Vector6::zeros()
        };
        let (dp, dq) = if needs(vr::PLATFORM_R..vr::LEG) {
            carried_pose_change(&cabin_r, &self.evaluation()?.platform, &d)
        } else {
            (Vec3::zeros(), nalgebra::Quaternion::identity())
        };
        for (o, u) in out.iter_mut().zip(unknowns) {
            *o = match *u {
                vr::FORCE..vr::ACTUATOR => dwrench[(*u - vr::FORCE) as usize],
                vr::ACTUATOR..vr::PLATFORM_R => dact[(*u - vr::ACTUATOR) as usize],
                vr::PLATFORM_R..vr::PLATFORM_Q => dp[(*u - vr::PLATFORM_R) as usize],
                vr::PLATFORM_Q..vr::LEG => [dq.w, dq.i, dq.j, dq.k][(*u - vr::PLATFORM_Q) as usize],
                // the legs follow the commanded relative motion, fixed within a step
                vr::LEG..vr::FEED_ERR => 0.0,
                vr::FEED_ERR..vr::FEED_ROT => df[(*u - vr::FEED_ERR) as usize],
                vr::FEED_ROT..vr::ESTIMATE_R => dtilt[(*u - vr::FEED_ROT) as usize],
                // made from earlier inputs only
                vr::ESTIMATE_R..vr::COMMAND_R => 0.0,
                other => return Err(format!("value reference {other} is not an output").into()),
            };
        }
        Ok(())
    }

    fn save(&mut self) -> Result<SavedStewart<'_>, ModelError> {
        Ok(SavedStewart { scene: self.scene.saved(), data: self.data.clone() })
    }

    fn restore(&mut self, saved: SavedStewart<'_>) -> Result<(), ModelError> {
        self.restore_parts(saved.scene, &saved.data)
    }

    fn save_in_memory(&mut self, saved: &mut Option<Box<dyn Any + Send>>) -> Result<bool, ModelError> {
        Ok(KeptState::save_into(saved, self.scene.saved(), &self.data))
    }

    fn restore_in_memory(&mut self, saved: &(dyn Any + Send)) -> Result<(), ModelError> {
        let (scene, data) = KeptState::<Data>::kept(saved, "the Stewart FMU")?;
        self.restore_parts(scene, data)
    }
}
