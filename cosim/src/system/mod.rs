//! The coupled system as the schemes see it: units (FMUs or in-process models) with Real inputs
//! and outputs, the connections between them as a map from outputs to inputs, and the scale of
//! every coupled quantity.
//!
//! The interface unknowns are all connected Real inputs, stacked unit by unit: `U`. After a step
//! every unit `k` has outputs `Y_k(U_k)`; the coupling asks `U_i = gain_i · Y_{source_i} +
//! offset_i` (a plain connection has gain 1 and offset 0; SSP linear transformations and unit
//! conversions set them). Non-Real connections (Integer, Boolean, String) are not unknowns: they
//! are sampled at communication points and held over the step ([`Units::exchange_discrete`]).
//! `Y` may also hold outputs that feed no input, read after every step for the adaptive step to
//! watch ([`crate::SystemSpec::observed`]).

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
    /// Direct feedthrough inside the units: `(y, u)` when output `y` responds at once to input
    /// `u` of the same unit (for FMUs, what `<ModelStructure><Outputs>` declares; an output
    /// without a `dependencies` list depends on every input, FMI 2.0 says).
    pub feedthrough: Vec<(usize, usize)>,
}

impl Layout {
    pub fn inputs(&self) -> usize {
        self.source.len()
    }

    pub fn outputs(&self) -> usize {
        self.output_names.len()
    }

    /// The unit that owns entry `y` of `Y`.
    pub(crate) fn owner_of_output(&self, y: usize) -> Option<usize> {
        self.units.iter().position(|u| u.outputs.contains(&y))
    }

    /// The coupled value of input `i` for outputs `y`.
    #[inline]
    pub fn coupled(&self, i: usize, y: &[f64]) -> f64 {
        self.gain[i] * y[self.source[i]] + self.offset[i]
    }

    /// An algebraic loop, if the system has one: inputs `u₀ → u₁ → … → u₀` where each next
    /// input takes an output that responds at once to the one before (direct feedthrough all
    /// the way round), so no unit's outputs can be computed before the others'. Returns the
    /// inputs of the first loop found, in order.
    pub(crate) fn algebraic_loop(&self) -> Option<Vec<usize>> {
        // input i → every input fed by an output that feeds through from i
        let next: Vec<Vec<usize>> = (0..self.inputs())
            .map(|i| {
                let outputs: Vec<usize> = self.feedthrough.iter().filter(|f| f.1 == i).map(|f| f.0).collect();
                (0..self.inputs()).filter(|&j| outputs.contains(&self.source[j])).collect()
            })
            .collect();
        // depth-first search; a successor on the current path closes a loop
        #[derive(Clone, Copy, PartialEq)]
        enum Mark {
            New,
            OnPath,
            Done,
        }
        let mut mark = vec![Mark::New; self.inputs()];
        for root in 0..self.inputs() {
            if mark[root] != Mark::New {
                continue;
            }
            let mut path = vec![root];
            let mut cursor = vec![0];
            mark[root] = Mark::OnPath;
            while let (Some(&i), Some(c)) = (path.last(), cursor.last_mut()) {
                let Some(&j) = next[i].get(*c) else {
                    mark[i] = Mark::Done;
                    path.pop();
                    cursor.pop();
                    continue;
                };
                *c += 1;
                match mark[j] {
                    Mark::OnPath => {
                        let start = path.iter().position(|&p| p == j).expect("on the path");
                        return Some(path[start..].to_vec());
                    }
                    Mark::New => {
                        mark[j] = Mark::OnPath;
                        path.push(j);
                        cursor.push(0);
                    }
                    Mark::Done => {}
                }
            }
        }
        None
    }

    /// A loop of [`Layout::algebraic_loop`] as text: every input, then the output it feeds
    /// through to, back to the first input.
    pub(crate) fn describe_loop(&self, inputs: &[usize]) -> String {
        let mut text = String::new();
        for (n, &i) in inputs.iter().enumerate() {
            let next = inputs[(n + 1) % inputs.len()];
            let y = self.source[next];
            text.push_str(&format!("`{}` → `{}` → ", self.input_names[i], self.output_names[y]));
        }
        text.push_str(&format!("`{}`", self.input_names[inputs[0]]));
        text
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

/// A unit's two rollback slots: every step of an iterating scheme saves its start in `Step`; the
/// adaptive step's step doubling keeps the start of its steps in `Checkpoint`, to go back over
/// more than one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    Step,
    Checkpoint,
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
    /// The unit ended the run on purpose (FMI 2.0: fmi2Discard; FMI 3.0: terminateSimulation or
    /// an early return): the run ends at the last communication point all units reached.
    /// `signal` says how, in the standard's words.
    #[error("ended the run ({signal}){}",
        .last_successful_time.map_or(String::new(), |t| format!(" at its last successful time {t} s")))]
    Ended { last_successful_time: Option<f64>, terminated: bool, signal: &'static str },
    #[error(transparent)]
    Fmi(#[from] fmi::import::Error),
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
    /// Reads its Real outputs in `Y` (the connected ones, and those read besides).
    fn get_outputs(&mut self, k: usize, y: &mut [f64]) -> Result<(), UnitError>;
    /// Saves its state into a rollback slot (overwriting what it held).
    fn save_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError>;
    /// Restores the state saved in a rollback slot, bit for bit.
    fn restore_state(&mut self, k: usize, slot: Slot) -> Result<(), UnitError>;
    /// `out = ∂Y_k/∂U_k · seed` of the step just taken (needs `step_derivatives`).
    fn step_derivative(&mut self, k: usize, seed: &[f64], out: &mut [f64]) -> Result<(), UnitError>;
    /// Passes the values of non-Real connections from outputs to inputs (at a communication
    /// point); a failure names the unit it concerns.
    fn exchange_discrete(&mut self) -> Result<(), (usize, UnitError)> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Units in a row, one input and one output each; unit k's input takes output `source[k]`;
    /// `through[k]`: unit k's output feeds through from its input.
    fn layout(source: &[usize], through: &[bool]) -> Layout {
        let n = source.len();
        Layout {
            units: (0..n).map(|k| UnitLayout { name: format!("n{k}"), inputs: k..k + 1, outputs: k..k + 1 }).collect(),
            source: source.to_vec(),
            gain: vec![1.0; n],
            offset: vec![0.0; n],
            scale: vec![1.0; n],
            group: vec![0; n],
            input_names: (0..n).map(|k| format!("n{k}.u")).collect(),
            output_names: (0..n).map(|k| format!("n{k}.y")).collect(),
            feedthrough: (0..n).filter(|&k| through[k]).map(|k| (k, k)).collect(),
        }
    }

    #[test]
    fn a_loop_needs_feedthrough_all_the_way_round() {
        // a ring of three: n0 ← n2, n1 ← n0, n2 ← n1
        let ring = [2, 0, 1];
        let l = layout(&ring, &[true, true, true]);
        let cycle = l.algebraic_loop().expect("a loop");
        assert_eq!(cycle.len(), 3);
        assert_eq!(l.describe_loop(&[0, 1, 2]), "`n0.u` → `n0.y` → `n1.u` → `n1.y` → `n2.u` → `n2.y` → `n0.u`");
        // one state on the ring breaks it
        assert_eq!(layout(&ring, &[true, false, true]).algebraic_loop(), None);
        // a unit feeding itself through feedthrough is a loop of one
        assert_eq!(layout(&[0, 0], &[true, true]).algebraic_loop(), Some(vec![0]));
        // a chain is none, however much feeds through
        let mut chain = layout(&[1, 2, 2], &[true, true, false]);
        assert_eq!(chain.algebraic_loop(), None);
        // a loop downstream of a chain is found
        chain.feedthrough.push((2, 2));
        assert_eq!(chain.algebraic_loop(), Some(vec![2]));
    }
}
