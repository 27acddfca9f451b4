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
}

/// Motion of the cabin centre point (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CabinKinematics {
    pub position: Vec3,
    pub orientation: Quat,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
    pub acceleration: Vec3,
    pub angular_acceleration: Vec3,
}

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
    matrix: ChainMatrix,
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
            matrix,
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
    pub fn step(&mut self, h: f64, wrench: &Vector6<f64>) -> Result<StepStats, DynamicsError> {
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
        for it in 0..self.options.newton_max_iter {
            let stale = match &self.state.factor {
                Some((_, fh)) => *fh != h,
                None => true,
            };
            let need_factor = stale || (it > 0 && !fresh && it >= self.options.newton_max_iter / 2);
            if need_factor {
                self.refactor(h, bp, gp, wrench).map_err(&fail)?;
                stats.factorizations += 1;
                fresh = true;
            }
            self.system.assemble(&self.trial, &self.velocity, &self.acceleration, wrench, &mut self.residual, None);
            let rmax = vec_max_abs(&self.residual);
            if !rmax.is_finite() {
                return Err(fail("the residual is not finite (the motion diverged)".into()));
            }
            let (factor, _) = self.state.factor.as_ref().expect("factorized above");
            for r in self.residual.iter_mut() {
                *r = -*r;
            }
            factor.solve_in_place(&mut self.residual);
            let delta = &self.residual;
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
            if !fresh && it > 0 && dmax > 0.25 * previous {
                self.refactor(h, bp, gp, wrench).map_err(&fail)?;
                stats.factorizations += 1;
                fresh = true;
            }
            previous = dmax;
        }
        if !converged {
            return Err(fail(format!(
                "Newton did not converge in {} iterations (last correction {previous:.3e}, tolerance {tol:.1e});                  reduce the step size or check the input for jumps",
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
        Ok(stats)
    }

    /// Builds and factorizes the iteration matrix at the current iterate.
    fn refactor(&mut self, h: f64, bp: f64, gp: f64, wrench: &Vector6<f64>) -> Result<(), String> {
        let c0 = self.system.cabin_offset();
        let theta = Vec3::new(self.increment[c0 + 3], self.increment[c0 + 4], self.increment[c0 + 5]);
        let coef = Coefficients { mass: bp, damping: gp, stiffness: 1.0, rotation_tangent: left_jacobian_so3(&theta) };
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
