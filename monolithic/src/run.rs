//! The monolithic model in time: model (immutable), state, and workspace kept apart.

use feedcore::genalpha::{self, Iterate, StepError, StepReport};
use feedcore::rigid::RigidMotion;
use feedcore::scene::{LEGS, SensorKind, ValidScene};
use feedcore::{Quat, Vec3};
use nalgebra::Vector6;
use stewart::CommandState;
use stewart::constraints::{CABIN, DRIVING, ROWS_PER_LEG};

use crate::config::Config;
use crate::model::{BuildError, Model};
use crate::problem::{Coefficients, Fault, Scratch, Step, command_point, largest_value};

/// Why the monolithic model cannot be built or go on.
#[derive(Debug, thiserror::Error)]
pub enum MonolithicError {
    #[error(transparent)]
    Build(#[from] BuildError),
    #[error("monolithic model stopped at t = {time:.6} s: {reason}")]
    Stopped { time: f64, reason: StepError<Fault> },
    #[error("monolithic model at t = {time:.6} s: consistent initial accelerations: {reason}")]
    Start { time: f64, reason: Fault },
    /// The adaptive step found no acceptable step of at least `h_min`.
    #[error(
        "monolithic model at t = {time:.6} s: no step of at least h-min = {h_min:e} s converged \
         (last error {error:.3e} relative to the tolerance); lower --h-min"
    )]
    StepTooSmall { time: f64, error: f64, h_min: f64 },
    /// A sampled sensor samples at step starts: a step must not skip a sample.
    #[error(
        "monolithic model at t = {time:.6} s: step {h} s is longer than a quarter of the sensor's sample \
         period {period} s ([control] {key}): a sample is taken at the first step start after \
         its instant; take steps of at most {most} s or lower the sample rate"
    )]
    SensorStep { time: f64, h: f64, period: f64, key: &'static str, most: f64 },
}

impl MonolithicError {
    /// The time a step failed at, if it was a step.
    pub fn time(&self) -> Option<f64> {
        match self {
            MonolithicError::Stopped { time, .. }
            | MonolithicError::Start { time, .. }
            | MonolithicError::StepTooSmall { time, .. }
            | MonolithicError::SensorStep { time, .. } => Some(*time),
            MonolithicError::Build(_) => None,
        }
    }
}

/// Results of one time point.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub time: f64,
    pub cabin: RigidMotion,
    /// What the Stewart platform exerts on the cabin (force; moment about the centre point).
    pub wrench: Vector6<f64>,
    /// Actuator tensions, N.
    pub actuator_forces: [f64; LEGS],
    /// Largest |Φ| of all position constraints (m or rad).
    pub constraint_residual: f64,
    /// The platform centre and orientation (platform to cabin frame) as commanded, cabin frame
    /// (the joints hold it there to the Newton tolerance).
    pub platform: Vec3,
    pub platform_rotation: Quat,
    /// With an inertial unit ([control.imu]): the cabin pose the compensation estimates.
    pub estimate: Option<(Vec3, Quat)>,
    /// Leg lengths (joint centre to joint centre), m.
    pub leg_lengths: [f64; LEGS],
}

/// A saved state (see [`Monolithic::save`]): the integrator's and a sampled sensor's.
#[derive(Clone, Debug)]
pub struct Snapshot(genalpha::State<Config>, Option<CommandState>);

/// The monolithic model of a scene, running.
pub struct Monolithic {
    model: Model,
    state: genalpha::State<Config>,
    work: genalpha::Workspace<Config>,
    scratch: Scratch,
    /// A sampled sensor's state (scene `[control]`, sensor = "sampled"): sampled at each step's
    /// start from the accepted cabin pose, as the Stewart FMU does.
    command: Option<CommandState>,
}

impl Monolithic {
    /// Builds the model of `scene` at its static equilibrium, from time 0, with consistent
    /// accelerations and multipliers.
    pub fn new(scene: &ValidScene) -> Result<Monolithic, MonolithicError> {
        let start = Model::build(scene)?;
        let model = start.model;
        let fail = |reason: Fault| MonolithicError::Start { time: 0.0, reason };
        let command =
            model.stewart.compensation().filter(|c| c.sensor() == SensorKind::Sampled).map(|c| c.start_state());
        let point = command_point(&model, command.as_ref(), 0.0);
        let scratch = Scratch::new(&model, &start.config, &point, 0.0).map_err(|e| fail(e.into()))?;
        let (n, m) = (model.motion_dim(), stewart::CONSTRAINTS);
        let state = genalpha::State::new(0.0, start.config, start.velocity, vec![0.0; n], vec![0.0; m]);
        let mut mono = Monolithic { work: genalpha::Workspace::new(&state), model, state, scratch, command };
        mono.initial_acceleration().map_err(fail)?;
        Ok(mono)
    }

    /// Consistent accelerations and multipliers: `[M Φ_qᵀ; Φ_q 0] [v̇; λ] = [f − g; γ]`.
    fn initial_acceleration(&mut self) -> Result<(), Fault> {
        let (n, m) = (self.model.motion_dim(), stewart::CONSTRAINTS);
        let st = &self.state;
        let zero_motion = vec![0.0; n];
        let zero_lambda = vec![0.0; m];
        let at = Iterate {
            time: st.time,
            config: &st.config,
            increment: &zero_motion,
            velocity: &st.velocity,
            acceleration: &zero_motion,
            multipliers: &zero_lambda,
        };
        let mass =
            Coefficients { mass: 1.0, damping: 0.0, stiffness: 0.0, constraint_scale: 1.0, slack_as_taut: false };
        let mut x = vec![0.0; n + m];
        self.scratch.assemble(&self.model, &at, 1.0, &mut x, Some(&mass))?;
        self.scratch.factor_step = None; // factors of M, not of an iteration matrix
        x[..n].iter_mut().for_each(|r| *r = -*r);
        for (k, row) in self.scratch.rows.iter().enumerate() {
            x[n + k] = row.gamma;
        }
        self.scratch.kkt.solve(&mut x);
        if x.iter().any(|v| !v.is_finite()) {
            return Err(Fault::NotFinite("accelerations and multipliers"));
        }
        self.state.acceleration.copy_from_slice(&x[..n]);
        self.state.pseudo_acceleration.copy_from_slice(&x[..n]);
        self.state.multipliers.copy_from_slice(&x[n..]);
        Ok(())
    }

    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// The compensation that commands the platform (an `off` one for a scene without `[control]`).
    pub fn compensation(&self) -> Option<&stewart::Compensation> {
        self.model.stewart.compensation()
    }

    /// The cable–cabin system (its cables, for element forces).
    pub fn cable_system(&self) -> &cable::system::System {
        &self.model.system
    }

    /// The cable–cabin part of the configuration now: free nodes and the cabin pose.
    pub fn cable_config(&self) -> &cable::system::Config {
        &self.state.config.cable
    }

    /// One step of size `h` (halved internally should Newton fail).
    pub fn step(&mut self, h: f64) -> Result<StepReport, MonolithicError> {
        if let (Some(state), Some(c)) = (self.command.as_mut(), self.model.stewart.compensation()) {
            let time = self.state.time;
            if h > c.max_step() * (1.0 + 1e-9) {
                let (period, key) = c.step_period();
                return Err(MonolithicError::SensorStep { time, h, period, key, most: c.max_step() });
            }
            // the sample at the step's start measures the accepted cabin motion
            state.sample(c, time, &cabin_motion(&self.model, &self.state));
        }
        let mut problem = Step { model: &self.model, scratch: &mut self.scratch, command: self.command.as_ref() };
        let report = self
            .model
            .integrator
            .step(&mut problem, &mut self.state, &mut self.work, h, &(), &())
            .map_err(|f| MonolithicError::Stopped { time: f.time, reason: f.reason })?;
        self.scratch.accepted_time = self.state.time;
        Ok(report)
    }

    /// Cabin motion, Stewart wrench, actuator forces and constraint residual now.
    pub fn sample(&mut self) -> Sample {
        let (model, st, sc) = (&self.model, &self.state, &mut self.scratch);
        let point = command_point(model, self.command.as_ref(), st.time);
        // the strokes of an accepted time exist: its step computed them (kept, unless a
        // snapshot was restored since)
        let strokes = sc.strokes_at_time(st.time).or_else(|| model.stewart.strokes_at(&point, st.time).ok());
        if let Some(strokes) = &strokes
            && sc.accepted_time != st.time
        {
            sc.evaluate_accepted(model, &st.config, strokes, st.time);
        }
        let cabin = cabin_motion(model, st);
        let mut wrench = Vector6::zeros();
        let mut actuator_forces = [0.0; LEGS];
        for (k, row) in sc.accepted.iter().enumerate() {
            let lambda = st.multipliers[k];
            for s in 0..2 {
                if row.bodies[s] == CABIN {
                    wrench -= row.jacobian[s] * lambda;
                }
            }
            if k % ROWS_PER_LEG == DRIVING {
                actuator_forces[k / ROWS_PER_LEG] = lambda;
            }
        }
        Sample {
            time: st.time,
            cabin,
            wrench,
            actuator_forces,
            constraint_residual: largest_value(&sc.accepted[..]),
            platform: point.position,
            platform_rotation: point.rotation(),
            estimate: self
                .command
                .as_ref()
                .zip(model.stewart.compensation())
                .and_then(|(state, c)| state.estimate(c, st.time)),
            leg_lengths: strokes.map_or([f64::NAN; LEGS], |s| s.map(|s| s.length)),
        }
    }

    /// The current state, to return to with [`Monolithic::restore`] (e.g. to retake a step
    /// with another size).
    pub fn snapshot(&self) -> Snapshot {
        Snapshot(self.state.clone(), self.command.clone())
    }

    /// As [`Monolithic::snapshot`], into existing storage (no allocation).
    pub fn save(&self, into: &mut Snapshot) {
        into.0.clone_from(&self.state);
        into.1.clone_from(&self.command);
    }

    /// Returns to a saved state. The kept factorization stays: it only steers Newton (and is
    /// rebuilt for another step size), so the steps that follow agree with those after the
    /// snapshot to the Newton tolerance.
    pub fn restore(&mut self, snapshot: &Snapshot) {
        self.state.clone_from(&snapshot.0);
        self.command.clone_from(&snapshot.1);
        self.scratch.accepted_time = f64::NAN;
    }
}

/// The cabin's motion in an integrator state.
fn cabin_motion(model: &Model, st: &genalpha::State<Config>) -> RigidMotion {
    let c0 = model.body_offset(CABIN);
    let v3 = |v: &[f64], k: usize| Vec3::new(v[c0 + k], v[c0 + k + 1], v[c0 + k + 2]);
    RigidMotion {
        position: st.config.cable.position,
        orientation: st.config.cable.orientation,
        velocity: v3(&st.velocity, 0),
        angular_velocity: v3(&st.velocity, 3),
        acceleration: v3(&st.acceleration, 0),
        angular_acceleration: v3(&st.acceleration, 3),
    }
}
