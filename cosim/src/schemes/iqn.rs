//! Interface quasi-Newton schemes: the fixed point `U = C·Y(U)` accelerated by
//! [`crate::iqn::Accelerator`] on inputs scaled per unit group.

use super::{Coupled, StepReport};
use crate::error::StepError;
use crate::system::Units;

impl<S: Units> Coupled<S> {
    pub(super) fn step_iqn(&mut self, t: f64, h: f64) -> Result<StepReport, StepError> {
        self.predict_end(h);
        self.keep_history(h);
        self.save_states(t)?;
        self.iqn.start_window();
        for it in 1..=self.options.max_iter {
            let done = self.evaluate(it, t, h);
            match done {
                Ok(Some(report)) => return Ok(report),
                Ok(None) => {}
                Err(e) => {
                    self.iqn.discard_window();
                    return Err(e);
                }
            }
            let Coupled { work, units, iqn, .. } = self;
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
}
