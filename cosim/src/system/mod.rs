//! The coupled system as the schemes see it: units (FMUs or in-process models) with Real inputs
//! and outputs, the connections between them as a map from outputs to inputs, and the scale of
//! every coupled quantity.
//!
//! The interface unknowns are all connected Real inputs, stacked unit by unit: `U`. After a step
//! every unit `k` has outputs `Y_k(U_k)`; the coupling asks `U_i = gain_i · Y_{source_i} +
//! offset_i` (a plain connection has gain 1 and offset 0; SSP linear transformations and unit
//! conversions set them). Non-Real connections (Integer, Boolean, String) are not unknowns: they
//! are sampled at communication points and held over the step ([`Units::exchange_discrete`]).

pub mod fmu;
pub mod spec;

use std::ops::Range;

/// One unit's place in `U` and `Y`.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitLayout {
    pub name: String,
    /// Its connected Real inputs in `U`.
    pub inputs: Range<usize>,
    /// Its connected Real outputs in `Y`.
    pub outputs: Range<usize>,
}

/// Where every coupled quantity sits and how the connections map outputs to inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub units: Vec<UnitLayout>,
    /// For every entry of `U`: the entry of `Y` connected to it.
    pub source: Vec<usize>,
    /// `U_i = gain_i · Y_source_i + offset_i`.
    pub gain: Vec<f64>,
    pub offset: Vec<f64>,
    /// Scale of every entry of `U` (positive): residuals and errors are measured relative to it.
    pub scale: Vec<f64>,
    /// Unit group of every entry of `U` (inputs of one unit with one unit of measure, e.g. the
    /// components of a force): they share a scale, and the adaptive step a range.
    pub group: Vec<usize>,
    /// `unit.variable` of every entry of `U` and of `Y`, for messages.
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
}

impl Layout {
    pub fn inputs(&self) -> usize {
        self.source.len()
    }

    pub fn outputs(&self) -> usize {
        self.output_names.len()
    }

    /// The unit that owns entry `y` of `Y`.
    pub fn owner_of_output(&self, y: usize) -> Option<usize> {
        self.units.iter().position(|u| u.outputs.contains(&y))
    }

    /// The coupled value of input `i` for outputs `y`.
    #[inline]
    pub fn coupled(&self, i: usize, y: &[f64]) -> f64 {
        self.gain[i] * y[self.source[i]] + self.offset[i]
    }

    /// Scales per unit group: the largest |value| (at least 1) among the inputs of the same
    /// unit sharing a group key (e.g. the unit of measure), so that the components of a force
    /// share one scale.
    pub fn group_scales<K: PartialEq>(values: &[f64], key: &[K]) -> Vec<f64> {
        (0..values.len())
            .map(|i| (0..values.len()).filter(|&j| key[j] == key[i]).map(|j| values[j].abs()).fold(1.0, f64::max))
            .collect()
    }

    /// Group numbers from group keys: equal keys, equal numbers (first appearance order).
    pub fn groups<K: PartialEq>(key: &[K]) -> Vec<usize> {
        let mut firsts: Vec<usize> = Vec::new();
        key.iter()
            .enumerate()
            .map(|(i, k)| match firsts.iter().position(|&f| key[f] == *k) {
                Some(g) => g,
                None => {
                    firsts.push(i);
                    firsts.len() - 1
                }
            })
            .collect()
    }
}

/// What a unit can do beyond stepping.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// Save and restore its state (rollback): iterating schemes and the adaptive step need it.
    pub rollback: bool,
    /// Derivatives of its step map (outputs after a step with respect to the inputs held during it).
    pub step_derivatives: bool,
    /// Takes input slopes over the step (fmi2SetRealInputDerivatives).
    pub interpolates: bool,
}

/// Why a unit could not do what it was asked.
#[derive(Debug, thiserror::Error)]
pub enum UnitError {
    /// The unit refused the step and will not go on (fmi2Discard): the run ends at the last
    /// communication point all units reached.
    #[error("ended the run (fmi2Discard{}){}", if *.terminated { ", fmi2Terminated" } else { "" },
        .last_successful_time.map_or(String::new(), |t| format!(" at its last successful time {t} s")))]
    Ended { last_successful_time: Option<f64>, terminated: bool },
    #[error(transparent)]
    Fmi(#[from] fmi2::import::Error),
    /// Any other failure of an in-process unit.
    #[error("{0}")]
    Other(String),
}

/// The units of a coupled system: what the schemes call. The FMU system implements it, and so
/// do in-process test systems. `k` is a unit index, slices are the unit's part of `U` or `Y`.
pub trait Units {
    fn layout(&self) -> &Layout;
    fn capabilities(&self, k: usize) -> Capabilities;
    /// Sets the unit's connected Real inputs.
    fn set_inputs(&mut self, k: usize, u: &[f64]) -> Result<(), UnitError>;
    /// Sets the slopes of its inputs over the next step (only if it `interpolates`).
    fn set_input_slopes(&mut self, k: usize, slopes: &[f64]) -> Result<(), UnitError>;
    fn do_step(&mut self, k: usize, t: f64, h: f64) -> Result<(), UnitError>;
    /// Reads its connected Real outputs.
    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError>;
    /// Saves its state into its one rollback slot (overwriting the last).
    fn save_state(&mut self, k: usize) -> Result<(), UnitError>;
    /// Restores the state of the rollback slot, bit for bit.
    fn restore_state(&mut self, k: usize) -> Result<(), UnitError>;
    /// `out = ∂Y_k/∂U_k · seed` of the step just taken (needs `step_derivatives`).
    fn step_derivative(&mut self, k: usize, seed: &[f64], out: &mut [f64]) -> Result<(), UnitError>;
    /// Passes the values of non-Real connections from outputs to inputs (at a communication point).
    fn exchange_discrete(&mut self) -> Result<(), UnitError> {
        Ok(())
    }
}
