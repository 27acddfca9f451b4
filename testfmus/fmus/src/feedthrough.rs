//! `feedthrough`: one input of every type, each passed at once to its output.
//!
//! The Real outputs depend on their inputs at a communication point (declared, derivative 1);
//! Integer, Boolean and String outputs follow theirs just as directly.

use std::path::Path;

use fmi::export::{Derivative, Model, ModelError, Seeds, StepOutcome};
use fmi::{Causality, ModelDescription, VarType, Variability, Variable};
use serde::{Deserialize, Serialize};
use zoo_models::Feedthrough;

/// Value references, per type.
pub mod vr {
    /// Real.
    pub const REAL_CONTINUOUS_IN: u32 = 0;
    pub const REAL_CONTINUOUS_OUT: u32 = 1;
    pub const REAL_DISCRETE_IN: u32 = 2;
    pub const REAL_DISCRETE_OUT: u32 = 3;
    /// Integer, Boolean, String: the input 0, the output 1.
    pub const IN: u32 = 0;
    pub const OUT: u32 = 1;
}

pub struct FeedthroughFmu {
    values: Feedthrough,
}

/// A saved state: the values, the string borrowed.
#[derive(Serialize, Deserialize)]
pub struct SavedFeedthrough<'a> {
    real_continuous: f64,
    real_discrete: f64,
    integer: i32,
    boolean: bool,
    string: &'a str,
}

impl Model for FeedthroughFmu {
    type State<'a> = SavedFeedthrough<'a>;

    fn description() -> Result<ModelDescription, ModelError> {
        let input = |name: &str, vr: u32, t: VarType, v: Variability| Variable::new(name, vr, t, Causality::Input, v);
        let output = |name: &str, vr: u32, t: VarType, v: Variability, from: &str| {
            Variable::new(name, vr, t, Causality::Output, v).depends_on(&[from]).initially_depends_on(&[from])
        };
        use VarType::{Boolean, Integer, Real, String};
        use Variability::{Continuous, Discrete};
        let variables = vec![
            input("real_continuous_in", vr::REAL_CONTINUOUS_IN, Real, Continuous).start(0.0),
            output("real_continuous_out", vr::REAL_CONTINUOUS_OUT, Real, Continuous, "real_continuous_in"),
            input("real_discrete_in", vr::REAL_DISCRETE_IN, Real, Discrete).start(0.0),
            output("real_discrete_out", vr::REAL_DISCRETE_OUT, Real, Discrete, "real_discrete_in"),
            input("int_in", vr::IN, Integer, Discrete).start(0),
            output("int_out", vr::OUT, Integer, Discrete, "int_in"),
            input("bool_in", vr::IN, Boolean, Discrete).start(false),
            output("bool_out", vr::OUT, Boolean, Discrete, "bool_in"),
            input("string_in", vr::IN, String, Discrete).start(""),
            output("string_out", vr::OUT, String, Discrete, "string_in"),
        ];
        let d = crate::description(
            "feedthrough",
            "{b005f70a-67a5-4ac3-ae3b-83eb05f00f2f}",
            "Every input passed at once to its output: Real (continuous, discrete), Integer, Boolean, String",
            true,
            (2.0, 0.1),
            variables,
        );
        Ok(crate::with_model_exchange(d, &[], &[]))
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(FeedthroughFmu { values: Feedthrough::default() })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), ModelError> {
        match vr {
            vr::REAL_CONTINUOUS_IN => self.values.real_continuous = value,
            vr::REAL_DISCRETE_IN => self.values.real_discrete = value,
            _ => return Err(format!("value reference {vr} is not settable").into()),
        }
        Ok(())
    }

    fn get_real(&mut self, vr: u32) -> Result<f64, ModelError> {
        match vr {
            vr::REAL_CONTINUOUS_IN | vr::REAL_CONTINUOUS_OUT => Ok(self.values.real_continuous),
            vr::REAL_DISCRETE_IN | vr::REAL_DISCRETE_OUT => Ok(self.values.real_discrete),
            _ => Err(format!("unknown value reference {vr}").into()),
        }
    }

    // The layer lets only the input be set; either value reference reads the one value.
    fn set_integer(&mut self, _vr: u32, value: i32) -> Result<(), ModelError> {
        self.values.integer = value;
        Ok(())
    }

    fn get_integer(&mut self, _vr: u32) -> Result<i32, ModelError> {
        Ok(self.values.integer)
    }

    fn set_boolean(&mut self, _vr: u32, value: bool) -> Result<(), ModelError> {
        self.values.boolean = value;
        Ok(())
    }

    fn get_boolean(&mut self, _vr: u32) -> Result<bool, ModelError> {
        Ok(self.values.boolean)
    }

    fn set_string(&mut self, _vr: u32, value: &str) -> Result<(), ModelError> {
        value.clone_into(&mut self.values.string);
        Ok(())
    }

    fn get_string(&mut self, _vr: u32) -> Result<String, ModelError> {
        Ok(self.values.string.clone())
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        Ok(())
    }

    fn do_step(&mut self, _t: f64, _h: f64) -> Result<StepOutcome, ModelError> {
        Ok(StepOutcome::Complete)
    }

    /// Each Real output has derivative 1 with respect to its own input, 0 otherwise.
    fn derivative(&mut self, _kind: Derivative, at: Seeds<'_>, out: &mut [f64]) -> Result<(), ModelError> {
        for (o, &unknown) in out.iter_mut().zip(at.unknowns) {
            let input = match unknown {
                vr::REAL_CONTINUOUS_OUT => vr::REAL_CONTINUOUS_IN,
                vr::REAL_DISCRETE_OUT => vr::REAL_DISCRETE_IN,
                other => return Err(crate::not_an_unknown(other)),
            };
            *o = 0.0;
            for (&known, &seed) in at.knowns.iter().zip(at.seed) {
                match known {
                    k if k == input => *o += seed,
                    vr::REAL_CONTINUOUS_IN | vr::REAL_DISCRETE_IN => {}
                    other => return Err(crate::not_a_known(other, "real_continuous_in, real_discrete_in")),
                }
            }
        }
        Ok(())
    }

    fn save(&mut self) -> Result<SavedFeedthrough<'_>, ModelError> {
        let v = &self.values;
        Ok(SavedFeedthrough {
            real_continuous: v.real_continuous,
            real_discrete: v.real_discrete,
            integer: v.integer,
            boolean: v.boolean,
            string: &v.string,
        })
    }

    fn restore(&mut self, s: SavedFeedthrough<'_>) -> Result<(), ModelError> {
        self.values = Feedthrough {
            real_continuous: s.real_continuous,
            real_discrete: s.real_discrete,
            integer: s.integer,
            boolean: s.boolean,
            string: s.string.to_owned(),
        };
        Ok(())
    }
}
