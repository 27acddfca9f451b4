//! Implicit time integration of the cable–cabin system: generalized-α (Chung–Hulbert
//! coefficients, Arnold–Brüls form on the rotation group, see [`feedcore::genalpha`]) with
//! Newton iterations on the position increment.
//!
//! Each step solves `r(q_{n+1}, v_{n+1}, v̇_{n+1}) = 0` with the iteration matrix
//! `S = β′ M + γ′ C + K T`, factorized in the chain structure (linear cost in the nodes). The
//! factorization is kept from step to step while Newton converges quickly with it and is
//! refreshed when the contraction slows down; it is part of the state, so a rollback
//! reproduces the same bits.

use std::fmt;

use feedcore::genalpha::GenAlpha;
use feedcore::rigid::left_jacobian_so3;
use feedcore::{Quat, Vec3};
use nalgebra::Vector6;

use crate::chain_matrix::{ChainFactor, ChainMatrix};
use crate::system::{Coefficients, Config, Energy, Support, System};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicsOptions {
    /// High-frequency spectral radius ρ∞ ∈ [0, 1].
    pub rho_inf: f64,
    /// Newton has converged when the largest correction is below this (m, or rad).
    pub newton_tol: f64,
    pub newton_max_iter: usize,
}

/// A simulation that cannot go on: when and why.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicsError {
    pub time: f64,
    pub reason: String,
}

impl fmt::Display for DynamicsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cable–cabin dynamics stopped at t = {:.6} s: {}", self.time, self.reason)
    }
}

impl std::error::Error for DynamicsError {}

/// Everything that determines the future of a simulation (what a rollback restores).
#[derive(Clone, Debug)]
pub struct State {
    pub time: f64,
    pub config: Config,
    pub velocity: Vec<f64>,
    /// True acceleration v̇.
    pub acceleration: Vec<f64>,
    /// The generalized-α pseudo-acceleration.
    pub pseudo_acceleration: Vec<f64>,
    /// Iteration matrix factorization and the step size it was built for.
    pub factor: Option<(ChainFactor, f64)>,
    /// The step that led here (what its sensitivity to the wrench needs).
    pub last_step: Option<LastStep>,
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
    pub position: Vec3,
    /// World-frame rotation vector.
    pub rotation: Vec3,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
    pub acceleration: Vec3,
    pub angular_acceleration: Vec3,
    /// (anchor end, cabin end) per cable.
    pub tensions: Vec<(f64, f64)>,
}

/// Motion of the cabin centre point (world frame).
pub use feedcore::rigid::RigidMotion as CabinKinematics;

/// Work done in one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepStats {
    pub iterations: usize,
    pub factorizations: usize,
}

pub struct Dynamics {
    pub system: System,
    pub options: DynamicsOptions,
    coef: GenAlpha,
    pub state: State,
    // scratch, reused every step
    trial: Config,
    increment: Vec<f64>,
    velocity: Vec<f64>,
    acceleration: Vec<f64>,
    residual: Vec<f64>,
    /// The last Newton correction.
    delta: Vec<f64>,
    matrix: ChainMatrix,
    /// Exact iteration matrix at the current state, factorized when a sensitivity is asked for.
    sensitivity: Option<ChainFactor>,
}

fn vec_max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

impl Dynamics {
    /// Starts at `config` with `velocity` at time `t0` under `wrench`; the initial acceleration
    /// is solved from the equations of motion.
    pub fn new(
        system: System,
        config: Config,
        velocity: Vec<f64>,
        t0: f64,
        wrench: &Vector6<f64>,
        options: DynamicsOptions,
    ) -> Result<Dynamics, DynamicsError> {
        let n = system.dim();
        assert_eq!(velocity.len(), n, "velocity vector has the wrong length");
        let mut residual = vec![0.0; n];
        let mut matrix = system.new_matrix();
        let zero = vec![0.0; n];
        // M v̇ = −r(v̇ = 0)
        system.assemble(&config, &velocity, &zero, wrench, &mut residual, Some((&mut matrix, Coefficients::MASS)));
        let fixed = system.support == Support::Fixed;
        let mass =
            matrix.factorize(fixed).map_err(|e| DynamicsError { time: t0, reason: format!("mass matrix: {e}") })?;
        let mut acceleration: Vec<f64> = residual.iter().map(|r| -r).collect();
        mass.solve_in_place(&mut acceleration);
        if acceleration.iter().any(|a| !a.is_finite()) {
            return Err(DynamicsError { time: t0, reason: "the initial acceleration is not finite".into() });
        }
        let state = State {
            time: t0,
            config: config.clone(),
            velocity,
            pseudo_acceleration: acceleration.clone(),
            acceleration,
            factor: None,
            last_step: None,
        };
        Ok(Dynamics {
            coef: GenAlpha::new(options.rho_inf),
            system,
            options,
            state,
            trial: config,
            increment: vec![0.0; n],
            velocity: vec![0.0; n],
            acceleration: vec![0.0; n],
            residual,
            delta: vec![0.0; n],
            matrix,
            sensitivity: None,
        })
    }

    pub fn time(&self) -> f64 {
        self.state.time
    }

    pub fn dim(&self) -> usize {
        self.system.dim()
    }

    /// Advances by `h` with the external `wrench` (force, moment about the cabin centre point,
    /// world frame) acting at the end of the step.
    ///
    /// Should Newton fail — an element snapping from slack to taut is an impact — the step is
    /// taken again as two halves (the wrench interpolated linearly from the last one), down to
    /// 1/64 of `h`, before the simulation stops with the reason.
    pub fn step(&mut self, h: f64, wrench: &Vector6<f64>) -> Result<StepStats, DynamicsError> {
        let start = self.state.last_step.map_or(*wrench, |l| l.wrench);
        self.step_split(h, &start, wrench, 0)
    }

    fn step_split(
        &mut self,
        h: f64,
        from: &Vector6<f64>,
        to: &Vector6<f64>,
        depth: u32,
    ) -> Result<StepStats, DynamicsError> {
        match self.step_once(h, to) {
            Err(e) if depth < 6 && e.reason.starts_with("Newton did not converge") => {
                let mid = (from + to) * 0.5;
                let a = self.step_split(0.5 * h, from, &mid, depth + 1)?;
                let b = self.step_split(0.5 * h, &mid, to, depth + 1)?;
                Ok(StepStats {
                    iterations: a.iterations + b.iterations,
                    factorizations: a.factorizations + b.factorizations,
                })
            }
            other => other,
        }
    }

    /// One generalized-α step; on failure `self.state` is as before (only the kept
    /// factorization may have been refreshed).
    fn step_once(&mut self, h: f64, wrench: &Vector6<f64>) -> Result<StepStats, DynamicsError> {
        let t1 = self.state.time + h;
        let fail = |reason: String| DynamicsError { time: t1, reason };
        if !(h > 0.0 && h.is_finite()) {
            return Err(fail(format!("invalid step size {h}")));
        }
        if wrench.iter().any(|w| !w.is_finite()) {
            return Err(fail(format!("the external wrench is not finite: {:?}", wrench.as_slice())));
        }
        let ga = self.coef;
        let (bp, gp) = (ga.beta_prime(h), ga.gamma_prime(h));
        let n = self.dim();
        let fixed = self.system.support == Support::Fixed;
        let st = &self.state;
        // Predictor: constant acceleration. Then a, v and the increment follow from v̇.
        let c_acc = 1.0 / (1.0 - ga.alpha_m);
        for i in 0..n {
            let vd1 = st.acceleration[i];
            let a1 = c_acc
                * ((1.0 - ga.alpha_f) * vd1 + ga.alpha_f * st.acceleration[i] - ga.alpha_m * st.pseudo_acceleration[i]);
            self.acceleration[i] = vd1;
            self.velocity[i] = st.velocity[i] + h * (1.0 - ga.gamma) * st.pseudo_acceleration[i] + h * ga.gamma * a1;
            self.increment[i] =
                h * st.velocity[i] + h * h * (0.5 - ga.beta) * st.pseudo_acceleration[i] + h * h * ga.beta * a1;
        }
        if fixed {
            let c0 = self.system.cabin_offset();
            for i in c0..n {
                self.acceleration[i] = 0.0;
                self.velocity[i] = 0.0;
                self.increment[i] = 0.0;
            }
        }
        self.trial.set_displaced(&st.config, &self.increment);

        let mut stats = StepStats::default();
        let mut previous = f64::INFINITY;
        let mut fresh = false;
        let tol = self.options.newton_tol;
        let mut converged = false;
        let mut previous_residual = f64::INFINITY;
        for it in 0..self.options.newton_max_iter {
            let stale = match &self.state.factor {
                Some((_, fh)) => *fh != h,
                None => true,
            };
            let need_factor = stale || (it > 0 && !fresh && it >= self.options.newton_max_iter / 2);
            if need_factor {
                self.refactor(h, bp, gp, wrench, true).map_err(&fail)?;
                stats.factorizations += 1;
                fresh = true;
            }
            self.system.assemble(&self.trial, &self.velocity, &self.acceleration, wrench, &mut self.residual, None);
            let mut rmax = vec_max_abs(&self.residual);
            // A correction that did not lower the residual has jumped across the tension-only
            // kink of an element (Newton would cycle): take back halves of it until it does.
            let mut backtracks = 0;
            while it > 0 && rmax.is_finite() && rmax >= previous_residual && rmax > 1e-6 && backtracks < 12 {
                backtracks += 1;
                for i in 0..n {
                    let d = 0.5 * self.delta[i];
                    self.delta[i] = d;
                    self.increment[i] -= d;
                    self.acceleration[i] -= bp * d;
                    self.velocity[i] -= gp * d;
                }
                self.trial.set_displaced(&self.state.config, &self.increment);
                self.system.assemble(&self.trial, &self.velocity, &self.acceleration, wrench, &mut self.residual, None);
                rmax = vec_max_abs(&self.residual);
            }
            if !rmax.is_finite() {
                return Err(fail("the residual is not finite (the motion diverged)".into()));
            }
            previous_residual = rmax;
            let (factor, _) = self.state.factor.as_ref().expect("factorized above");
            for (d, r) in self.delta.iter_mut().zip(&self.residual) {
                *d = -*r;
            }
            factor.solve_in_place(&mut self.delta);
            let delta = &self.delta;
            let dmax = vec_max_abs(delta);
            if !dmax.is_finite() {
                return Err(fail("the Newton correction is not finite".into()));
            }
            for i in 0..n {
                self.increment[i] += delta[i];
                self.acceleration[i] += bp * delta[i];
                self.velocity[i] += gp * delta[i];
            }
            self.trial.set_displaced(&self.state.config, &self.increment);
            stats.iterations = it + 1;
            // Converged when the correction is below the tolerance, or when the error it leaves
            // (estimated from a fast contraction ρ as ρ/(1−ρ)·|δ|) is ten times below it.
            let rate = dmax / previous;
            if dmax <= tol || (it > 0 && rate < 0.2 && rate / (1.0 - rate) * dmax <= 0.1 * tol) {
                converged = true;
                break;
            }
            // Slow contraction with an old factorization: refresh it at the current iterate.
            // Still slow with a fresh one: an element sits at its slack limit, where the taut
            // stiffness given to slack elements is a poor guess; from then on use the exact
            // tangent at every iterate (semismooth Newton), so the set of slack elements settles.
            if it > 0 && dmax > 0.25 * previous {
                self.refactor(h, bp, gp, wrench, !fresh).map_err(&fail)?;
                stats.factorizations += 1;
                fresh = true;
            }
            previous = dmax;
        }
        if !converged {
            return Err(fail(format!(
                "Newton did not converge in {} iterations (last correction {previous:.3e}, tolerance {tol:.1e}); reduce the step size or check the input for jumps",
                self.options.newton_max_iter
            )));
        }
        // accept
        let st = &mut self.state;
        for i in 0..n {
            let a1 = c_acc
                * ((1.0 - ga.alpha_f) * self.acceleration[i] + ga.alpha_f * st.acceleration[i]
                    - ga.alpha_m * st.pseudo_acceleration[i]);
            st.pseudo_acceleration[i] = a1;
        }
        st.acceleration.copy_from_slice(&self.acceleration);
        st.velocity.copy_from_slice(&self.velocity);
        std::mem::swap(&mut st.config, &mut self.trial);
        st.time = t1;
        let c0 = self.system.cabin_offset();
        st.last_step = Some(LastStep {
            h,
            wrench: *wrench,
            rotation_increment: Vec3::new(self.increment[c0 + 3], self.increment[c0 + 4], self.increment[c0 + 5]),
        });
        self.sensitivity = None;
        Ok(stats)
    }

    /// Builds and factorizes the iteration matrix at the current iterate.
    /// `slack_as_taut`: see [`Coefficients::slack_as_taut`]; false gives the exact tangent.
    fn refactor(&mut self, h: f64, bp: f64, gp: f64, wrench: &Vector6<f64>, slack_as_taut: bool) -> Result<(), String> {
        let c0 = self.system.cabin_offset();
        let theta = Vec3::new(self.increment[c0 + 3], self.increment[c0 + 4], self.increment[c0 + 5]);
        let coef = Coefficients {
            mass: bp,
            damping: gp,
            stiffness: 1.0,
            rotation_tangent: left_jacobian_so3(&theta),
            slack_as_taut,
        };
        self.system.assemble(
            &self.trial,
            &self.velocity,
            &self.acceleration,
            wrench,
            &mut self.residual,
            Some((&mut self.matrix, coef)),
        );
        let factor = self
            .matrix
            .factorize(self.system.support == Support::Fixed)
            .map_err(|e| format!("iteration matrix: {e}"))?;
        self.state.factor = Some((factor, h));
        Ok(())
    }

    /// How the state reached by the last step would change with the end-of-step wrench:
    /// `δ(motion, tensions) = ∂/∂W · seed`, from the exact iteration matrix at the converged
    /// state (factorized once per step, on the first call). Before any step, the direct
    /// feedthrough: only the accelerations respond, through the mass matrix.
    pub fn wrench_sensitivity(&mut self, seed: &Vector6<f64>) -> Result<CabinDelta, DynamicsError> {
        let c0 = self.system.cabin_offset();
        let fixed = self.system.support == Support::Fixed;
        let fail = |reason: String| DynamicsError { time: self.state.time, reason };
        let st = &self.state;
        let (bp, gp, theta) = match &st.last_step {
            Some(last) => (self.coef.beta_prime(last.h), self.coef.gamma_prime(last.h), last.rotation_increment),
            None => (f64::NAN, f64::NAN, Vec3::zeros()),
        };
        if self.sensitivity.is_none() {
            let (coef, wrench) = match &st.last_step {
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
                &mut self.residual,
                Some((&mut self.matrix, coef)),
            );
            let f = self.matrix.factorize(fixed).map_err(|e| fail(format!("sensitivity matrix: {e}")))?;
            self.sensitivity = Some(f);
        }
        // r contains −W on the cabin rows: S δu = δW there.
        let du = &mut self.residual;
        du.iter_mut().for_each(|x| *x = 0.0);
        du[c0..c0 + 6].copy_from_slice(seed.as_slice());
        self.sensitivity.as_ref().expect("factorized above").solve_in_place(du);
        let v3 = |k: usize| Vec3::new(du[c0 + k], du[c0 + k + 1], du[c0 + k + 2]);
        let cables = self.system.cables();
        if self.state.last_step.is_none() {
            return Ok(CabinDelta {
                position: Vec3::zeros(),
                rotation: Vec3::zeros(),
                velocity: Vec3::zeros(),
                angular_velocity: Vec3::zeros(),
                acceleration: v3(0),
                angular_acceleration: v3(3),
                tensions: vec![(0.0, 0.0); cables],
            });
        }
        let (dr, dth) = (v3(0), v3(3));
        // the rotation coordinate is an increment inside exp(); the world rotation it makes:
        let dphi = left_jacobian_so3(&theta) * dth;
        du[c0 + 3..c0 + 6].copy_from_slice(dphi.as_slice());
        let tensions = self.system.end_tension_sensitivity(&self.state.config, du);
        Ok(CabinDelta {
            position: dr,
            rotation: dphi,
            velocity: dr * gp,
            angular_velocity: dth * gp,
            acceleration: dr * bp,
            angular_acceleration: dth * bp,
            tensions,
        })
    }

    /// The whole state as numbers (bit for bit), for saving and restoring a simulation.
    pub fn encode_state(&self, out: &mut Vec<f64>) {
        let st = &self.state;
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
        match &st.last_step {
            Some(l) => {
                out.push(l.h);
                out.extend_from_slice(l.wrench.as_slice());
                out.extend_from_slice(l.rotation_increment.as_slice());
            }
            None => out.extend_from_slice(&[0.0; 10]),
        }
        match &st.factor {
            Some((f, h)) => {
                out.push(*h);
                f.encode(out);
            }
            None => out.push(0.0),
        }
    }

    /// Restores a state written by [`Dynamics::encode_state`] of the same system, in place.
    pub fn decode_state(&mut self, data: &[f64]) -> Result<(), String> {
        let n = self.dim();
        let nodes = self.state.config.nodes.len();
        let fixed_len = 1 + 3 * nodes + 7 + 3 * n + 10 + 1;
        if data.len() < fixed_len {
            return Err(format!("state has {} numbers, at least {fixed_len} expected", data.len()));
        }
        let h = data[fixed_len - 1];
        let factor_data = &data[fixed_len..];
        if h == 0.0 && !factor_data.is_empty() {
            return Err("state has trailing numbers".into());
        }
        // the factorization first: it is the only part that can still be refused
        if h != 0.0 {
            match &mut self.state.factor {
                Some((f, fh)) => {
                    f.decode_into(factor_data)?;
                    *fh = h;
                }
                None => {
                    let f = ChainFactor::decode(self.system.cables(), self.system.free_nodes(), factor_data)?;
                    self.state.factor = Some((f, h));
                }
            }
        } else {
            self.state.factor = None;
        }
        let st = &mut self.state;
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
        let l = take(10);
        st.last_step = (l[0] != 0.0).then(|| LastStep {
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
        let st = &self.state;
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
        self.system.end_tensions(&self.state.config, out);
    }

    /// Energy, with the gravitational part measured from `reference`.
    pub fn energy(&self, reference: &Config) -> Energy {
        self.system.energy(&self.state.config, &self.state.velocity, reference)
    }
}
