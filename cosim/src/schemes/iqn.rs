//! Interface quasi-Newton schemes: the fixed point `U = C·Y(U)` accelerated by
//! [`crate::iqn::Accelerator`] on inputs scaled per unit group.

use super::{Core, CouplingScheme, StepReport};
use crate::error::StepError;
use crate::iqn::{Accelerator, IqnOptions};
use crate::system::{Slot, Units};

pub(super) struct Iqn {
    accelerator: Accelerator,
    /// The history as it was before the last step and at the checkpoint.
    before_step: Accelerator,
    checkpoint: Accelerator,
}

impl Iqn {
    pub(super) fn new(inputs: usize, options: IqnOptions) -> Iqn {
        let fresh = || Accelerator::new(inputs, options);
        Iqn { accelerator: fresh(), before_step: fresh(), checkpoint: fresh() }
    }
}

impl<S: Units> CouplingScheme<S> for Iqn {
    fn step(&mut self, core: &mut Core<S>, t: f64, h: f64) -> Result<StepReport, StepError> {
        core.predict_end(h);
        core.keep_history(h);
        core.save_states(t)?;
        let iqn = &mut self.accelerator;
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
        let Iqn { accelerator, before_step, checkpoint } = self;
        accelerator.copy_into(match slot {
            Slot::Step => before_step,
            Slot::Checkpoint => checkpoint,
        });
    }

    fn roll_back(&mut self, slot: Slot) {
        let Iqn { accelerator, before_step, checkpoint } = self;
        match slot {
            Slot::Step => before_step,
            Slot::Checkpoint => checkpoint,
        }
        .copy_into(accelerator);
    }
}
