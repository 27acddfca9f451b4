//! Explicit staggering: Jacobi, Gauss–Seidel and the data-flow order; one evaluation per step.

use super::{Core, CouplingScheme, StepReport};
use crate::error::StepError;
use crate::system::{Layout, Units};

/// Every unit steps with the inputs of the last communication point.
pub(super) struct Jacobi;

impl<S: Units> CouplingScheme<S> for Jacobi {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        let mut jacobi = || {
            // With a slope the units extrapolate from the last communication point themselves.
            let slope = core.predict();
            core.keep_history(h);
            for k in 0..core.units.layout().units.len() {
                if core.rates.stepping[k] {
                    core.advance(k, slope, t, h)?;
                }
            }
            core.read_outputs(t + h)?;
            let residual = core.residual(&core.work.guess).0;
            Ok(StepReport { iterations: 1, residual })
        };
        jacobi().map_err(|e| core.unstable(e))
    }
}

/// The units one after the other, each with the newest outputs of those before it.
pub(super) struct GaussSeidel {
    order: Vec<usize>,
    /// A failed step is judged for instability (not in the data-flow order, exact for a system
    /// without feedback).
    judged: bool,
}

impl GaussSeidel {
    /// In the order of the system description, or reversed.
    pub(super) fn listed(layout: &Layout, reversed: bool) -> GaussSeidel {
        let n = layout.units.len();
        let order = if reversed { (0..n).rev().collect() } else { (0..n).collect() };
        GaussSeidel { order, judged: true }
    }

    /// In the order of the data flow: every unit after the ones it takes inputs from (exact for
    /// a system without feedback, e.g. the decoupled model).
    pub(super) fn data_flow(layout: &Layout) -> GaussSeidel {
        GaussSeidel { order: flow_order(layout), judged: false }
    }

    fn step_in_order<S: Units>(&self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        let slope = core.predict();
        core.keep_history(h);
        for &k in &self.order {
            if !core.rates.stepping[k] {
                continue;
            }
            core.advance(k, slope, t, h)?;
            // the inputs this unit stepped with, for the residual (`guess` moves on below)
            let r = core.units.layout().units[k].inputs.clone();
            let Core { work, .. } = core;
            work.x[r.clone()].copy_from_slice(&work.guess[r]);
            // the newest outputs of this unit feed the ones after it
            let o = core.units.layout().units[k].outputs.clone();
            if let Err(e) = core.units.get_outputs(k, &mut core.y[o.clone()]) {
                return Err(core.unit_err(t + h, k, e));
            }
            let Core { units, y, work, rates, .. } = core;
            let l = units.layout();
            for (i, &src) in l.source.iter().enumerate() {
                // a slower unit's outputs reach the others from its communication point on
                if o.contains(&src) && !rates.from_slower[i] {
                    work.guess[i] = l.coupled(i, y); // already an end-of-step value: no extrapolation
                    work.slope[i] = 0.0;
                }
            }
        }
        core.read_outputs(t + h)?;
        let residual = core.residual(&core.work.x).0;
        Ok(StepReport { iterations: 1, residual })
    }
}

impl<S: Units> CouplingScheme<S> for GaussSeidel {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        let result = self.step_in_order(core, t, h);
        if self.judged { result.map_err(|e| core.unstable(e)) } else { result }
    }
}

/// The units ordered so that each comes after those it takes inputs from (Kahn's algorithm;
/// units on a feedback loop keep their listed order).
fn flow_order(l: &Layout) -> Vec<usize> {
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
