//! The second level's controller as an FMI 2.0 and 3.0 Co-Simulation FMU (`control_fmu`).
//!
//! Inputs: the cabin's true motion, as the Stewart FMU takes it (`cabin.r`, `cabin.q`, `cabin.v`,
//! `cabin.w`, `cabin.a`, `cabin.alpha`; world frame) — what the instruments observe. Outputs: the
//! platform's command, its pose relative to its home pose (`command.r`: the centre's displacement,
//! cabin frame, m; `command.rot`: the rotation vector, rad), which the Stewart FMU follows with
//! `command_input = true`; and the cabin pose the controller estimates (`estimate.r`,
//! `estimate.q`). Parameter: `scene`, whose `[control]` holds every number.
//!
//! Inside, the code of the Stewart FMU's built-in second level ([`stewart::CommandState`]): the
//! sampled pose with its delay and seeded noise, the inertial unit, the Kalman filter, the notch,
//! the prediction. At the end of each step it measures the cabin as the inputs hold it (an
//! iterating importer's end-of-step values), at the sample instants that fall there, and hands on
//! the last command that applies by then; at the end of initialization it measures the start. Its
//! communication step is its command period (the inertial unit's, else the sensor's): a longer
//! step is refused, a shorter one takes each sample at the first communication point at or after
//! its instant. Outputs change only through a step (no direct feedthrough); in initialization
//! mode they follow the inputs (the start's measurement, made again for each).

use std::any::Any;
use std::path::Path;

use feedcore::scene::{Scene, SceneError, SensorKind, ValidScene};
use feedcore::{Quat, Vec3};
use fmi::description::Causality;
use fmi::export::{Model, ModelError, StepOutcome};
use fmi::resources::{FileKind, FileParameter, KeptState, SavedFile};
use fmi::{CoSimulationFlags, ModelDescription, Resource, Variable};
use serde::{Deserialize, Serialize};
use stewart::{CommandState, Compensation, Stewart};
use stewart_fmu::{INPUTS, cabin_motion, rest_inputs};

/// The scene used unless the `scene` parameter names another one.
pub const DEFAULT_SCENE: &str = "lt50m_C_compensated.toml";
/// Identifies the variable table: change it whenever the table changes.
pub const GUID: &str = "{5d0c7a93-2e61-4f8b-b7c4-91a3e6d25f08}";

/// Scene files: shipped in `resources/` and compiled in; at most 1 MiB.
static SCENES: FileKind<ValidScene, SceneError> = FileKind::new(&feedcore::shipped::SCENES, 1 << 20, Scene::from_toml);

/// The variables: the cabin inputs are the Stewart FMU's, in the same order.
pub mod vr {
    use fmi::table::Block;

    const WXYZ: &[&str] = &["w", "x", "y", "z"];

    fmi::variable_table! {
        /// Real inputs, the cabin's true motion (the Stewart FMU's cabin inputs).
        R = stewart_fmu::cabin::R,
        Q = stewart_fmu::cabin::Q,
        V = stewart_fmu::cabin::V,
        W = stewart_fmu::cabin::W,
        A = stewart_fmu::cabin::A,
        ALPHA = stewart_fmu::cabin::ALPHA,
        /// Real outputs: the command, and the controller's estimate of the cabin pose.
        COMMAND_R = Block::output("command.r", 3, "m",
            "commanded displacement of the moving platform's centre from its home position, cabin frame"),
        COMMAND_ROT = Block::output("command.rot", 3, "rad",
            "commanded rotation of the moving platform from its home attitude, rotation vector in the cabin frame"),
        ESTIMATE_R = Block::output("estimate.r", 3, "m",
            "cabin position the controller estimates, world frame ([control.imu]; else the reference pose)"),
        ESTIMATE_Q = Block::output("estimate.q", 4, "",
            "cabin orientation the controller estimates ({k}), body to world ([control.imu]; else the reference)").labels(WXYZ),
    }
    /// String `scene`.
    pub const SCENE: u32 = 0;
    /// One past the last Real.
    pub const END: u32 = ESTIMATE_Q + 4;
}

/// Everything but the scene file.
#[derive(Debug, Serialize, Deserialize)]
struct Data {
    initialized: bool,
    time: f64,
    inputs: [f64; INPUTS],
    /// The controller's state (after initialization).
    controller: Option<CommandState>,
    /// The command handed on now, relative to home.
    command: [f64; 6],
}

impl Clone for Data {
    fn clone(&self) -> Self {
        let mut copy = Data { controller: None, ..*self };
        copy.controller.clone_from(&self.controller);
        copy
    }

    /// Reuses the controller's queues (a state saved at every step allocates nothing).
    fn clone_from(&mut self, source: &Self) {
        let Data { initialized, time, inputs, controller, command } = source;
        (self.initialized, self.time, self.inputs, self.command) = (*initialized, *time, *inputs, *command);
        self.controller.clone_from(controller);
    }
}

/// A saved state: the scene file's name and the rest.
#[derive(Serialize, Deserialize)]
pub struct SavedControl<'a> {
    #[serde(borrow)]
    scene: SavedFile<'a>,
    data: Data,
}

pub struct ControlFmu {
    scene: FileParameter<ValidScene, SceneError>,
    data: Data,
    /// The scene's second level, built when first needed.
    compensation: Option<Compensation>,
}

/// The names of the outputs, in value-reference order.
pub fn output_names() -> Vec<String> {
    fmi::table::names(vr::TABLE, Causality::Output)
}

impl ControlFmu {
    /// The scene's second level; refused for a scene whose instrument is not sampled.
    fn compensation(&mut self) -> Result<&Compensation, ModelError> {
        if self.compensation.is_none() {
            let scene = self.scene.value();
            let label = self.scene.label();
            if scene.control.is_none() {
                return Err(format!(
                    "scene `{label}` has no [control]: the controller takes its instruments, filter and target from it"
                )
                .into());
            }
            let c = Stewart::from_scene(scene)?.compensation().cloned().ok_or("the scene has no second level")?;
            if c.sensor() == SensorKind::Ideal {
                return Err(format!(
                    "scene `{label}`: [control] sensor = \"ideal\" measures the cabin continuously, and its command follows \
                     the cabin's motion at every instant, which a controller stepping at communication points cannot \
                     hand on; use sensor = \"sampled\" (or \"off\": the platform held at home)"
                )
                .into());
            }
            self.compensation = Some(c);
        }
        self.compensation.as_ref().ok_or_else(|| "the second level could not be built".into())
    }

    /// The command and estimate now: after initialization the controller's; before, those of
    /// the start's measurement made on the inputs as they are.
    fn outputs(&mut self) -> Result<([f64; 6], Vec3, Quat), ModelError> {
        let (t, u) = (self.data.time, self.data.inputs);
        let started = self.data.controller.take();
        let result = self.compensation().and_then(|c| {
            let measured;
            let state = match &started {
                Some(state) => state,
                None => {
                    let mut fresh = c.start_state();
                    if c.sensor() == SensorKind::Sampled {
                        fresh.sample(c, t, &cabin_motion(&u)?);
                    }
                    measured = fresh;
                    &measured
                }
            };
            let command = c.relative_command(&state.command_at(t));
            let (p, q) = state.estimate(c, t).unwrap_or_else(|| c.reference());
            Ok((command, p, q))
        });
        self.data.controller = started;
        result
    }

    fn restore_parts(&mut self, scene: SavedFile<'_>, data: &Data) -> Result<(), ModelError> {
        if self.scene.restore(scene)? {
            self.compensation = None;
        }
        self.data.clone_from(data);
        Ok(())
    }
}

impl Model for ControlFmu {
    type State<'a> = SavedControl<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let rest = rest_inputs(SCENES.open(None, DEFAULT_SCENE)?.value());
        let mut variables = fmi::table::variables(vr::TABLE, |v| rest[v as usize]);
        let inputs: Vec<String> = fmi::table::names(vr::TABLE, Causality::Input);
        for v in variables.iter_mut().filter(|v| v.causality == Causality::Output) {
            // made in a step from the inputs held over it, never at once; in initialization mode
            // from the start's measurement of the inputs
            v.depends_on = Some(Vec::new());
            let mut initially = inputs.clone();
            initially.push("scene".into());
            v.initial_depends_on = Some(initially);
        }
        variables.push(Variable::parameter("scene", vr::SCENE, DEFAULT_SCENE, false).describe(
            "scene file (TOML) whose [control] the controller runs; relative paths resolve against resources/, which \
             holds the shipped scenes; or the scene itself, data:application/toml;name=NAME,TEXT (TEXT percent-encoded)",
        ));
        let flags = CoSimulationFlags { provides_directional_derivative: false, ..CoSimulationFlags::EXPORTED };
        Ok(ModelDescription::co_simulation(
            "control_fmu",
            GUID,
            "The Stewart platform's second level: instruments, fusion, notch and prediction; the cabin's motion in, the \
             platform's command (pose relative to home) out",
            env!("CARGO_PKG_VERSION"),
            flags,
            variables,
        ))
    }

    fn resources() -> Vec<Resource> {
        SCENES.resources()
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let scene = SCENES.open(resources, DEFAULT_SCENE)?;
        let inputs = rest_inputs(scene.value());
        Ok(ControlFmu {
            scene,
            data: Data { initialized: false, time: 0.0, inputs, controller: None, command: [0.0; 6] },
            compensation: None,
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let slot =
            self.data.inputs.get_mut(vr as usize).ok_or_else(|| format!("value reference {vr} is not an input"))?;
        *slot = value;
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        if let Some(u) = self.data.inputs.get(vr as usize) {
            return Ok(*u);
        }
        if !(vr::COMMAND_R..vr::END).contains(&vr) {
            return Err(format!("value reference {vr} is not a Real of this model").into());
        }
        let (command, p, q) = if self.data.initialized {
            let state = self.data.controller.as_ref().ok_or("the controller has no state")?;
            let c = self.compensation.as_ref().ok_or("the second level is not built")?;
            let (p, q) = state.estimate(c, self.data.time).unwrap_or_else(|| c.reference());
            (self.data.command, p, q)
        } else {
            self.outputs()?
        };
        let q = q.into_inner();
        Ok(match vr {
            vr::COMMAND_R..vr::ESTIMATE_R => command[(vr - vr::COMMAND_R) as usize],
            vr::ESTIMATE_R..vr::ESTIMATE_Q => p[(vr - vr::ESTIMATE_R) as usize],
            _ => [q.w, q.i, q.j, q.k][(vr - vr::ESTIMATE_Q) as usize],
        })
    }

    /// `scene`, the only String.
    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        if self.scene.set(value)? {
            self.compensation = None;
        }
        Ok(())
    }

    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Ok(self.scene.name().to_owned())
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        let cabin = cabin_motion(&self.data.inputs)?;
        let c = self.compensation()?;
        let mut state = c.start_state();
        if c.sensor() == SensorKind::Sampled {
            state.sample(c, start_time, &cabin);
        }
        let command = c.relative_command(&state.command_at(start_time));
        self.data.controller = Some(state);
        self.data.command = command;
        self.data.time = start_time;
        self.data.initialized = true;
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let cabin = cabin_motion(&self.data.inputs)?;
        let mut state = self.data.controller.take().ok_or("the controller has no state")?;
        let result = self.compensation().and_then(|c| {
            let (period, key) = c.step_period();
            if h > period * (1.0 + 1e-9) {
                return Err(format!(
                    "communication step {h} s at t = {t} s is longer than the controller's command period {period} s \
                     ([control] {key}): each command is made at a communication point; step it at its period"
                )
                .into());
            }
            if c.sensor() == SensorKind::Sampled {
                state.sample(c, t + h, &cabin);
            }
            Ok(c.relative_command(&state.command_at(t + h)))
        });
        self.data.controller = Some(state);
        self.data.command = result?;
        self.data.time = t + h;
        Ok(StepOutcome::Complete)
    }

    fn save(&mut self) -> Result<SavedControl<'_>, ModelError> {
        Ok(SavedControl { scene: self.scene.saved(), data: self.data.clone() })
    }

    fn restore(&mut self, saved: SavedControl<'_>) -> Result<(), ModelError> {
        self.restore_parts(saved.scene, &saved.data)
    }

    fn save_in_memory(&mut self, saved: &mut Option<Box<dyn Any + Send>>) -> Result<bool, ModelError> {
        Ok(KeptState::save_into(saved, self.scene.saved(), &self.data))
    }

    fn restore_in_memory(&mut self, saved: &(dyn Any + Send)) -> Result<(), ModelError> {
        let (scene, data) = KeptState::<Data>::kept(saved, "the control FMU")?;
        self.restore_parts(scene, data)
    }
}
