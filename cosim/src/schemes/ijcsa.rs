//! Interface-Jacobian co-simulation: Newton on `R(U) = U − C·Y(U)` with the units' step-map
//! Jacobians (derivatives where a unit provides them, central differences with rollback
//! otherwise).

use super::{Coupled, JacobianUpdate, StepReport};
use std::ops::Range;

use crate::error::StepError;
use crate::system::{Layout, Units};

/// The inputs the interface Newton system eliminates first: those of the unit with the most
/// inputs none of which takes one of its own outputs (their block of `C ∂Y/∂U` is then zero,
/// ∂Y/∂U being block diagonal over the units); none if every unit feeds itself.
pub(super) fn eliminated_first(l: &Layout) -> Range<usize> {
    l.units
        .iter()
        .filter(|u| !u.inputs.clone().any(|i| u.outputs.contains(&l.source[i])))
        .max_by_key(|u| u.inputs.len())
        .map_or(0..0, |u| u.inputs.clone())
}

impl<S: Units> Coupled<S> {
    pub(super) fn step_ijcsa(&mut self, t: f64, h: f64) -> Result<StepReport, StepError> {
        self.predict_end(h);
        self.keep_history();
        self.save_states(t)?;
        let mut fresh_jacobian = false;
        let mut last_res = f64::INFINITY;
        for it in 1..=self.options.max_iter {
            if let Some(done) = self.evaluate(it, t, h)? {
                return Ok(done);
            }
            // Jacobian of the step just taken (derivatives at the current inputs)
            let res = self.residual(&self.work.guess).0;
            let slow = res > 0.1 * last_res;
            if !self.has_jacobian
                || self.options.jacobian == JacobianUpdate::EveryStep && it == 1
                || (slow && !fresh_jacobian)
            {
                self.interface_jacobian(t, h)?;
                fresh_jacobian = true;
            }
            last_res = res;
            // Newton: (I − C ∂Y/∂U) ΔU = C Y − U, in place
            let Coupled { work, units, dydu, interface, .. } = self;
            let l = units.layout();
            let n = work.r.len();
            for i in 0..n {
                let (row, from) = (&mut work.newton[i * n..(i + 1) * n], &dydu[l.source[i] * n..(l.source[i] + 1) * n]);
                for (m, d) in row.iter_mut().zip(from) {
                    *m = l.gain[i] * d;
                }
            }
            if !interface.solve(&work.newton, &mut work.r) {
                return Err(self.failed(t + h, "the interface Jacobian is singular"));
            }
            for (g, d) in work.guess.iter_mut().zip(&work.r) {
                *g += d;
            }
        }
        unreachable!("evaluate fails at the iteration limit")
    }

    /// ∂Y/∂U after stepping with `work.guess` (the units' step maps) into `self.dydu`:
    /// derivatives where the unit provides them, central differences with rollback otherwise.
    fn interface_jacobian(&mut self, t: f64, h: f64) -> Result<(), StepError> {
        let nu = self.work.r.len();
        for k in 0..self.units.layout().units.len() {
            let Coupled { units, work, dydu, .. } = self;
            let (ir, or) = (units.layout().units[k].inputs.clone(), units.layout().units[k].outputs.clone());
            let (io, ni, oo, no) = (ir.start, ir.len(), or.start, or.len());
            let (seed, col) = (&mut work.seed[..ni], &mut work.col[..no]);
            let res = (|| {
                if units.capabilities(k).step_derivatives {
                    for c in 0..ni {
                        seed.fill(0.0);
                        seed[c] = 1.0;
                        units.step_derivative(k, seed, col)?;
                        for r in 0..no {
                            dydu[(oo + r) * nu + io + c] = col[r];
                        }
                    }
                    return Ok(());
                }
                // central differences, each from the saved state; the nominal step last
                for c in 0..ni {
                    let delta = 1e-6 * units.layout().scale[io + c];
                    for r in 0..no {
                        dydu[(oo + r) * nu + io + c] = 0.0;
                    }
                    for sign in [1.0, -1.0] {
                        work.end[..ni].copy_from_slice(&work.guess[ir.clone()]);
                        work.end[c] += sign * delta;
                        units.restore_state(k)?;
                        units.set_inputs(k, &work.end[..ni])?;
                        units.do_step(k, t, h)?;
                        units.get_outputs(k, col)?;
                        for r in 0..no {
                            dydu[(oo + r) * nu + io + c] += sign * col[r] / (2.0 * delta);
                        }
                    }
                }
                units.restore_state(k)?;
                units.set_inputs(k, &work.guess[ir.clone()])?;
                units.do_step(k, t, h)
            })();
            if let Err(e) = res {
                return Err(self.unit_err(t + h, k, e));
            }
        }
        self.has_jacobian = true;
        Ok(())
    }
}
