//! The closed loop of a plant and its LQG controller: its stationary (periodic) covariance, and
//! the time average of any output's mean square between the samples too — what a long run of the
//! linear closed loop would measure.
//!
//! The loop's state at a sample is the plant's continuous part and the filter's error
//! `ζ = (x_c, e = x − x̂⁻)`; over one step at phase j it moves as `ζ' = Ā_j ζ + B̄_j (w, v)`. (The
//! discrete part of the plant — memories, delay lines, random-walk biases — acts on nothing but
//! the readings, through the error; a bias itself has no stationary covariance, its error has.) Lifted over a period, the covariance at
//! phase 0 solves a discrete Lyapunov equation; the other phases follow by the recursion. Between
//! samples an output `z = H x_c + D u` moves with the continuous plant and the held command, plus
//! the noise of that part of the step; its mean square is integrated over the step by Simpson's
//! rule on [`SUBSTEPS`] intervals (error of order (T/8)⁴ against the plant's fastest time scale
//! to the fourth: below 1e-6 for T = 10 ms and dynamics below 10 Hz).

use nalgebra::DMatrix;

use crate::lqg::{Plant, Synthesis};
use crate::sampled;

/// Simpson intervals per sample period.
pub const SUBSTEPS: usize = 8;

/// The closed loop's periodic stationary covariance and what the outputs need between samples.
#[derive(Clone, Debug)]
pub struct ClosedLoop {
    /// Per phase: Cov of (x_c, u) at the sample.
    sample_cov: Vec<DMatrix<f64>>,
    /// Per Simpson point s_i: (e^{A s}, ∫₀ˢ e^{Aσ}dσ B, the noise covariance added by s).
    points: Vec<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)>,
    nc: usize,
}

impl ClosedLoop {
    /// The loop of `plant` with `syn`'s controller.
    pub fn new(plant: &Plant, syn: &Synthesis) -> Result<ClosedLoop, sampled::LyapunovError> {
        let ctl = &syn.controller;
        let (n, m, nc) = (plant.states(), plant.inputs(), plant.continuous_states());
        let (a, q) = (&syn.sampled.a, &syn.sampled.q);
        let (ad, bd) = &syn.sampled.continuous;
        let kc = ctl.k.columns(0, nc).into_owned();
        let eye = DMatrix::<f64>::identity(n, n);
        let size = nc + n;
        let mut steps = Vec::new();
        for (j, (c, l)) in ctl.phases.iter().enumerate() {
            let r = &plant.phases[j].r;
            let mj = c.nrows();
            // e⁺ = (I − LC) e − L v; u = −K_c x_c + K (I − LC) e − K L v
            let ilc = &eye - l * c;
            let k_ilc = &ctl.k * &ilc;
            let kl = &ctl.k * l;
            let mut abar = DMatrix::zeros(size, size);
            abar.view_mut((0, 0), (nc, nc)).copy_from(&(ad - bd * &kc));
            abar.view_mut((0, nc), (nc, n)).copy_from(&(bd * &k_ilc));
            abar.view_mut((nc, nc), (n, n)).copy_from(&(a * &ilc));
            let mut bbar = DMatrix::zeros(size, n + mj);
            bbar.view_mut((0, 0), (nc, nc)).copy_from(&DMatrix::identity(nc, nc));
            bbar.view_mut((0, n), (nc, mj)).copy_from(&(-(bd * &kl)));
            bbar.view_mut((nc, 0), (n, n)).copy_from(&eye);
            bbar.view_mut((nc, n), (n, mj)).copy_from(&(-(a * l)));
            let mut noise = DMatrix::zeros(n + mj, n + mj);
            noise.view_mut((0, 0), (n, n)).copy_from(q);
            noise.view_mut((n, n), (mj, mj)).copy_from(r);
            // (x_c, u) at the sample
            let mut mmap = DMatrix::zeros(nc + m, size);
            mmap.view_mut((0, 0), (nc, nc)).copy_from(&DMatrix::identity(nc, nc));
            mmap.view_mut((nc, 0), (m, nc)).copy_from(&(-&kc));
            mmap.view_mut((nc, nc), (m, n)).copy_from(&k_ilc);
            let nmap = -kl;
            steps.push((abar, &bbar * &noise * bbar.transpose(), mmap, nmap, r.clone()));
        }
        // lifted over one period from phase 0
        let p = steps.len();
        let mut phi = DMatrix::identity(size, size);
        let mut acc = DMatrix::zeros(size, size);
        for (abar, qbar, ..) in &steps {
            acc = abar * &acc * abar.transpose() + qbar;
            phi = abar * &phi;
        }
        let mut cov = sampled::lyapunov(&phi, &acc)?;
        let mut sample_cov = Vec::with_capacity(p);
        for (abar, qbar, mmap, nmap, r) in &steps {
            let mut s = mmap * &cov * mmap.transpose();
            let mut view = s.view_mut((nc, nc), (m, m));
            view += nmap * r * nmap.transpose();
            sampled::symmetrize(&mut s);
            sample_cov.push(s);
            cov = abar * &cov * abar.transpose() + qbar;
            sampled::symmetrize(&mut cov);
        }
        let points = (0..=SUBSTEPS)
            .map(|i| {
                let s = plant.period * i as f64 / SUBSTEPS as f64;
                let (e, g) = sampled::hold(&plant.a, &plant.b, s);
                (e, g, sampled::noise(&plant.a, &plant.w, s))
            })
            .collect();
        Ok(ClosedLoop { sample_cov, points, nc })
    }

    /// The time average of E[zᵀz] for `z = H x_c + D u`.
    pub fn mean_square(&self, h: &DMatrix<f64>, d: &DMatrix<f64>) -> f64 {
        self.component_mean_squares(h, d).iter().sum()
    }

    /// The time average of E[z_i²] for each component of `z = H x_c + D u`.
    pub fn component_mean_squares(&self, h: &DMatrix<f64>, d: &DMatrix<f64>) -> Vec<f64> {
        let rows = h.nrows();
        let mut total = vec![0.0; rows];
        let (nc, m) = (self.nc, d.ncols());
        for (i, (e, g, qn)) in self.points.iter().enumerate() {
            let weight = if i == 0 || i == SUBSTEPS {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            } / (3.0 * SUBSTEPS as f64);
            let mut z = DMatrix::zeros(rows, nc + m);
            z.view_mut((0, 0), (rows, nc)).copy_from(&(h * e));
            z.view_mut((0, nc), (rows, m)).copy_from(&(h * g + d));
            let noise = h * qn * h.transpose();
            for cov in &self.sample_cov {
                let zc = &z * cov * z.transpose();
                for r in 0..rows {
                    total[r] += weight * (zc[(r, r)] + noise[(r, r)]) / self.sample_cov.len() as f64;
                }
            }
        }
        total
    }
}
