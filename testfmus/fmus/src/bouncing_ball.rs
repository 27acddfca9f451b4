//! `bouncing_ball`: a ball dropped onto the ground; every impact is located at its exact time
//! inside the communication step (not at a communication point).

use std::path::Path;

use fmi::export::{Model, ModelError, StepOutcome};
use fmi::{Causality, ModelDescription, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::{Ball, BouncingBall};

/// Value references, per type.
pub mod vr {
    /// Real.
    pub const H: u32 = 0;
    pub const V: u32 = 1;
    pub const G: u32 = 2;
    pub const E: u32 = 3;
    pub const V_MIN: u32 = 4;
    pub const H0: u32 = 5;
    pub const V0: u32 = 6;
    pub const DER_H: u32 = 7;
    pub const DER_V: u32 = 8;
    /// Integer.
    pub const BOUNCES: u32 = 0;
    /// Boolean.
    pub const RESTING: u32 = 0;
}

/// One instance: parameters and the ball, saved as they are.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct BouncingBallFmu {
    g: f64,
    e: f64,
    v_min: f64,
    h0: f64,
    v0: f64,
    ball: Ball,
    initialized: bool,
}

impl BouncingBallFmu {
    fn ball(&self) -> Ball {
        if self.initialized { self.ball } else { Ball { h: self.h0, v: self.v0, bounces: 0, resting: false } }
    }
}

impl Model for BouncingBallFmu {
    type State<'a> = BouncingBallFmu;

    fn description() -> Result<ModelDescription, ModelError> {
        let discrete_output = |name: &str, vr: u32, t: VarType| {
            Variable::new(name, vr, t, Causality::Output, Variability::Discrete)
                .depends_on::<&str>(&[])
                .initially_depends_on::<&str>(&[])
        };
        let variables = vec![
            Variable::real_output("h", vr::H, "m")
                .describe("height")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["h0"]),
            Variable::real_output("v", vr::V, "m/s")
                .describe("vertical velocity, up positive")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["v0"]),
            discrete_output("bounces", vr::BOUNCES, VarType::Integer).describe("impacts so far"),
            discrete_output("resting", vr::RESTING, VarType::Boolean).describe("at rest on the ground for good"),
            Variable::parameter("g", vr::G, 9.81, true).unit("m/s2").describe("gravitational acceleration (downwards)"),
            Variable::parameter("e", vr::E, 0.7, true).describe("coefficient of restitution, in [0, 1]"),
            Variable::parameter("v_min", vr::V_MIN, 0.1, true)
                .unit("m/s")
                .describe("a slower rebound leaves the ball resting"),
            Variable::parameter("h0", vr::H0, 1.0, false).unit("m").describe("initial height"),
            Variable::parameter("v0", vr::V0, 0.0, false).unit("m/s").describe("initial velocity"),
            Variable::new("der_h", vr::DER_H, VarType::Real, Causality::Local, Variability::Continuous)
                .unit("m/s")
                .describe("dh/dt (Model Exchange)"),
            Variable::new("der_v", vr::DER_V, VarType::Real, Causality::Local, Variability::Continuous)
                .unit("m/s2")
                .describe("dv/dt (Model Exchange): -g in flight, 0 at rest"),
        ];
        let d = crate::description(
            "bouncing_ball",
            "{b9475902-b0c4-431e-9086-7816531d035c}",
            "A bouncing ball: exact parabolas, impacts located inside the step (Co-Simulation), or the \
             height as event indicator (Model Exchange)",
            false,
            (3.0, 0.01),
            variables,
        );
        Ok(crate::with_model_exchange(d, &[(vr::H, vr::DER_H), (vr::V, vr::DER_V)], &[vr::H]))
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        (self.ball.h, self.ball.v) = (x[0], x[1]);
        Ok(())
    }

    /// The height: an impact is its crossing of zero.
    fn event_indicators(&mut self, z: &mut [f64]) -> Result<(), ModelError> {
        z[0] = self.ball().h;
        Ok(())
    }

    /// At an impact (on or below the ground, moving down) the ball rebounds with `e` times its
    /// speed, or rests for good when the rebound is slower than `v_min`.
    fn update_discrete_states(&mut self, _t: f64) -> Result<fmi::export::DiscreteUpdate, ModelError> {
        let b = &mut self.ball;
        let impact = !b.resting && b.h <= 0.0 && b.v < 0.0;
        if impact {
            b.h = 0.0;
            b.v *= -self.e;
            b.bounces += 1;
            if b.v <= self.v_min {
                (b.v, b.resting) = (0.0, true);
            }
        }
        Ok(fmi::export::DiscreteUpdate { states_changed: impact, ..Default::default() })
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        let ball = Ball { h: 1.0, v: 0.0, bounces: 0, resting: false };
        Ok(BouncingBallFmu { g: 9.81, e: 0.7, v_min: 0.1, h0: 1.0, v0: 0.0, ball, initialized: false })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        let nonnegative = || if value >= 0.0 { Ok(value) } else { Err(format!("{value}: must not be negative")) };
        match vr {
            vr::G => self.g = nonnegative()?,
            vr::E if (0.0..=1.0).contains(&value) => self.e = value,
            vr::E => return Err(format!("{value}: must be in [0, 1]").into()),
            vr::V_MIN => self.v_min = nonnegative()?,
            vr::H0 => self.h0 = nonnegative()?,
            vr::V0 => self.v0 = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        let ball = self.ball();
        Ok(match vr {
            vr::H => ball.h,
            vr::V => ball.v,
            vr::G => self.g,
            vr::E => self.e,
            vr::V_MIN => self.v_min,
            vr::H0 => self.h0,
            vr::V0 => self.v0,
            vr::DER_H => ball.v,
            vr::DER_V if ball.resting => 0.0,
            vr::DER_V => -self.g,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    /// `bounces`, the only Integer.
    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Ok(self.ball().bounces)
    }

    /// `resting`, the only Boolean.
    fn get_boolean(&mut self, _vr: u32) -> Result<bool, ModelError> {
        Ok(self.ball().resting)
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        (self.ball, self.initialized) = (self.ball(), true);
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        BouncingBall { g: self.g, e: self.e, v_min: self.v_min }.advance(&mut self.ball, h);
        Ok(StepOutcome::Complete)
    }

    fn save(&mut self) -> Result<BouncingBallFmu, ModelError> {
        Ok(*self)
    }

    fn restore(&mut self, saved: BouncingBallFmu) -> Result<(), ModelError> {
        *self = saved;
        Ok(())
    }
}
