//! `van_der_pol`: `x0' = x1`, `x1' = μ (1 − x0²) x1 − x0 + u`, classical RK4 in substeps.
//!
//! The states `x0`, `x1` and `der_x0 = x1` do not respond to `u` at a communication point;
//! `der_x1` does, at once (declared, and given by `fmi2GetDirectionalDerivative`).

use std::path::Path;

use fmi::export::{Derivative, Model, ModelError, Seeds, StepOutcome};
use fmi::{ModelDescription, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::VanDerPol;

/// Value references (Real).
pub mod vr {
    pub const U: u32 = 0;
    pub const X0: u32 = 1;
    pub const X1: u32 = 2;
    pub const DER_X0: u32 = 3;
    pub const DER_X1: u32 = 4;
    pub const MU: u32 = 5;
    pub const X0_START: u32 = 6;
    pub const X1_START: u32 = 7;
    pub const MAX_SUBSTEP: u32 = 8;
}

/// One instance: parameters, input and state, saved as they are.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct VanDerPolFmu {
    mu: f64,
    start: [f64; 2],
    max_substep: f64,
    u: f64,
    x: [f64; 2],
    initialized: bool,
}

impl VanDerPolFmu {
    fn model(&self) -> VanDerPol {
        VanDerPol { mu: self.mu, max_substep: self.max_substep }
    }

    fn state(&self) -> [f64; 2] {
        if self.initialized { self.x } else { self.start }
    }

    /// ∂unknown/∂known at this instant; in initialization mode the state is the start values.
    fn partial(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        let [x0, x1] = self.state();
        let init = !self.initialized;
        let mu = self.mu;
        Ok(match (unknown, known) {
            (vr::X0, vr::X0_START) | (vr::X1 | vr::DER_X0, vr::X1_START) if init => 1.0,
            (vr::X0 | vr::X1 | vr::DER_X0, vr::U | vr::MU | vr::X0_START | vr::X1_START) => 0.0,
            (vr::DER_X1, vr::U) => 1.0,
            (vr::DER_X1, vr::MU) => (1.0 - x0 * x0) * x1,
            (vr::DER_X1, vr::X0_START) if init => -2.0 * mu * x0 * x1 - 1.0,
            (vr::DER_X1, vr::X1_START) if init => mu * (1.0 - x0 * x0),
            (vr::DER_X1, vr::X0_START | vr::X1_START) => 0.0,
            (vr::X0 | vr::X1 | vr::DER_X0 | vr::DER_X1, other) => {
                return Err(crate::not_a_known(other, "u, mu, x0_start, x1_start"));
            }
            (other, _) => return Err(crate::not_an_unknown(other)),
        })
    }
}

impl Model for VanDerPolFmu {
    type State<'a> = VanDerPolFmu;

    fn description() -> Result<ModelDescription, ModelError> {
        let variables = vec![
            Variable::real_input("u", vr::U, 0.0, "").describe("forcing input"),
            Variable::real_output("x0", vr::X0, "")
                .describe("position")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x0_start"]),
            Variable::real_output("x1", vr::X1, "")
                .describe("velocity")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x1_start"]),
            Variable::real_output("der_x0", vr::DER_X0, "")
                .describe("der(x0) = x1")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x1_start"]),
            Variable::real_output("der_x1", vr::DER_X1, "")
                .describe("der(x1) = mu (1 - x0^2) x1 - x0 + u")
                .depends_on(&["u"])
                .initially_depends_on(&["u", "mu", "x0_start", "x1_start"]),
            Variable::parameter("mu", vr::MU, 1.0, true).describe("damping parameter"),
            Variable::parameter("x0_start", vr::X0_START, 2.0, false).describe("initial position"),
            Variable::parameter("x1_start", vr::X1_START, 0.0, false).describe("initial velocity"),
            Variable::parameter("max_substep", vr::MAX_SUBSTEP, 1e-3, false)
                .describe("largest Runge-Kutta substep inside a communication step (s)"),
        ];
        let d = crate::description(
            "van_der_pol",
            "{add1c0c0-bf34-46da-96cd-4046bb037f25}",
            "Van der Pol oscillator with a forcing input, classical Runge-Kutta in substeps",
            true,
            (20.0, 0.01),
            variables,
        );
        Ok(crate::with_model_exchange(d, &[(vr::X0, vr::DER_X0), (vr::X1, vr::DER_X1)], &[]))
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        self.x = [x[0], x[1]];
        Ok(())
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(VanDerPolFmu { mu: 1.0, start: [2.0, 0.0], max_substep: 1e-3, u: 0.0, x: [2.0, 0.0], initialized: false })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::U => self.u = value,
            vr::MU => self.mu = value,
            vr::X0_START => self.start[0] = value,
            vr::X1_START => self.start[1] = value,
            vr::MAX_SUBSTEP if value > 0.0 => self.max_substep = value,
            vr::MAX_SUBSTEP => return Err(format!("{value}: must be positive").into()),
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        let x = self.state();
        let rate = self.model().rate(x, self.u);
        Ok(match vr {
            vr::U => self.u,
            vr::X0 => x[0],
            vr::X1 => x[1],
            vr::DER_X0 => rate[0],
            vr::DER_X1 => rate[1],
            vr::MU => self.mu,
            vr::X0_START => self.start[0],
            vr::X1_START => self.start[1],
            vr::MAX_SUBSTEP => self.max_substep,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        (self.x, self.initialized) = (self.start, true);
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let x = self.model().advance(self.x, self.u, h);
        if !(x[0].is_finite() && x[1].is_finite()) {
            return Err(format!("the state became {x:?} (mu = {}, h = {h})", self.mu).into());
        }
        self.x = x;
        Ok(StepOutcome::Complete)
    }

    fn derivative(&mut self, _kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        crate::from_partials(at, out, |unknown, known| self.partial(unknown, known))
    }

    fn save(&mut self) -> Result<VanDerPolFmu, ModelError> {
        Ok(*self)
    }

    fn restore(&mut self, saved: VanDerPolFmu) -> Result<(), ModelError> {
        *self = saved;
        Ok(())
    }
}
