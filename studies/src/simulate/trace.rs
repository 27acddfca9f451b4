//! What a run records: the sampled time histories and the summary of every step.

use std::io::Write;

use feedcore::scene::Quantity;

use crate::feed::FeedTrace;

/// Figures of a whole run, taken at every step (not from the samples).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    /// Largest |displacement| of the cabin centre per world axis, mm.
    pub max_abs_disp_mm: [f64; 3],
    /// Largest distance of the cabin centre from its static position, mm, and when.
    pub peak_mm: f64,
    pub peak_time_s: f64,
    /// Steps taken and iterations (system evaluations, or Newton iterations) over all of them.
    pub steps: u64,
    pub iterations: u64,
    /// Largest scaled interface residual at the end of a step (co-simulation).
    pub max_interface_residual: f64,
    /// Largest position-constraint residual (monolithic), m.
    pub max_constraint_residual_m: f64,
    /// Tries of the adaptive step rejected (and rolled back), and the smallest and largest
    /// step taken (the fixed step otherwise), s.
    pub rejected_steps: u64,
    pub h_min_used: f64,
    pub h_max_used: f64,
}

/// Time histories of one run, sampled at the scene's output interval (an adaptive run: at every
/// accepted step), and its summary.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub method: String,
    /// The fixed step, s (0 for an adaptive run: see `h`).
    pub dt: f64,
    pub t_end: f64,
    pub steps: u64,
    /// Interval of the samples actually taken (a whole number of steps), s; 0 for an adaptive
    /// run.
    pub sample_interval_s: f64,
    pub t: Vec<f64>,
    /// An adaptive run: the step that ended at each sample (0 for the start); empty otherwise.
    pub h: Vec<f64>,
    /// Cabin-centre displacement from the static equilibrium, mm (world x, y, z).
    pub disp_mm: Vec<[f64; 3]>,
    /// Cabin rotation from the static orientation, world rotation vector, mrad.
    pub rot_mrad: Vec<[f64; 3]>,
    /// What the Stewart platform exerts on the cabin (force N; moment about the centre point
    /// N·m); zero unless the scene asks for the wrench or the method prescribes it.
    pub wrench: Vec<[f64; 6]>,
    /// The feed, legs and limits (scenes with `[control]`).
    pub feed: Option<FeedTrace>,
    pub summary: Summary,
    pub wall_time_s: f64,
}

impl Trace {
    pub fn max_abs_disp_mm(&self) -> [f64; 3] {
        self.summary.max_abs_disp_mm
    }

    /// Largest distance of the cabin centre from its static position over every step, mm.
    pub fn peak_mm(&self) -> f64 {
        self.summary.peak_mm
    }

    pub fn mean_iterations(&self) -> f64 {
        if self.summary.steps == 0 { 0.0 } else { self.summary.iterations as f64 / self.summary.steps as f64 }
    }

    pub fn max_residual(&self) -> f64 {
        self.summary.max_interface_residual
    }

    pub fn constraint_residual(&self) -> f64 {
        self.summary.max_constraint_residual_m
    }

    /// Whether the steps were chosen by the adaptive step.
    pub fn is_adaptive(&self) -> bool {
        !self.h.is_empty()
    }

    /// Largest and RMS distance (mm) of the cabin centre from another run's at this run's
    /// sample times within the other's span (the other run interpolated linearly between its
    /// samples: sample it at least as finely).
    pub fn error_against(&self, reference: &Trace) -> (f64, f64) {
        let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
        let mut j = 0;
        for i in 0..self.t.len() {
            let t = self.t[i];
            while j + 1 < reference.t.len() && reference.t[j + 1] <= t + 1e-9 {
                j += 1;
            }
            if reference.t.is_empty() || t > reference.t[reference.t.len() - 1] + 1e-9 {
                break;
            }
            let r = if (reference.t[j] - t).abs() <= 1e-9 || j + 1 == reference.t.len() {
                reference.disp_mm[j]
            } else {
                let w = (t - reference.t[j]) / (reference.t[j + 1] - reference.t[j]);
                let (a, b) = (reference.disp_mm[j], reference.disp_mm[j + 1]);
                [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])]
            };
            let d: f64 = (0..3).map(|k| (self.disp_mm[i][k] - r[k]).powi(2)).sum::<f64>().sqrt();
            max = max.max(d);
            sum += d * d;
            n += 1;
        }
        (max, (sum / n.max(1) as f64).sqrt())
    }

    /// Writes the time histories the scene asks for (`outputs.quantities`): `t` (and `h_s`, the
    /// step that ended there, in an adaptive run), then `dx_mm, dy_mm, dz_mm` (cabin
    /// displacement), `rx_mrad, ry_mrad, rz_mrad` (rotation), `fx_n … mz_nm` (Stewart wrench),
    /// each group only if asked for.
    pub fn write_csv(&self, out: &mut dyn Write, quantities: &[Quantity]) -> std::io::Result<()> {
        type Column<'a> = &'a dyn Fn(usize) -> &'a [f64];
        let groups: [(Quantity, &str, Column); 3] = [
            (Quantity::CabinDisplacement, "dx_mm,dy_mm,dz_mm", &|i| &self.disp_mm[i]),
            (Quantity::CabinRotation, "rx_mrad,ry_mrad,rz_mrad", &|i| &self.rot_mrad[i]),
            (Quantity::Wrench, "fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm", &|i| &self.wrench[i]),
        ];
        let chosen: Vec<_> = groups.iter().filter(|g| quantities.contains(&g.0)).collect();
        let mut f = std::io::BufWriter::new(out);
        write!(f, "t")?;
        if self.is_adaptive() {
            write!(f, ",h_s")?;
        }
        for g in &chosen {
            write!(f, ",{}", g.1)?;
        }
        if let Some(feed) = &self.feed {
            write!(f, ",{}", feed.csv_header())?;
        }
        writeln!(f)?;
        for i in 0..self.t.len() {
            write!(f, "{}", self.t[i])?;
            if self.is_adaptive() {
                write!(f, ",{}", self.h[i])?;
            }
            for g in &chosen {
                for x in (g.2)(i) {
                    write!(f, ",{x:e}")?;
                }
            }
            if let Some(feed) = &self.feed {
                feed.write_row(&mut f, i)?;
            }
            writeln!(f)?;
        }
        f.flush()
    }
}
