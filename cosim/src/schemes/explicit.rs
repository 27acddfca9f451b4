//! Explicit staggering: Jacobi, Gauss–Seidel and the data-flow order; one evaluation per step.

use super::{Coupled, StepReport};
use crate::error::StepError;
use crate::system::Units;

impl<S: Units> Coupled<S> {
    pub(super) fn step_jacobi(&mut self, t: f64, h: f64) -> Result<StepReport, StepError> {
        // With a slope the units extrapolate from the last communication point themselves.
        let slope = self.predict();
        self.keep_history(h);
        for k in 0..self.units.layout().units.len() {
            self.advance(k, slope, t, h)?;
        }
        self.finish_step(t + h)
    }

    pub(super) fn step_gauss_seidel(&mut self, t: f64, h: f64) -> Result<StepReport, StepError> {
        let slope = self.predict();
        self.keep_history(h);
        for step in 0..self.order.len() {
            let k = self.order[step];
            self.advance(k, slope, t, h)?;
            // the inputs this unit stepped with, for the residual (`guess` moves on below)
            let r = self.units.layout().units[k].inputs.clone();
            let Coupled { work, .. } = self;
            work.x[r.clone()].copy_from_slice(&work.guess[r]);
            // the newest outputs of this unit feed the ones after it
            let o = self.units.layout().units[k].outputs.clone();
            if let Err(e) = self.units.get_outputs(k, &mut self.y[o.clone()]) {
                return Err(self.unit_err(t + h, k, e));
            }
            let Coupled { units, y, work, .. } = self;
            let l = units.layout();
            for (i, &src) in l.source.iter().enumerate() {
                if o.contains(&src) {
                    work.guess[i] = l.coupled(i, y); // already an end-of-step value: no extrapolation
                    work.slope[i] = 0.0;
                }
            }
        }
        self.read_outputs(t + h)?;
        let residual = self.residual(&self.work.x).0;
        Ok(StepReport { iterations: 1, residual })
    }

    /// After the units stepped with (end-of-step) inputs `work.guess`: new outputs and residual.
    fn finish_step(&mut self, t1: f64) -> Result<StepReport, StepError> {
        self.read_outputs(t1)?;
        let residual = self.residual(&self.work.guess).0;
        Ok(StepReport { iterations: 1, residual })
    }

    /// The units ordered so that each comes after those it takes inputs from (Kahn's algorithm;
    /// units on a feedback loop keep their listed order).
    pub(super) fn flow_order(&self) -> Vec<usize> {
        let l = self.units.layout();
        let n = l.units.len();
        let feeds = |k: usize| -> Vec<usize> {
            l.units[k].inputs.clone().filter_map(|i| l.owner_of_output(l.source[i])).filter(|&j| j != k).collect()
        };
        let mut order = Vec::with_capacity(n);
        while order.len() < n {
            let next = (0..n)
                .filter(|k| !order.contains(k))
                .find(|&k| feeds(k).iter().all(|j| order.contains(j)))
                .or_else(|| (0..n).find(|k| !order.contains(k)));
            order.push(next.expect("a unit is left"));
        }
        order
    }
}
