//! Time integration of the cable–cabin system with the shared generalized-α integrator
//! ([`feedcore::genalpha`]): this module is the model side of a step — residual, iteration
//! matrix `S = β′ M + γ′ C + K T` factorized in the chain structure (linear cost in the nodes),
//! and placing a trial configuration — plus what the co-simulation needs on top: the sensitivity
//! of a step to the wrench, and saving and restoring the state bit for bit.
//!
//! The factorization is kept from step to step while Newton converges quickly with it; it is
//! part of the state, so a rollback reproduces the same bits.

use std::sync::Arc;

use feedcore::genalpha::{self, Failure, Integrator, Iterate, IterationMatrix, Newton, OptionsError, StepError};
use feedcore::rigid::{MotionChange, left_jacobian_so3};
use feedcore::{Quat, Vec3};

use nalgebra::{Matrix3x6, Vector6};

use crate::chain_matrix::{ChainFactor, ChainMatrix, FactorError};
use crate::system::{Coefficients, Config, Energy, Support, System};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicsOptions {
    /// High-frequency spectral radius ρ∞ ∈ [0, 1].
    pub rho_inf: f64,
    /// Newton has converged when the largest correction is below this (m, or rad).
    pub newton_tol: f64,
    pub newton_max_iter: usize,
}

/// What the cable–cabin model itself can object to during a step.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CableFault {
    #[error("the external wrench is not finite: {0:?} (force N, moment N·m)")]
    Wrench([f64; 6]),
    #[error("iteration matrix: {0}")]
    Factor(#[from] FactorError),
}

/// A simulation that cannot start or go on.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    #[error("cable–cabin dynamics stopped at t = {time:.6} s: {reason}")]
    Stopped { time: f64, reason: StepError<CableFault> },
    #[error("cable–cabin dynamics: {0}")]
    Options(#[from] OptionsError),
    #[error("cable–cabin dynamics at t = {time:.6} s: {what}")]
    Start { time: f64, what: StartError },
    #[error("cable–cabin dynamics at t = {time:.6} s: sensitivity matrix: {source}")]
    Sensitivity { time: f64, source: FactorError },
    #[error("saved cable–cabin state: {0}")]
    Saved(#[from] SavedStateError),
}

impl DynamicsError {
    /// The time a step failed at, if it was a step.
    pub fn time(&self) -> Option<f64> {
        match self {
            DynamicsError::Stopped { time, .. }
            | DynamicsError::Start { time, .. }
            | DynamicsError::Sensitivity { time, .. } => Some(*time),
            _ => None,
        }
    }
}

impl From<Failure<CableFault>> for DynamicsError {
    fn from(f: Failure<CableFault>) -> Self {
        DynamicsError::Stopped { time: f.time, reason: f.reason }
    }
}

/// Why the initial state cannot be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StartError {
    #[error("the velocity vector has {found} entries; the system has {expected} unknowns")]
    VelocityLength { found: usize, expected: usize },
    #[error("mass matrix: {0}")]
    Mass(FactorError),
    #[error("the initial {0} is not finite")]
    NotFinite(&'static str),
}

/// A saved state that does not fit this system.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SavedStateError {
    #[error("state has {found} numbers, at least {expected} expected")]
    TooShort { found: usize, expected: usize },
    #[error("state has trailing numbers")]
    Trailing,
    #[error("a state of a model with {found} unknowns; this one has {expected}")]
    OtherModel { found: usize, expected: usize },
    #[error("{0}")]
    Factor(#[from] FactorError),
}

/// Everything that determines the future of a simulation (what a rollback restores).
#[derive(Clone, Debug)]
pub struct State {
    /// Time, configuration, velocities and accelerations.
    pub motion: genalpha::State<Config>,
    /// The kept iteration matrix factorization and the step size it was built for; shared with
    /// the states saved in memory since it was built ([`Dynamics::save_into`]).
    factor: Arc<ChainFactor>,
    factor_step: Option<f64>,
    /// The step that led here (what its sensitivity to the wrench needs).
    pub last_step: Option<LastStep>,
}

impl State {
    /// Copies `other` into this state's storage (no allocation); the factorization is shared.
    fn copy_from(&mut self, other: &State) {
        self.motion.clone_from(&other.motion);
        self.factor = Arc::clone(&other.factor);
        self.factor_step = other.factor_step;
        self.last_step = other.last_step;
    }
}

/// Step size, end-of-step wrench and rotation increment of the step that led to a state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LastStep {
    pub h: f64,
    pub wrench: Vector6<f64>,
    pub rotation_increment: Vec3,
}

/// Change of the cabin's motion and of the end tensions caused by a change of the wrench.
#[derive(Clone, Debug, PartialEq)]
pub struct CabinDelta {
    pub motion: MotionChange,
    /// (anchor end, cabin end) per cable.
    pub tensions: Vec<(f64, f64)>,
}

/// Motion of the cabin centre point (world frame).
pub use feedcore::rigid::RigidMotion as CabinKinematics;

/// Work done in one step.
pub use feedcore::genalpha::StepReport as StepStats;

/// The cable–cabin model in time: the system (immutable), the integrator, the state, and the
/// scratch of steps and sensitivities.
pub struct Dynamics {
    system: System,
    integrator: Integrator,
    state: State,
    work: genalpha::Workspace<Config>,
    matrix: ChainMatrix,
    /// Scratch of the sensitivity solves.
    scratch: Vec<f64>,
    /// Exact iteration matrix at the current state, factorized when a sensitivity is asked for,
    /// and how each cable's end nodes follow the cabin in it.
    sensitivity: Option<ChainFactor>,
    ends: Vec<(Matrix3x6<f64>, Matrix3x6<f64>)>,
}

/// The model side of one generalized-α step (see [`genalpha::Problem`]).
struct Step<'a> {
    system: &'a System,
    wrench: Vector6<f64>,
    matrix: &'a mut ChainMatrix,
    factor: &'a mut Arc<ChainFactor>,
    factor_step: &'a mut Option<f64>,
}

impl genalpha::Problem for Step<'_> {
    type Config = Config;
    type Input = Vector6<f64>;
    type Error = CableFault;

    /// Nodes and cabin move smoothly (no constraints at index 3).
    fn extrapolated_unknowns(&self) -> usize {
        self.system.dim()
    }

    fn place(&self, base: &Config, increment: &[f64], trial: &mut Config) {
        trial.set_displaced(base, increment);
    }

    fn begin_step(&mut self, time: f64, wrench: &Vector6<f64>) -> Result<(), CableFault> {
        if wrench.iter().any(|w| !w.is_finite()) {
            return Err(CableFault::Wrench(std::array::from_fn(|k| wrench[k])));
        }
        self.wrench = *wrench + self.system.scene_load(time);
        Ok(())
    }

    fn residual(&mut self, at: &Iterate<'_, Config>, _constraint_scale: f64, residual: &mut [f64]) {
        self.system.residual(at.config, at.velocity, at.acceleration, &self.wrench, residual);
    }

    fn factorize(
        &mut self,
        at: &Iterate<'_, Config>,
        s: &IterationMatrix,
        residual: &mut [f64],
    ) -> Result<(), CableFault> {
        let c0 = self.system.cabin_offset();
        let theta = Vec3::from_column_slice(&at.increment[c0 + 3..c0 + 6]);
        let coef = Coefficients {
            mass: s.mass,
            damping: s.damping,
            stiffness: 1.0,
            rotation_tangent: left_jacobian_so3(&theta),
            slack_as_taut: s.slack_as_taut,
        };
        let matrix = Some((&mut *self.matrix, coef));
        self.system.assemble(at.config, at.velocity, at.acceleration, &self.wrench, residual, matrix);
        *self.factor_step = None;
        // make_mut copies the factorization when a saved state shares it, else writes in place
        self.matrix.factorize_into(self.system.support == Support::Fixed, Arc::make_mut(self.factor))?;
        *self.factor_step = Some(s.step);
        Ok(())
    }

    fn factorized_step(&self) -> Option<f64> {
        *self.factor_step
    }

    fn solve(&mut self, rhs: &mut [f64]) {
        self.factor.solve_in_place(rhs);
    }

    fn unknown_name(&self, index: usize) -> String {
        self.system.unknown_name(index)
    }
}

impl Dynamics {
    /// Starts at `config` with `velocity` at time `t0` under `wrench`; the initial acceleration
    /// is solved from the equations of motion. With the cabin held fixed its velocity is zero.
    pub fn new(
        system: System,
        config: Config,
        mut velocity: Vec<f64>,
        t0: f64,
        wrench: &Vector6<f64>,
        options: DynamicsOptions,
    ) -> Result<Dynamics, DynamicsError> {
        let n = system.dim();
        let start = |what| DynamicsError::Start { time: t0, what };
        if velocity.len() != n {
            return Err(start(StartError::VelocityLength { found: velocity.len(), expected: n }));
        }
        let shortest = system.element_length.iter().copied().fold(f64::INFINITY, f64::min);
        let newton = Newton::new(options.newton_tol, options.newton_max_iter, shortest)?;
        let integrator = Integrator::new(options.rho_inf, newton)?;
        let fixed = system.support == Support::Fixed;
        let c0 = system.cabin_offset();
        if fixed {
            velocity[c0..].fill(0.0);
        }
        if velocity.iter().chain(wrench.iter()).any(|x| !x.is_finite()) {
            return Err(start(StartError::NotFinite("velocity or wrench")));
        }
        let mut residual = vec![0.0; n];
        let mut matrix = system.new_matrix();
        let zero = vec![0.0; n];
        // M v̇ = −r(v̇ = 0)
        let load = wrench + system.scene_load(t0);
        system.assemble(&config, &velocity, &zero, &load, &mut residual, Some((&mut matrix, Coefficients::MASS)));
        let mass = matrix.factorize(fixed).map_err(|e| start(StartError::Mass(e)))?;
        let mut acceleration: Vec<f64> = residual.iter().map(|r| -r).collect();
        mass.solve_in_place(&mut acceleration);
        if acceleration.iter().any(|a| !a.is_finite()) {
            return Err(start(StartError::NotFinite("acceleration")));
        }
        let motion = genalpha::State::new(t0, config, velocity, acceleration, Vec::new());
        let work = genalpha::Workspace::new(&motion);
        let state = State {
            motion,
            factor: Arc::new(ChainFactor::new(system.cables(), system.free_nodes())),
            factor_step: None,
            last_step: None,
        };
        Ok(Dynamics { system, integrator, state, work, matrix, scratch: residual, sensitivity: None, ends: Vec::new() })
    }

    pub fn time(&self) -> f64 {
        self.state.motion.time
    }

    pub fn dim(&self) -> usize {
        self.system.dim()
    }

    pub fn system(&self) -> &System {
        &self.system
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    /// The current configuration.
    pub fn config(&self) -> &Config {
        &self.state.motion.config
    }

    /// Advances by `h` with the external `wrench` (force, moment about the cabin centre point,
    /// world frame) acting at the end of the step.
    ///
    /// Should Newton fail — an element snapping from slack to taut is an impact — the step is
    /// taken again as halves (the wrench interpolated linearly from the last one), down to
    /// 1/64 of `h`, before the simulation stops with the reason.
    pub fn step(&mut self, h: f64, wrench: &Vector6<f64>) -> Result<StepStats, DynamicsError> {
        let from = self.state.last_step.map_or(*wrench, |l| l.wrench);
        let State { motion, factor, factor_step, last_step } = &mut self.state;
        let mut problem = Step { system: &self.system, wrench: *wrench, matrix: &mut self.matrix, factor, factor_step };
        let report = self.integrator.step(&mut problem, motion, &mut self.work, h, &from, wrench)?;
        let c0 = self.system.cabin_offset();
        *last_step = Some(LastStep {
            h: report.last_step,
            wrench: *wrench,
            rotation_increment: Vec3::from_column_slice(&self.work.increment()[c0 + 3..c0 + 6]),
        });
        self.sensitivity = None;
        Ok(report)
    }

    /// How the state reached by the last step would change with the end-of-step wrench:
    /// `δ(motion, tensions) = ∂/∂W · seed`, from the exact iteration matrix at the converged
    /// state (factorized once per step, on the first call). Before any step, the direct
    /// feedthrough: only the accelerations respond, through the mass matrix. The end tensions'
    /// response (the chain ends' response to the cabin, once per step, and a pass over the end
    /// elements per seed) only `with_tensions`; otherwise `tensions` is empty.
    pub fn wrench_sensitivity(
        &mut self,
        seed: &Vector6<f64>,
        with_tensions: bool,
    ) -> Result<CabinDelta, DynamicsError> {
        let c0 = self.system.cabin_offset();
        let fixed = self.system.support == Support::Fixed;
        let st = &self.state.motion;
        let ga = self.integrator.coefficients();
        let (bp, gp, theta) = match &self.state.last_step {
            Some(last) => (ga.beta_prime(last.h), ga.gamma_prime(last.h), last.rotation_increment),
            None => (f64::NAN, f64::NAN, Vec3::zeros()),
        };
        if self.sensitivity.is_none() {
            let (coef, wrench) = match &self.state.last_step {
                Some(last) => (
                    Coefficients {
                        mass: bp,
                        damping: gp,
                        stiffness: 1.0,
                        rotation_tangent: left_jacobian_so3(&theta),
                        slack_as_taut: false,
                    },
                    last.wrench,
                ),
                None => (Coefficients::MASS, Vector6::zeros()),
            };
            self.system.assemble(
                &st.config,
                &st.velocity,
                &st.acceleration,
                &wrench,
                &mut self.scratch,
                Some((&mut self.matrix, coef)),
            );
            let f =
                self.matrix.factorize(fixed).map_err(|source| DynamicsError::Sensitivity { time: st.time, source })?;
            self.ends.clear(); // filled on the first call that asks for tensions
            self.sensitivity = Some(f);
        }
        // r contains −W on the cabin rows: S δu = δW there, and zero on the nodes, whose
        // response follows the cabin's (only the chain ends matter, for the end tensions).
        let factor = self.sensitivity.as_ref().expect("factorized above");
        let xc = factor.solve_cabin_load(seed);
        let (dr, dth) = (xc.fixed_rows::<3>(0).into_owned(), xc.fixed_rows::<3>(3).into_owned());
        if self.state.last_step.is_none() {
            return Ok(CabinDelta {
                motion: MotionChange { acceleration: dr, angular_acceleration: dth, ..MotionChange::default() },
                tensions: if with_tensions { vec![(0.0, 0.0); self.system.cables()] } else { Vec::new() },
            });
        }
        // the rotation coordinate is an increment inside exp(); the world rotation it makes:
        let dphi = left_jacobian_so3(&theta) * dth;
        let motion = |tensions| CabinDelta {
            motion: MotionChange {
                position: dr,
                rotation: dphi,
                velocity: dr * gp,
                angular_velocity: dth * gp,
                acceleration: dr * bp,
                angular_acceleration: dth * bp,
            },
            tensions,
        };
        if !with_tensions {
            return Ok(motion(Vec::new()));
        }
        if self.ends.is_empty() {
            self.ends.extend((0..self.system.cables()).map(|c| factor.end_response(c)));
        }
        let m = self.system.free_nodes();
        let du = &mut self.scratch;
        for (c, (first, last)) in self.ends.iter().enumerate() {
            if m > 0 {
                du[3 * c * m..3 * c * m + 3].copy_from_slice((first * xc).as_slice());
                du[3 * (c * m + m - 1)..3 * (c * m + m)].copy_from_slice((last * xc).as_slice());
            }
        }
        du[c0..c0 + 3].copy_from_slice(dr.as_slice());
        du[c0 + 3..c0 + 6].copy_from_slice(dphi.as_slice());
        Ok(motion(self.system.end_tension_sensitivity(&st.config, du)))
    }

    /// The whole state as numbers (bit for bit), for saving and restoring a simulation.
    pub fn encode_state(&self, out: &mut Vec<f64>) {
        let st = &self.state.motion;
        out.push(st.time);
        for x in &st.config.nodes {
            out.extend_from_slice(x.as_slice());
        }
        out.extend_from_slice(st.config.position.as_slice());
        let q = st.config.orientation.quaternion();
        out.extend_from_slice(&[q.w, q.i, q.j, q.k]);
        out.extend_from_slice(&st.velocity);
        out.extend_from_slice(&st.acceleration);
        out.extend_from_slice(&st.pseudo_acceleration);
        out.extend_from_slice(&st.previous_acceleration);
        out.push(st.previous_step);
        match &self.state.last_step {
            Some(l) => {
                out.push(l.h);
                out.extend_from_slice(l.wrench.as_slice());
                out.extend_from_slice(l.rotation_increment.as_slice());
            }
            None => out.extend_from_slice(&[0.0; 10]),
        }
        match self.state.factor_step {
            Some(h) => {
                out.push(h);
                self.state.factor.encode(out);
            }
            None => out.push(0.0),
        }
    }

    /// The whole state kept in memory, into `saved` (its storage reused): the motion copied, the
    /// factorization shared (it changes only when Newton refactorizes, and then not in place).
    pub fn save_into(&self, saved: &mut Option<State>) {
        match saved {
            Some(s) => s.copy_from(&self.state),
            None => *saved = Some(self.state.clone()),
        }
    }

    /// Restores a state kept by [`Dynamics::save_into`] of a model of the same system.
    pub fn restore_from(&mut self, saved: &State) -> Result<(), DynamicsError> {
        let (found, expected) = (saved.motion.dim(), self.dim());
        if found != expected || saved.motion.config.nodes.len() != self.state.motion.config.nodes.len() {
            return Err(SavedStateError::OtherModel { found, expected }.into());
        }
        self.state.copy_from(saved);
        self.sensitivity = None;
        Ok(())
    }

    /// Restores a state written by [`Dynamics::encode_state`] of the same system, in place.
    pub fn decode_state(&mut self, data: &[f64]) -> Result<(), DynamicsError> {
        let n = self.dim();
        let nodes = self.state.motion.config.nodes.len();
        let fixed_len = 1 + 3 * nodes + 7 + 4 * n + 1 + 10 + 1;
        if data.len() < fixed_len {
            return Err(SavedStateError::TooShort { found: data.len(), expected: fixed_len }.into());
        }
        let h = data[fixed_len - 1];
        let factor_data = &data[fixed_len..];
        if h == 0.0 && !factor_data.is_empty() {
            return Err(SavedStateError::Trailing.into());
        }
        // the factorization first: it is the only part that can still be refused
        if h != 0.0 {
            self.state.factor_step = None;
            Arc::make_mut(&mut self.state.factor).decode_into(factor_data).map_err(SavedStateError::from)?;
        }
        self.state.factor_step = (h != 0.0).then_some(h);
        let st = &mut self.state.motion;
        let mut pos = 0;
        let mut take = |k: usize| {
            let s = &data[pos..pos + k];
            pos += k;
            s
        };
        st.time = take(1)[0];
        for x in st.config.nodes.iter_mut() {
            *x = Vec3::from_column_slice(take(3));
        }
        st.config.position = Vec3::from_column_slice(take(3));
        let q = take(4);
        st.config.orientation = Quat::new_unchecked(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        st.velocity.copy_from_slice(take(n));
        st.acceleration.copy_from_slice(take(n));
        st.pseudo_acceleration.copy_from_slice(take(n));
        st.previous_acceleration.copy_from_slice(take(n));
        st.previous_step = take(1)[0];
        let l = take(10);
        self.state.last_step = (l[0] != 0.0).then(|| LastStep {
            h: l[0],
            wrench: Vector6::from_column_slice(&l[1..7]),
            rotation_increment: Vec3::from_column_slice(&l[7..10]),
        });
        self.sensitivity = None;
        Ok(())
    }

    /// Motion of the cabin centre point.
    pub fn cabin(&self) -> CabinKinematics {
        let c0 = self.system.cabin_offset();
        let st = &self.state.motion;
        let v3 = |v: &[f64], k: usize| Vec3::new(v[c0 + k], v[c0 + k + 1], v[c0 + k + 2]);
        CabinKinematics {
            position: st.config.position,
            orientation: st.config.orientation,
            velocity: v3(&st.velocity, 0),
            angular_velocity: v3(&st.velocity, 3),
            acceleration: v3(&st.acceleration, 0),
            angular_acceleration: v3(&st.acceleration, 3),
        }
    }

    /// Axial force of the element next to the anchor and next to the cabin, per cable.
    pub fn end_tensions(&self, out: &mut [(f64, f64)]) {
        self.system.end_tensions(&self.state.motion.config, out);
    }

    /// Energy, with the gravitational part measured from `reference`.
    pub fn energy(&self, reference: &Config) -> Energy {
        self.system.energy(&self.state.motion.config, &self.state.motion.velocity, reference)
    }
}
