//! Interface quasi-Newton schemes: the fixed point `U = C·Y(U)` accelerated by
//! [`crate::iqn::Accelerator`] on inputs scaled per unit group.
//!
//! A multi-rate system iterates other inputs in different macro steps ([`super::rates`]): each
//! set of stepping units keeps a history of its own, built from its own steps.

use super::{Core, CouplingScheme, StepReport};
use crate::error::StepError;
use crate::iqn::{Accelerator, IqnOptions};
use crate::system::{Slot, Units};

/// One set of stepping units' history, as it is, before the last step and at the checkpoint.
struct History {
    stepping: Vec<bool>,
    accelerator: Accelerator,
    before_step: Accelerator,
    checkpoint: Accelerator,
}

pub(super) struct Iqn {
    inputs: usize,
    options: IqnOptions,
    histories: Vec<History>,
}

impl Iqn {
    pub(super) fn new(inputs: usize, options: IqnOptions) -> Iqn {
        Iqn { inputs, options, histories: Vec::new() }
    }

    /// The history of the units stepping now (made the first time they step together).
    fn history(&mut self, stepping: &[bool]) -> &mut History {
        let found = self.histories.iter().position(|h| h.stepping == stepping);
        let k = found.unwrap_or_else(|| {
            let fresh = || Accelerator::new(self.inputs, self.options);
            self.histories.push(History {
                stepping: stepping.to_vec(),
                accelerator: fresh(),
                before_step: fresh(),
                checkpoint: fresh(),
            });
            self.histories.len() - 1
        });
        &mut self.histories[k]
    }
}

impl<S: Units> CouplingScheme<S> for Iqn {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        core.predict_end(h);
        core.keep_history(h);
        core.save_states(t)?;
        let iqn = &mut self.history(&core.rates.stepping).accelerator;
        iqn.start_window();
        for it in 1..=core.options.max_iter {
            let done = core.evaluate(it, t, h);
            match done {
                Ok(Some(report)) => return Ok(report),
                Ok(None) => {}
                Err(e) => {
                    iqn.discard_window();
                    return Err(e);
                }
            }
            let Core { work, units, .. } = core;
            let scale = &units.layout().scale;
            for i in 0..work.x.len() {
                work.x[i] = work.guess[i] / scale[i];
                work.xt[i] = (work.guess[i] + work.r[i]) / scale[i];
            }
            iqn.update(&mut work.x, &work.xt);
            for i in 0..work.x.len() {
                work.guess[i] = work.x[i] * scale[i];
            }
        }
        unreachable!("evaluate fails at the iteration limit")
    }

    fn keep(&mut self, slot: Slot) {
        for h in &mut self.histories {
            h.accelerator.copy_into(match slot {
                Slot::Step => &mut h.before_step,
                Slot::Checkpoint => &mut h.checkpoint,
            });
        }
    }

    fn roll_back(&mut self, slot: Slot) {
        for h in &mut self.histories {
            match slot {
                Slot::Step => &h.before_step,
                Slot::Checkpoint => &h.checkpoint,
            }
            .copy_into(&mut h.accelerator);
        }
    }
}
