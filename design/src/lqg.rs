//! Sampled-data LQG synthesis: the H2-optimal controller of a continuous plant read by
//! instruments at a fixed rate, some of them every p-th sample (a periodic measurement), whose
//! command is held between samples.
//!
//! The plant's state is `x = (x_c, x_d)`: `x_c` continuous (`ẋ_c = A x_c + B u + ξ`, ξ white of
//! intensity W), `x_d` discrete (memories and delay lines of sampled quantities, random walks:
//! `x_d' = F x_c + E x_d + η`, Cov η = V). At sample k (phase j = k mod p) the instruments read
//! `y = C_j x + v` (Cov v = R_j) and the command `u_k` applies at once, held to the next sample.
//! The cost is the time average of `(x_c, u)ᵀ M (x_c, u)` (M positive semidefinite, its input
//! block definite).
//!
//! Separation: the command is `u = −K x̂⁺` with K the sampled LQR (the cost's integral over a
//! period made a quadratic form of the sample, [`crate::sampled::cost`]) and x̂⁺ the Kalman
//! filter's estimate after the sample's measurements, whose gains repeat with period p. The
//! filter's periodic Riccati equation is solved by lifting one period into a time-invariant
//! system (its measurement noise then correlated with its process noise) and solving that one's
//! DARE ([`crate::riccati::filter_dare`]); the recursion through one period must return to it.

use nalgebra::DMatrix;

use crate::riccati::{self, Dare, RiccatiError};
use crate::sampled;

/// The measurements of one phase: `y = C x + v`, Cov v = R.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub c: DMatrix<f64>,
    pub r: DMatrix<f64>,
}

/// A plant for sampled-data LQG design (see the module's text).
#[derive(Clone, Debug)]
pub struct Plant {
    /// Sample period, s.
    pub period: f64,
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    /// Intensity of the continuous white noise, nc × nc.
    pub w: DMatrix<f64>,
    pub f: DMatrix<f64>,
    pub e: DMatrix<f64>,
    pub v: DMatrix<f64>,
    /// Phase j's measurements; the measurement phases repeat with period `phases.len()`.
    pub phases: Vec<Measurement>,
    /// Weight on (x_c, u), (nc + m) square.
    pub weight: DMatrix<f64>,
}

impl Plant {
    pub fn continuous_states(&self) -> usize {
        self.a.nrows()
    }

    pub fn states(&self) -> usize {
        self.a.nrows() + self.e.nrows()
    }

    pub fn inputs(&self) -> usize {
        self.b.ncols()
    }

    fn check(&self) -> Result<(), SynthesisError> {
        let (nc, nd, m) = (self.a.nrows(), self.e.nrows(), self.b.ncols());
        let n = nc + nd;
        let shapes = [
            ("A", self.a.shape(), (nc, nc)),
            ("B", self.b.shape(), (nc, m)),
            ("W", self.w.shape(), (nc, nc)),
            ("F", self.f.shape(), (nd, nc)),
            ("E", self.e.shape(), (nd, nd)),
            ("V", self.v.shape(), (nd, nd)),
            ("weight", self.weight.shape(), (nc + m, nc + m)),
        ];
        for (name, got, want) in shapes {
            if got != want {
                return Err(SynthesisError::Shape(format!("{name} is {got:?}, not {want:?}")));
            }
        }
        if self.phases.is_empty() {
            return Err(SynthesisError::Shape("no measurement phase".into()));
        }
        for (j, ph) in self.phases.iter().enumerate() {
            let mj = ph.c.nrows();
            if ph.c.ncols() != n || ph.r.shape() != (mj, mj) {
                return Err(SynthesisError::Shape(format!("phase {j}: C {:?}, R {:?}", ph.c.shape(), ph.r.shape())));
            }
        }
        if !(self.period > 0.0 && self.period.is_finite()) {
            return Err(SynthesisError::Shape(format!("sample period {}", self.period)));
        }
        let finite = |m: &DMatrix<f64>| m.iter().all(|x| x.is_finite());
        if ![&self.a, &self.b, &self.w, &self.f, &self.e, &self.v, &self.weight].iter().all(|m| finite(m))
            || !self.phases.iter().all(|p| finite(&p.c) && finite(&p.r))
        {
            return Err(SynthesisError::Shape("a matrix holds a number that is not finite".into()));
        }
        Ok(())
    }

    /// The plant sampled: the whole state's transition and input matrices and process noise.
    pub fn sampled(&self) -> Sampled {
        let (nc, nd, m) = (self.a.nrows(), self.e.nrows(), self.b.ncols());
        let n = nc + nd;
        let (ad, bd) = sampled::hold(&self.a, &self.b, self.period);
        let qc = sampled::noise(&self.a, &self.w, self.period);
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (nc, nc)).copy_from(&ad);
        a.view_mut((nc, 0), (nd, nc)).copy_from(&self.f);
        a.view_mut((nc, nc), (nd, nd)).copy_from(&self.e);
        let mut b = DMatrix::zeros(n, m);
        b.view_mut((0, 0), (nc, m)).copy_from(&bd);
        let mut q = DMatrix::zeros(n, n);
        q.view_mut((0, 0), (nc, nc)).copy_from(&qc);
        q.view_mut((nc, nc), (nd, nd)).copy_from(&self.v);
        Sampled { a, b, q, continuous: (ad, bd) }
    }
}

/// The plant at its samples.
#[derive(Clone, Debug)]
pub struct Sampled {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    /// Covariance of the process noise over one period.
    pub q: DMatrix<f64>,
    /// The continuous part's own (transition, input) matrices.
    pub continuous: (DMatrix<f64>, DMatrix<f64>),
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SynthesisError {
    #[error("the plant: {0}")]
    Shape(String),
    #[error("the regulator's Riccati equation: {0}")]
    Regulator(RiccatiError),
    #[error("the Kalman filter's Riccati equation: {0}")]
    Filter(RiccatiError),
    #[error("the Kalman filter's covariance does not return to itself over one period (relative gap {gap:.2e})")]
    Periodicity { gap: f64 },
    #[error("the closed loop: {0}")]
    ClosedLoop(String),
}

/// The controller: `x̂⁻ ← A x̂⁺ + B u` between samples; at phase j
/// `x̂⁺ = x̂⁻ + L_j (y − C_j x̂⁻)`, `u = −K x̂⁺`.
#[derive(Clone, Debug, PartialEq)]
pub struct Controller {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub k: DMatrix<f64>,
    /// Per phase: (C_j, L_j).
    pub phases: Vec<(DMatrix<f64>, DMatrix<f64>)>,
}

/// What a synthesis found: the controller and how well its equations were solved.
#[derive(Clone, Debug)]
pub struct Synthesis {
    pub controller: Controller,
    pub regulator: Dare,
    /// The lifted filter equation's solution (prior covariance at phase 0).
    pub filter: Dare,
    /// Prior covariance at each phase.
    pub priors: Vec<DMatrix<f64>>,
    /// Relative gap of the filter's covariance after one period of its recursion.
    pub periodicity_gap: f64,
    pub sampled: Sampled,
    /// The sampled cost's weights (Q, N, R) on (x_c, u).
    pub cost: (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>),
}

/// The steady-state periodic Kalman filter: prior covariances per phase, the lifted DARE.
fn periodic_filter(s: &Sampled, phases: &[Measurement]) -> Result<(Dare, Vec<DMatrix<f64>>, f64), SynthesisError> {
    let (a, q) = (&s.a, &s.q);
    let n = a.nrows();
    let p = phases.len();
    // powers of A
    let mut powers = vec![DMatrix::identity(n, n)];
    for j in 1..=p {
        powers.push(a * &powers[j - 1]);
    }
    let rows: Vec<usize> = phases.iter().map(|ph| ph.c.nrows()).collect();
    let offset: Vec<usize> = rows.iter().scan(0, |acc, r| Some(std::mem::replace(acc, *acc + r))).collect();
    let total: usize = rows.iter().sum();
    // X' = Aᵖ X + W̃, W̃ = Σ_i A^{p−1−i} w_i; Y_j = C_j A^j X + C_j Σ_{i<j} A^{j−1−i} w_i + v_j
    let lifted_a = powers[p].clone();
    let mut lifted_c = DMatrix::zeros(total, n);
    for j in 0..p {
        lifted_c.view_mut((offset[j], 0), (rows[j], n)).copy_from(&(&phases[j].c * &powers[j]));
    }
    let mut lifted_q = DMatrix::zeros(n, n);
    for i in 0..p {
        lifted_q += &powers[p - 1 - i] * q * powers[p - 1 - i].transpose();
    }
    let mut lifted_r = DMatrix::zeros(total, total);
    let mut lifted_s = DMatrix::zeros(n, total);
    for j in 0..p {
        lifted_r.view_mut((offset[j], offset[j]), (rows[j], rows[j])).copy_from(&phases[j].r);
        for k in 0..p {
            // Σ_{i < min(j,k)} C_j A^{j−1−i} Q A^{k−1−i}ᵀ C_kᵀ
            let mut block = DMatrix::zeros(rows[j], rows[k]);
            for i in 0..j.min(k) {
                block +=
                    &phases[j].c * &powers[j - 1 - i] * q * powers[k - 1 - i].transpose() * phases[k].c.transpose();
            }
            let mut view = lifted_r.view_mut((offset[j], offset[k]), (rows[j], rows[k]));
            view += block;
        }
        let mut cross = DMatrix::zeros(n, rows[j]);
        for i in 0..j {
            cross += &powers[p - 1 - i] * q * powers[j - 1 - i].transpose() * phases[j].c.transpose();
        }
        lifted_s.view_mut((0, offset[j]), (n, rows[j])).copy_from(&cross);
    }
    sampled::symmetrize(&mut lifted_r);
    let lifted =
        riccati::filter_dare(&lifted_a, &lifted_c, &lifted_q, &lifted_r, &lifted_s).map_err(SynthesisError::Filter)?;
    // the recursion through one period, from the lifted prior
    let mut priors = Vec::with_capacity(p);
    let mut prior = lifted.x.clone();
    for ph in phases {
        priors.push(prior.clone());
        let posterior = update(&prior, ph).map_err(SynthesisError::Filter)?.1;
        prior = a * posterior * a.transpose() + q;
        sampled::symmetrize(&mut prior);
    }
    let gap = (&prior - &priors[0]).norm() / priors[0].norm().max(f64::MIN_POSITIVE);
    Ok((lifted, priors, gap))
}

/// The measurement update of a prior covariance: (gain L, posterior covariance), Joseph form.
fn update(prior: &DMatrix<f64>, ph: &Measurement) -> Result<(DMatrix<f64>, DMatrix<f64>), RiccatiError> {
    let n = prior.nrows();
    let s = &ph.c * prior * ph.c.transpose() + &ph.r;
    let chol = s.cholesky().ok_or(RiccatiError::NotPositive { what: "measurement noise" })?;
    let gain = chol.solve(&(&ph.c * prior)).transpose();
    let ikc = DMatrix::identity(n, n) - &gain * &ph.c;
    let mut post = &ikc * prior * ikc.transpose() + &gain * &ph.r * gain.transpose();
    sampled::symmetrize(&mut post);
    Ok((gain, post))
}

/// Largest relative gap of the filter's covariance after one period.
pub const PERIODICITY_BOUND: f64 = 1e-8;

/// The LQG controller of a plant.
pub fn synthesize(plant: &Plant) -> Result<Synthesis, SynthesisError> {
    plant.check()?;
    let (nc, nd, m) = (plant.a.nrows(), plant.e.nrows(), plant.b.ncols());
    let s = plant.sampled();
    let (qd, nd_cross, rd) = sampled::cost(&plant.a, &plant.b, &plant.weight, plant.period);
    let (ad, bd) = &s.continuous;
    let regulator = riccati::dare(ad, bd, &qd, &rd, &nd_cross).map_err(SynthesisError::Regulator)?;
    let (filter, priors, gap) = periodic_filter(&s, &plant.phases)?;
    if !(gap <= PERIODICITY_BOUND) {
        return Err(SynthesisError::Periodicity { gap });
    }
    let mut k = DMatrix::zeros(m, nc + nd);
    k.view_mut((0, 0), (m, nc)).copy_from(&regulator.gain);
    let phases = priors
        .iter()
        .zip(&plant.phases)
        .map(|(prior, ph)| Ok((ph.c.clone(), update(prior, ph).map_err(SynthesisError::Filter)?.0)))
        .collect::<Result<Vec<_>, SynthesisError>>()?;
    Ok(Synthesis {
        controller: Controller { a: s.a.clone(), b: s.b.clone(), k, phases },
        regulator,
        filter,
        priors,
        periodicity_gap: gap,
        sampled: s,
        cost: (qd, nd_cross, rd),
    })
}

/// The controller's state: the filter's prior and posterior estimates and the command in force.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ControllerState {
    prior: Vec<f64>,
    posterior: Vec<f64>,
    command: Vec<f64>,
    /// Whether a sample has been taken (the first has no prediction before it).
    started: bool,
}

impl ControllerState {
    /// Copies `source` into this state's storage (no allocation once sized).
    pub fn copy_from(&mut self, source: &ControllerState) {
        self.prior.clone_from(&source.prior);
        self.posterior.clone_from(&source.posterior);
        self.command.clone_from(&source.command);
        self.started = source.started;
    }

    /// The command in force.
    pub fn command(&self) -> &[f64] {
        &self.command
    }

    /// The estimate after the last sample.
    pub fn estimate(&self) -> &[f64] {
        &self.posterior
    }
}

/// `out = m · x` (column-major `m`), without allocating.
fn multiply_into(out: &mut [f64], m: &DMatrix<f64>, x: &[f64], accumulate: bool) {
    let (rows, cols) = m.shape();
    if !accumulate {
        out[..rows].fill(0.0);
    }
    for (j, xj) in x.iter().enumerate().take(cols) {
        if *xj != 0.0 {
            let col = &m.as_slice()[j * rows..(j + 1) * rows];
            for (o, c) in out.iter_mut().zip(col) {
                *o += c * xj;
            }
        }
    }
}

impl Controller {
    pub fn states(&self) -> usize {
        self.a.nrows()
    }

    pub fn inputs(&self) -> usize {
        self.b.ncols()
    }

    /// The measurement count of phase j.
    pub fn measurements(&self, phase: usize) -> usize {
        self.phases[phase].0.nrows()
    }

    /// The state at rest (every deviation zero).
    pub fn start(&self) -> ControllerState {
        let n = self.states();
        ControllerState {
            prior: vec![0.0; n],
            posterior: vec![0.0; n],
            command: vec![0.0; self.inputs()],
            started: false,
        }
    }

    /// One sample at phase `phase` with the measurements `y`: the filter predicts from the last
    /// sample with the command then in force, corrects, and the new command is returned. Only the
    /// first `present` of the phase's measurements were taken (a fix late or not yet come): the
    /// others count as read exactly as predicted. Allocates nothing.
    pub fn step<'s>(&self, state: &'s mut ControllerState, phase: usize, y: &[f64], present: usize) -> &'s [f64] {
        let (c, l) = &self.phases[phase];
        if state.started {
            multiply_into(&mut state.prior, &self.a, &state.posterior, false);
            multiply_into(&mut state.prior, &self.b, &state.command, true);
        }
        state.started = true;
        // innovation y − C x̂⁻ (at most a few dozen measurements: on the stack)
        let mut innovation = [0.0; MAX_MEASUREMENTS];
        let (rows, taken) = (c.nrows(), present.min(c.nrows()));
        innovation[..taken].copy_from_slice(&y[..taken]);
        for (j, xj) in state.prior.iter().enumerate() {
            if *xj != 0.0 {
                for (i, v) in innovation[..taken].iter_mut().enumerate() {
                    *v -= c[(i, j)] * xj;
                }
            }
        }
        state.posterior.copy_from_slice(&state.prior);
        multiply_into(&mut state.posterior, l, &innovation[..rows], true);
        multiply_into(&mut state.command, &self.k, &state.posterior, false);
        for u in state.command.iter_mut() {
            *u = -*u;
        }
        &state.command
    }
}

/// Most measurements one phase may have.
pub const MAX_MEASUREMENTS: usize = 64;
