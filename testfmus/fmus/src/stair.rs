//! `stair`: a counter from 1, up by one every `period`; at `final_count` the model ends: the
//! step that reaches it returns fmi2Discard, `fmi2Terminated` is true and
//! `fmi2LastSuccessfulTime` is the time of the final count (inside the step or at its end).

use std::path::Path;

use fmi::export::{Model, ModelError, StepOutcome};
use fmi::{Causality, ModelDescription, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::{Stair, StairStep};

/// Value references, per type.
pub mod vr {
    /// Real.
    pub const PERIOD: u32 = 0;
    /// Integer.
    pub const COUNTER: u32 = 0;
    pub const FINAL_COUNT: u32 = 1;
}

/// One instance: parameters and the count, saved as they are.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct StairFmu {
    period: f64,
    final_count: i32,
    counter: i32,
}

impl StairFmu {
    fn model(&self) -> Stair {
        Stair { period: self.period, final_count: self.final_count }
    }
}

impl Model for StairFmu {
    type State<'a> = StairFmu;

    fn description() -> Result<ModelDescription, ModelError> {
        let variables = vec![
            Variable::new("counter", vr::COUNTER, VarType::Integer, Causality::Output, Variability::Discrete)
                .describe("1, then one more at every multiple of the period")
                .depends_on::<&str>(&[])
                .initially_depends_on::<&str>(&[]),
            Variable::parameter("period", vr::PERIOD, 1.0, false).unit("s").describe("time between increments"),
            Variable::parameter("final_count", vr::FINAL_COUNT, 10, false)
                .describe("the count at which the model ends (fmi2DoStep returns fmi2Discard)"),
        ];
        let d = crate::description(
            "stair",
            "{70a83ecd-ae86-4363-9a81-1b8404d22948}",
            "A counter with time events that ends the simulation at its final count",
            false,
            (10.0, 0.2),
            variables,
        );
        Ok(crate::with_model_exchange(d, &[], &[]))
    }

    /// At each multiple of the period (a time event) the counter goes up by one; at the final
    /// count the model ends the simulation.
    fn update_discrete_states(&mut self, t: f64) -> Result<fmi::export::DiscreteUpdate, ModelError> {
        self.counter = self.model().count_at(t);
        let mut update = fmi::export::DiscreteUpdate::default();
        if self.counter >= self.final_count {
            update.terminate = Some(format!("the counter reached {}", self.final_count));
        } else {
            update.next_event_time = Some(f64::from(self.counter) * self.period);
        }
        Ok(update)
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(StairFmu { period: 1.0, final_count: 10, counter: 1 })
    }

    /// `period`, the only settable Real.
    fn set_real(&mut self, _vr: u32, value: f64) -> Result<(), ModelError> {
        if !(value > 0.0) {
            return Err(format!("{value}: must be positive").into());
        }
        self.period = value;
        Ok(())
    }

    fn get_real(&mut self, _vr: u32) -> Result<f64, ModelError> {
        Ok(self.period)
    }

    /// `final_count`, the only settable Integer.
    fn set_integer(&mut self, _vr: u32, value: i32) -> Result<(), ModelError> {
        if value < 1 {
            return Err(format!("{value}: must be at least 1").into());
        }
        self.final_count = value;
        Ok(())
    }

    fn get_integer(&mut self, vr: u32) -> Result<i32, ModelError> {
        Ok(if vr == vr::COUNTER { self.counter } else { self.final_count })
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.counter = self.model().count_at(start_time);
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        match self.model().step(t, h) {
            StairStep::Reached(count) => {
                self.counter = count;
                Ok(StepOutcome::Complete)
            }
            StairStep::Ended { time } => {
                self.counter = self.final_count;
                Ok(StepOutcome::Terminated { time, reason: format!("the counter reached {}", self.final_count) })
            }
        }
    }

    fn save(&mut self) -> Result<StairFmu, ModelError> {
        Ok(*self)
    }

    fn restore(&mut self, saved: StairFmu) -> Result<(), ModelError> {
        *self = saved;
        Ok(())
    }
}
