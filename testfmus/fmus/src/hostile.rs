//! `hostile_me`: not of the zoo (`master package` leaves it out) — a Model Exchange only FMU
//! that misbehaves on request, for the tests of the master's integration. Well behaved
//! (`misbehaviour` = 0) it is `ẋ = −x` with a time event at `t_bad` that changes nothing; each
//! other value switches on one fault an importer must survive and name:
//!
//! | `misbehaviour` | from | fault |
//! |---|---|---|
//! | 1 | the time event at `t_bad` | the derivative is NaN |
//! | 2 | the start | the event indicator never settles: a relay whose every switch crosses its indicator again (an event every 2·`delta` s) |
//! | 3 | the time event at `t_bad` | the event iteration never ends (another update needed, forever) |
//! | 4 | the time event at `t_bad` | FMI 3.0: the number of continuous states reported grows by one |
//! | 5 | the start | `ẋ = x²` from `x0`: a blow-up at `1/x0` no tolerance can follow |

use std::path::Path;

use fmi::export::{DiscreteUpdate, Model, ModelError, StepOutcome};
use fmi::{Causality, ModelDescription, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};

/// Value references, per type.
pub mod vr {
    /// Real.
    pub const X: u32 = 0;
    pub const DER_X: u32 = 1;
    pub const Z: u32 = 2;
    pub const X0: u32 = 3;
    pub const T_BAD: u32 = 4;
    pub const DELTA: u32 = 5;
    /// Integer.
    pub const MISBEHAVIOUR: u32 = 0;
}

/// The faults, by their `misbehaviour` number.
const NAN: i32 = 1;
const CHATTER: i32 = 2;
const ENDLESS: i32 = 3;
const STATES: i32 = 4;
const BLOW_UP: i32 = 5;

/// One instance, saved as it is.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct HostileFmu {
    misbehaviour: i32,
    x0: f64,
    t_bad: f64,
    delta: f64,
    x: f64,
    /// The relay's direction (`misbehaviour` 2): ẋ = `dir`.
    dir: f64,
    /// The fault is on (after the time event at `t_bad`).
    bad: bool,
    initialized: bool,
}

impl HostileFmu {
    fn state(&self) -> f64 {
        if self.initialized { self.x } else { self.x0 }
    }

    fn rate(&self) -> f64 {
        let x = self.state();
        match self.misbehaviour {
            NAN if self.bad => f64::NAN,
            CHATTER => self.dir,
            BLOW_UP => x * x,
            _ => -x,
        }
    }

    /// The relay switches when `x` overshoots zero by `delta` in its direction: the switch puts
    /// `x` on the far side of the new threshold, so the indicator crosses zero again `2 delta`
    /// later (a hysteresis the wrong way round).
    fn indicator(&self) -> f64 {
        if self.misbehaviour == CHATTER { self.state() - self.dir * self.delta } else { 1.0 }
    }
}

impl Model for HostileFmu {
    type State<'a> = HostileFmu;

    fn description() -> Result<ModelDescription, ModelError> {
        let local =
            |name: &str, vr: u32| Variable::new(name, vr, VarType::Real, Causality::Local, Variability::Continuous);
        let variables = vec![
            Variable::real_output("x", vr::X, "")
                .describe("state")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x0"]),
            local("der_x", vr::DER_X).describe("its derivative"),
            local("z", vr::Z).describe("the event indicator"),
            Variable::parameter("x0", vr::X0, 1.0, false).describe("initial state"),
            Variable::parameter("t_bad", vr::T_BAD, 0.5, false)
                .unit("s")
                .describe("the time event that starts a fault"),
            Variable::parameter("delta", vr::DELTA, 1e-6, false).describe("the relay's threshold (misbehaviour 2)"),
            Variable::parameter("misbehaviour", vr::MISBEHAVIOUR, 0, false).describe(
                "0 none; 1 NaN derivative; 2 chattering; 3 endless event iteration; 4 state count; 5 blow-up",
            ),
        ];
        let mut d = crate::description(
            "hostile_me",
            "{5e1f0c3a-7d52-4b8e-9a61-68737469ee01}",
            "A Model Exchange FMU that misbehaves on request (tests of importers)",
            false,
            (2.0, 0.1),
            variables,
        );
        (d.co_simulation, d.flags) = (false, fmi::CoSimulationFlags::default());
        Ok(crate::with_model_exchange(d, &[(vr::X, vr::DER_X)], &[vr::Z]))
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(HostileFmu {
            misbehaviour: 0,
            x0: 1.0,
            t_bad: 0.5,
            delta: 1e-6,
            x: 1.0,
            dir: -1.0,
            bad: false,
            initialized: false,
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::X0 => self.x0 = value,
            vr::T_BAD => self.t_bad = value,
            vr::DELTA => self.delta = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        Ok(match vr {
            vr::X => self.state(),
            vr::DER_X => self.rate(),
            vr::Z => self.indicator(),
            vr::X0 => self.x0,
            vr::T_BAD => self.t_bad,
            vr::DELTA => self.delta,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    fn set_integer(&mut self, _vr: u32, value: i32) -> Result<(), ModelError> {
        if !(0..=BLOW_UP).contains(&value) {
            return Err(format!("misbehaviour {value}: must be 0 to {BLOW_UP}").into());
        }
        self.misbehaviour = value;
        Ok(())
    }

    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Ok(self.misbehaviour)
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        (self.x, self.initialized) = (self.x0, true);
        Ok(())
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        self.x = x[0];
        Ok(())
    }

    fn event_indicators(&mut self, z: &mut [f64]) -> Result<(), ModelError> {
        z[0] = self.indicator();
        Ok(())
    }

    fn update_discrete_states(&mut self, t: f64) -> Result<DiscreteUpdate, ModelError> {
        let mut update = DiscreteUpdate::default();
        if self.misbehaviour == CHATTER && self.indicator() * self.dir >= 0.0 {
            self.dir = -self.dir;
        }
        if t >= self.t_bad {
            self.bad = true;
            update.again = self.misbehaviour == ENDLESS;
        } else {
            update.next_event_time = Some(self.t_bad);
        }
        Ok(update)
    }

    fn reported_state_count(&self, declared: usize) -> usize {
        if self.misbehaviour == STATES && self.bad { declared + 1 } else { declared }
    }

    fn do_step(&mut self, _t: f64, _h: f64) -> Result<StepOutcome, ModelError> {
        Err("Model Exchange only".into())
    }

    fn save(&mut self) -> Result<HostileFmu, ModelError> {
        Ok(*self)
    }

    fn restore(&mut self, saved: HostileFmu) -> Result<(), ModelError> {
        *self = saved;
        Ok(())
    }
}
