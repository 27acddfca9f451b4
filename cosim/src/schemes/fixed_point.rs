//! The fixed-point iteration with rollback: constant relaxation or Aitken's dynamic factor.

use super::{Core, CouplingScheme, Relaxation, StepReport};
use crate::error::StepError;
use crate::system::Units;

pub(super) struct FixedPoint {
    pub(super) relaxation: Relaxation,
}

impl<S: Units> CouplingScheme<S> for FixedPoint {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        core.predict_end(h);
        core.keep_history(h);
        core.save_states(t)?;
        let mut omega = match self.relaxation {
            Relaxation::Fixed(w) => w,
            Relaxation::Aitken => 0.3,
        };
        for it in 1..=core.options.max_iter {
            if let Some(done) = core.evaluate(it, t, h)? {
                return Ok(done);
            }
            let Core { work, units, .. } = core;
            let scale = &units.layout().scale;
            if self.relaxation == Relaxation::Aitken && it > 1 {
                // Aitken Δ²: ω ← −ω · (r_prev · (r − r_prev)) / |r − r_prev|², scaled entries
                let (mut num, mut dd) = (0.0, 0.0);
                for i in 0..work.r.len() {
                    let d = (work.r[i] - work.r_prev[i]) / scale[i];
                    dd += d * d;
                    num += work.r_prev[i] / scale[i] * d;
                }
                if dd > 0.0 {
                    omega = (-omega * num / dd).clamp(0.05, 1.0);
                }
            }
            for (g, r) in work.guess.iter_mut().zip(&work.r) {
                *g += omega * r;
            }
            work.r_prev.copy_from_slice(&work.r);
        }
        unreachable!("evaluate fails at the iteration limit")
    }
}
