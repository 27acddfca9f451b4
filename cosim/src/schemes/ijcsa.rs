//! Interface-Jacobian co-simulation: Newton on `R(U) = U − C·Y(U)` with the units' step-map
//! Jacobians (derivatives where a unit provides them, central differences with rollback
//! otherwise).

use std::ops::Range;

use super::{Core, CouplingScheme, JacobianUpdate, StepReport};
use crate::dense::IdentityMinus;
use crate::error::StepError;
use crate::system::{Layout, Slot, Units};

/// A reused (secant-updated) block of ∂Y/∂U whose prediction of a step's correction misses by
/// more than this fraction of it (and by more than the tolerance) is recomputed at the first
/// iteration of the next [`VOLATILE_STEPS`] steps. At LT50m C (h = 0.01, linear
/// extrapolation) the cable FMU's block misses by 1e-5–1e-4, the Stewart FMU's, which follows
/// the prescribed platform motion, by 2e-3–1e-2; the interface Newton needs about 3e-3
/// (tolerance 1e-8 against a first residual of 4e-6).
const STALE: f64 = 1e-3;

/// How many steps a unit found stale has its block recomputed before it is tried again.
const VOLATILE_STEPS: u32 = 100;

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

/// The interface Jacobian ∂Y/∂U and what decides when it is recomputed.
#[derive(Clone, Debug, Default)]
struct Jacobian {
    /// Block diagonal over the units, row-major ny × nu.
    dydu: Vec<f64>,
    /// The macro step whose step maps `dydu` differentiates, once there is one.
    step: Option<f64>,
    /// Per unit, the steps its block is still recomputed at every first iteration after it was
    /// found stale (`reuse`).
    volatile: Vec<u32>,
}

pub(super) struct Ijcsa {
    update: JacobianUpdate,
    jacobian: Jacobian,
    /// A reused Jacobian as it was before the last step and at the checkpoint.
    before_step: Jacobian,
    checkpoint: Jacobian,
    /// The interface Newton system's solver (a unit's inputs eliminated first where it can).
    interface: IdentityMinus,
    /// The last iterate and its outputs (the secant of a reused Jacobian).
    u_it: Vec<f64>,
    y_it: Vec<f64>,
}

impl Ijcsa {
    pub(super) fn new(layout: &Layout, update: JacobianUpdate) -> Ijcsa {
        let (nu, ny) = (layout.inputs(), layout.outputs());
        Ijcsa {
            update,
            jacobian: Jacobian { dydu: vec![0.0; ny * nu], step: None, volatile: vec![0; layout.units.len()] },
            before_step: Jacobian::default(),
            checkpoint: Jacobian::default(),
            interface: IdentityMinus::new(nu, eliminated_first(layout)),
            u_it: vec![0.0; nu],
            y_it: vec![0.0; ny],
        }
    }
}

impl<S: Units> CouplingScheme<S> for Ijcsa {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        core.predict_end(h);
        core.keep_history(h);
        core.save_states(t)?;
        let mut fresh_jacobian = false;
        let mut last_res = f64::INFINITY;
        let reuse = self.update == JacobianUpdate::Reuse;
        for it in 1..=core.options.max_iter {
            if let Some(done) = core.evaluate(it, t, h)? {
                return Ok(done);
            }
            if reuse && it > 1 {
                self.secant_update(core);
            }
            // Jacobian of the step just taken (derivatives at the current inputs)
            let res = core.residual(&core.work.guess).0;
            let slow = res > 0.1 * last_res;
            // a reused Jacobian belongs to the step size it was made for: another size (an
            // adaptive step's) is another step map, recomputed once rather than found stale
            if self.jacobian.step != Some(h)
                || self.update == JacobianUpdate::EveryStep && it == 1
                || (slow && !fresh_jacobian)
            {
                self.interface_jacobian(core, t, h)?;
                fresh_jacobian = true;
            } else if reuse && it == 1 {
                for k in 0..self.jacobian.volatile.len() {
                    if self.jacobian.volatile[k] > 0 && core.rates.stepping[k] && core.rates.feeds_iterated[k] {
                        self.jacobian.volatile[k] -= 1;
                        unit_jacobian(core, &mut self.jacobian.dydu, t, h, k)?;
                    }
                }
            }
            last_res = res;
            if reuse {
                self.u_it.copy_from_slice(&core.work.guess);
                self.y_it.copy_from_slice(&core.y);
            }
            // Newton: (I − C ∂Y/∂U) ΔU = C Y − U, in place
            let Core { work, units, rates, .. } = core;
            let l = units.layout();
            let n = work.r.len();
            let dydu = &self.jacobian.dydu;
            // an input this step does not iterate keeps its value: its row is the identity's
            let gain = |i: usize| if rates.iterated[i] { l.gain[i] } else { 0.0 };
            let row = |i: usize| (gain(i), &dydu[l.source[i] * n..(l.source[i] + 1) * n]);
            if !self.interface.solve_by_rows(row, &mut work.r) {
                return Err(core.failed(t + h, "the interface Jacobian is singular"));
            }
            for (g, d) in work.guess.iter_mut().zip(&work.r) {
                *g += d;
            }
        }
        unreachable!("evaluate fails at the iteration limit")
    }

    /// A reused Jacobian is kept (with `--jacobian reuse`); one recomputed every step is not.
    fn keep(&mut self, slot: Slot) {
        if self.update == JacobianUpdate::Reuse {
            let kept = match slot {
                Slot::Step => &mut self.before_step,
                Slot::Checkpoint => &mut self.checkpoint,
            };
            // in place: the vectors keep their allocation from step to step
            kept.dydu.clone_from(&self.jacobian.dydu);
            kept.step = self.jacobian.step;
            kept.volatile.clone_from(&self.jacobian.volatile);
        }
    }

    fn roll_back(&mut self, slot: Slot) {
        if self.update == JacobianUpdate::Reuse {
            let kept = match slot {
                Slot::Step => &self.before_step,
                Slot::Checkpoint => &self.checkpoint,
            };
            self.jacobian.dydu.copy_from_slice(&kept.dydu);
            self.jacobian.step = kept.step;
            self.jacobian.volatile.copy_from_slice(&kept.volatile);
        }
    }
}

impl Ijcsa {
    /// Broyden's (good) update of every unit's block of ∂Y/∂U with the secant of this step's
    /// last two iterates, `J_k += (ΔY_k − J_k ΔU_k) (D⁻²ΔU_k)ᵀ / (ΔU_kᵀ D⁻² ΔU_k)`, D the
    /// inputs' scales: the reused Jacobian maps the last correction exactly, and the next
    /// step's correction, along a smooth motion, points much the same way. A unit whose block
    /// missed the secant by more than [`STALE`] of the change it made in the inputs it feeds
    /// (each scaled) and by more than the tolerance is volatile: its block is recomputed at the
    /// first iteration of the next [`VOLATILE_STEPS`] steps.
    fn secant_update<S: Units>(&mut self, core: &mut Core<S>) {
        let Core { units, work, y, options, rates, .. } = core;
        let Jacobian { dydu, volatile, .. } = &mut self.jacobian;
        let (u_it, y_it) = (&self.u_it, &self.y_it);
        let tol = options.tol;
        let l = units.layout();
        let nu = work.r.len();
        for (k, u) in l.units.iter().enumerate().filter(|(k, _)| rates.stepping[*k]) {
            let (ir, or) = (u.inputs.clone(), u.outputs.clone());
            let (ds, w) = (&mut work.seed[..ir.len()], &mut work.end[..ir.len()]);
            let mut norm = 0.0;
            for (c, i) in ir.clone().enumerate() {
                ds[c] = work.guess[i] - u_it[i];
                w[c] = ds[c] / (l.scale[i] * l.scale[i]);
                norm += ds[c] * w[c];
            }
            if !(norm > 0.0) {
                continue;
            }
            for r in or.clone() {
                let row = &dydu[r * nu + ir.start..r * nu + ir.end];
                work.col[r] = y[r] - y_it[r] - row.iter().zip(ds.iter()).map(|(j, s)| j * s).sum::<f64>();
            }
            // the miss and the change in the inputs this unit feeds, each in its scale
            let (mut miss, mut change) = (0.0f64, 0.0f64);
            for (i, &r) in l.source.iter().enumerate() {
                if or.contains(&r) && rates.iterated[i] {
                    miss = miss.max((l.gain[i] * work.col[r] / l.scale[i]).abs());
                    change = change.max((l.gain[i] * (y[r] - y_it[r]) / l.scale[i]).abs());
                }
            }
            if miss > STALE * change && miss > tol {
                volatile[k] = VOLATILE_STEPS;
            }
            for r in or {
                let row = &mut dydu[r * nu + ir.start..r * nu + ir.end];
                let m = work.col[r] / norm;
                for (j, wc) in row.iter_mut().zip(w.iter()) {
                    *j += m * wc;
                }
            }
        }
    }

    /// ∂Y/∂U after stepping with `work.guess` (the units' step maps): derivatives where the
    /// unit provides them, central differences with rollback otherwise.
    fn interface_jacobian<S: Units>(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<(), StepError> {
        // a unit whose outputs no input of this step iterates (a sink, or a slower unit feeding
        // held inputs only) has a block no Newton row reads: not computed
        for k in 0..core.units.layout().units.len() {
            if core.rates.stepping[k] && core.rates.feeds_iterated[k] {
                unit_jacobian(core, &mut self.jacobian.dydu, t, h, k)?;
            }
        }
        self.jacobian.step = Some(h);
        Ok(())
    }
}

/// Unit `k`'s block of ∂Y/∂U into `dydu` (see [`Ijcsa::interface_jacobian`]).
fn unit_jacobian<S: Units>(core: &mut Core<S>, dydu: &mut [f64], t: f64, h: f64, k: usize) -> Result<(), StepError> {
    let nu = core.work.r.len();
    let (t_k, h_k) = core.rates.window(k, t, h);
    let Core { units, work, rates, .. } = core;
    let (ir, or) = (units.layout().units[k].inputs.clone(), units.layout().units[k].outputs.clone());
    let (io, ni, oo, no) = (ir.start, ir.len(), or.start, or.len());
    let (seed, col) = (&mut work.seed[..ni], &mut work.col[..no]);
    // an input this step does not iterate (a slower unit's held output) keeps its value: its
    // column is never used, and is neither asked for nor differenced
    let held = |c: usize| !rates.iterated[io + c];
    for c in (0..ni).filter(|&c| held(c)) {
        for r in 0..no {
            dydu[(oo + r) * nu + io + c] = 0.0;
        }
    }
    let res = (|| {
        if units.capabilities(k).step_derivatives {
            for c in (0..ni).filter(|&c| !held(c)) {
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
        for c in (0..ni).filter(|&c| !held(c)) {
            let delta = 1e-6 * units.layout().scale[io + c];
            for r in 0..no {
                dydu[(oo + r) * nu + io + c] = 0.0;
            }
            for sign in [1.0, -1.0] {
                work.end[..ni].copy_from_slice(&work.guess[ir.clone()]);
                work.end[c] += sign * delta;
                units.restore_state(k, Slot::Step)?;
                units.set_inputs(k, &work.end[..ni])?;
                units.do_step(k, t_k, h_k)?;
                units.get_outputs(k, col)?;
                for r in 0..no {
                    dydu[(oo + r) * nu + io + c] += sign * col[r] / (2.0 * delta);
                }
            }
        }
        units.restore_state(k, Slot::Step)?;
        units.set_inputs(k, &work.guess[ir.clone()])?;
        units.do_step(k, t_k, h_k)
    })();
    res.map_err(|e| core.unit_err(t + h, k, e))
}
