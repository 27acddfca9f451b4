//! A run of the linear closed loop with seeded Gaussian noise: the plant stepped exactly at a
//! fraction of the sample period (the continuous noise drawn with its covariance over that
//! substep), the controller at every sample, outputs recorded at every substep. What the
//! predicted mean squares ([`crate::h2`]) are checked against.

use feedcore::random::SplitMix64;
use nalgebra::{DMatrix, DVector};

use crate::lqg::{Plant, Synthesis};
use crate::sampled;

/// A recorded run: each output's mean square over batches of equal length (their spread gives
/// the estimate's standard error).
#[derive(Clone, Debug)]
pub struct Run {
    /// Per batch, per output: the mean of zᵀz.
    pub batches: Vec<Vec<f64>>,
}

impl Run {
    /// Output `i`'s mean square over the run and the standard error of that mean (batch means).
    pub fn mean_square(&self, i: usize) -> (f64, f64) {
        let n = self.batches.len() as f64;
        let values: Vec<f64> = self.batches.iter().map(|b| b[i]).collect();
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    }
}

/// Factor of a covariance for drawing: Cholesky where definite, else through its eigenvalues
/// (negative round-off clipped).
fn factor(cov: &DMatrix<f64>) -> DMatrix<f64> {
    if let Some(c) = cov.clone().cholesky() {
        return c.l();
    }
    let e = cov.clone().symmetric_eigen();
    let mut f = e.eigenvectors.clone();
    for (j, v) in e.eigenvalues.iter().enumerate() {
        let s = v.max(0.0).sqrt();
        f.column_mut(j).scale_mut(s);
    }
    f
}

/// How long and how finely a run goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Length {
    /// Plant steps per sample period.
    pub substeps: usize,
    /// Sample periods run before the recording starts, and recorded.
    pub warmup: usize,
    pub samples: usize,
    /// Batches the recorded samples are split into (for the standard error).
    pub batches: usize,
    pub seed: u64,
}

/// Runs `syn`'s controller on `plant`; `outputs` are (H, D) pairs on (x_c, u).
pub fn run(plant: &Plant, syn: &Synthesis, outputs: &[(DMatrix<f64>, DMatrix<f64>)], length: Length) -> Run {
    let Length { substeps, warmup, samples, batches, seed } = length;
    let (nc, nd, m) = (plant.continuous_states(), plant.e.nrows(), plant.inputs());
    let h = plant.period / substeps as f64;
    let (e_h, g_h) = sampled::hold(&plant.a, &plant.b, h);
    let noise_h = factor(&sampled::noise(&plant.a, &plant.w, h));
    let noise_d = factor(&plant.v);
    let noise_y: Vec<DMatrix<f64>> = plant.phases.iter().map(|p| factor(&p.r)).collect();
    let mut rng = SplitMix64::new(seed);
    let mut normal = |k: usize| DVector::from_fn(k, |_, _| rng.normal());
    let (mut xc, mut xd) = (DVector::zeros(nc), DVector::zeros(nd));
    let ctl = &syn.controller;
    let mut state = ctl.start();
    let per_batch = samples / batches;
    let mut out = Run { batches: vec![vec![0.0; outputs.len()]; batches] };
    let p = plant.phases.len();
    for k in 0..warmup + per_batch * batches {
        let phase = k % p;
        let mut x = DVector::zeros(nc + nd);
        x.rows_mut(0, nc).copy_from(&xc);
        x.rows_mut(nc, nd).copy_from(&xd);
        let y = &plant.phases[phase].c * &x + &noise_y[phase] * normal(plant.phases[phase].c.nrows());
        let u = DVector::from_column_slice(ctl.step(&mut state, phase, y.as_slice(), y.len()));
        // the discrete part moves with the sample it remembers
        xd = &plant.f * &xc + &plant.e * &xd + &noise_d * normal(nd);
        for _ in 0..substeps {
            if k >= warmup {
                let batch = (k - warmup) / per_batch;
                for (i, (hh, dd)) in outputs.iter().enumerate() {
                    let z = hh * &xc + dd * &u;
                    out.batches[batch][i] += z.norm_squared() / (per_batch * substeps) as f64;
                }
            }
            xc = &e_h * &xc + &g_h * &u + &noise_h * normal(nc);
        }
        debug_assert_eq!(u.len(), m);
    }
    out
}
