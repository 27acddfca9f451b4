//! `dahlquist`: `ẋ = −k x + u`, stepped exactly with `u` held over the step (Co-Simulation),
//! or integrated by the importer (Model Exchange: the state `x`, its derivative `der_x`).
//!
//! `x` does not respond to `u` at a communication point (it is a state); `der_x = −k x + u`
//! does, at once: declared in `<ModelStructure>` and given by `fmi2GetDirectionalDerivative`.

use std::path::Path;

use fmi::export::{Derivative, Model, ModelError, Seeds, StepOutcome};
use fmi::{ModelDescription, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::Dahlquist;

/// Value references (Real).
pub mod vr {
    pub const U: u32 = 0;
    pub const X: u32 = 1;
    pub const DER_X: u32 = 2;
    pub const K: u32 = 3;
    pub const X0: u32 = 4;
}

/// One instance: parameters, input and state, saved as they are.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct DahlquistFmu {
    k: f64,
    x0: f64,
    u: f64,
    x: f64,
    initialized: bool,
}

impl DahlquistFmu {
    fn model(&self) -> Dahlquist {
        Dahlquist { k: self.k }
    }

    /// The state now: before initialization ends, the start value.
    fn state(&self) -> f64 {
        if self.initialized { self.x } else { self.x0 }
    }

    /// ∂unknown/∂known at this instant; in initialization mode `x` is `x0`.
    fn partial(&self, unknown: u32, known: u32) -> Result<f64, ModelError> {
        let x = self.state();
        let init = !self.initialized;
        Ok(match (unknown, known) {
            (vr::X, vr::X0) if init => 1.0,
            (vr::X, vr::U | vr::K | vr::X0) => 0.0,
            (vr::DER_X, vr::U) => 1.0,
            (vr::DER_X, vr::K) => -x,
            (vr::DER_X, vr::X0) if init => -self.k,
            (vr::DER_X, vr::X0) => 0.0,
            (vr::X | vr::DER_X, other) => return Err(crate::not_a_known(other, "u, k, x0")),
            (other, _) => return Err(crate::not_an_unknown(other)),
        })
    }
}

impl Model for DahlquistFmu {
    type State<'a> = DahlquistFmu;

    fn description() -> Result<ModelDescription, ModelError> {
        let variables = vec![
            Variable::real_input("u", vr::U, 0.0, "").describe("forcing input"),
            Variable::real_output("x", vr::X, "")
                .describe("state")
                .depends_on::<&str>(&[])
                .initially_depends_on(&["x0"]),
            Variable::real_output("der_x", vr::DER_X, "")
                .describe("its time derivative −k x + u")
                .depends_on(&["u"])
                .initially_depends_on(&["u", "k", "x0"]),
            Variable::parameter("k", vr::K, 1.0, true).describe("rate constant (1/s)"),
            Variable::parameter("x0", vr::X0, 1.0, false).describe("initial state"),
        ];
        let d = crate::description(
            "dahlquist",
            "{a4945425-c098-4172-b0a6-1030caf5f9ea}",
            "Dahlquist's test equation with a forcing input: der(x) = -k x + u, exact for a held u",
            true,
            (10.0, 0.1),
            variables,
        );
        Ok(crate::with_model_exchange(d, &[(vr::X, vr::DER_X)], &[]))
    }

    fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), ModelError> {
        self.x = x[0];
        Ok(())
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(DahlquistFmu { k: 1.0, x0: 1.0, u: 0.0, x: 1.0, initialized: false })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::U => self.u = value,
            vr::K => self.k = value,
            vr::X0 => self.x0 = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        let x = self.state();
        Ok(match vr {
            vr::U => self.u,
            vr::X => x,
            vr::DER_X => self.model().rate(x, self.u),
            vr::K => self.k,
            vr::X0 => self.x0,
            _ => return Err(format!("unknown value reference {vr}").into()),
        })
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        (self.x, self.initialized) = (self.x0, true);
        Ok(())
    }

    fn do_step(&mut self, _t: f64, h: f64) -> Result<StepOutcome, ModelError> {
        let x = self.model().advance(self.x, self.u, h);
        if !x.is_finite() {
            return Err(format!("x became {x} (k = {}, h = {h})", self.k).into());
        }
        self.x = x;
        Ok(StepOutcome::Complete)
    }

    fn derivative(&mut self, _kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        crate::from_partials(at, out, |unknown, known| self.partial(unknown, known))
    }

    fn save(&mut self) -> Result<DahlquistFmu, ModelError> {
        Ok(*self)
    }

    fn restore(&mut self, saved: DahlquistFmu) -> Result<(), ModelError> {
        *self = saved;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_exact_and_der_x_follows_the_input_at_once() {
        let mut m = DahlquistFmu::instantiate(None).unwrap();
        m.set_real(vr::K, 2.0).unwrap();
        m.exit_initialization(0.0).unwrap();
        for i in 0..10 {
            m.do_step(0.1 * f64::from(i), 0.1).unwrap();
        }
        assert!((m.get_real(vr::X).unwrap() - (-2.0_f64).exp()).abs() < 1e-15);
        let before = m.get_real(vr::DER_X).unwrap();
        m.set_real(vr::U, 0.5).unwrap();
        assert_eq!(m.get_real(vr::DER_X).unwrap() - before, 0.5, "feedthrough, no step needed");
        let mut d = [0.0; 2];
        m.directional_derivative(&[vr::X, vr::DER_X], &[vr::U], &[1.0], &mut d).unwrap();
        assert_eq!(d, [0.0, 1.0]);
        assert!(m.directional_derivative(&[vr::X], &[vr::DER_X], &[1.0], &mut d[..1]).is_err());
    }
}
