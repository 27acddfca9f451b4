//! Values of every type passed straight through: the outputs are the inputs, at once.

use serde::{Deserialize, Serialize};

/// The inputs, which are also the outputs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Feedthrough {
    pub real_continuous: f64,
    pub real_discrete: f64,
    pub integer: i32,
    pub boolean: bool,
    pub string: String,
}
