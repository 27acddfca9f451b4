//! A model's Real variables declared once: a table of blocks (a vector variable `name[1..n]` or a
//! scalar) from which the value references, the names, the offsets into the model's arrays and
//! the `<ModelVariables>` entries all come. [`variable_table!`](crate::variable_table) lays the
//! blocks out one after the other and names each block's first value reference.

use std::ops::Range;

use crate::description::{Causality, Variable};

/// One block of Real variables.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// The first value reference (set by the table).
    pub vr: u32,
    pub name: &'static str,
    pub count: u32,
    /// Named `name[1]`…`name[count]`; a scalar block is named `name`.
    indexed: bool,
    pub causality: Causality,
    pub unit: &'static str,
    /// `{k}` stands for the component: its label, or its index from 1 when there are no labels.
    pub description: &'static str,
    pub labels: &'static [&'static str],
    /// The declared range, if any (values set outside it are refused).
    pub range: Option<(f64, f64)>,
    /// A parameter's start value (inputs take theirs from the model).
    pub start: f64,
}

impl Block {
    const fn new(
        name: &'static str,
        count: u32,
        causality: Causality,
        unit: &'static str,
        description: &'static str,
    ) -> Block {
        Block { vr: 0, name, count, indexed: true, causality, unit, description, labels: &[], range: None, start: 0.0 }
    }

    /// `count` continuous Real inputs.
    pub const fn input(name: &'static str, count: u32, unit: &'static str, description: &'static str) -> Block {
        Block::new(name, count, Causality::Input, unit, description)
    }

    /// `count` continuous Real outputs.
    pub const fn output(name: &'static str, count: u32, unit: &'static str, description: &'static str) -> Block {
        Block::new(name, count, Causality::Output, unit, description)
    }

    /// A fixed scalar Real parameter with its start value.
    pub const fn parameter(name: &'static str, start: f64, unit: &'static str, description: &'static str) -> Block {
        Block { indexed: false, start, ..Block::new(name, 1, Causality::Parameter, unit, description) }
    }

    /// Components named by `labels` in the descriptions (e.g. a quaternion's w, x, y, z).
    pub const fn labels(self, labels: &'static [&'static str]) -> Block {
        Block { labels, ..self }
    }

    pub const fn range(self, min: f64, max: f64) -> Block {
        Block { range: Some((min, max)), ..self }
    }

    /// The block starting at value reference `vr`.
    pub const fn at(self, vr: u32) -> Block {
        Block { vr, ..self }
    }

    /// Its value references.
    pub const fn values(&self) -> Range<u32> {
        self.vr..self.vr + self.count
    }

    /// The name of component `k` (from 0).
    pub fn name_of(&self, k: usize) -> String {
        if self.indexed { format!("{}[{}]", self.name, k + 1) } else { self.name.to_owned() }
    }

    pub fn names(&self) -> impl Iterator<Item = String> + '_ {
        (0..self.count as usize).map(|k| self.name_of(k))
    }

    /// The description of component `k` (from 0).
    pub fn description_of(&self, k: usize) -> String {
        let label = self.labels.get(k).map_or_else(|| (k + 1).to_string(), |l| (*l).to_owned());
        self.description.replace("{k}", &label)
    }

    /// Its variables; an input's start value is `input_start(vr)`.
    pub fn variables(&self, input_start: &dyn Fn(u32) -> f64) -> Vec<Variable> {
        (0..self.count)
            .map(move |k| {
                let (name, vr) = (self.name_of(k as usize), self.vr + k);
                let v = match self.causality {
                    Causality::Input => Variable::real_input(name, vr, input_start(vr), self.unit),
                    Causality::Output => Variable::real_output(name, vr, self.unit),
                    _ => Variable::parameter(name, vr, self.start, false).unit(self.unit),
                };
                let v = match self.range {
                    Some((min, max)) => v.range(min, max),
                    None => v,
                };
                v.describe(self.description_of(k as usize))
            })
            .collect()
    }
}

/// The number of scalar variables of this causality.
pub const fn count(table: &[Block], causality: Causality) -> usize {
    let (mut n, mut i) = (0, 0);
    while i < table.len() {
        // `==` on the enum is not const: compare the discriminants
        if table[i].causality as u8 == causality as u8 {
            n += table[i].count as usize;
        }
        i += 1;
    }
    n
}

/// The names of the scalar variables of this causality, in value-reference order.
pub fn names(table: &[Block], causality: Causality) -> Vec<String> {
    table.iter().filter(|b| b.causality == causality).flat_map(Block::names).collect()
}

/// Every variable of the table in value-reference order; an input's start value is
/// `input_start(vr)`.
pub fn variables(table: &[Block], input_start: impl Fn(u32) -> f64) -> Vec<Variable> {
    table.iter().flat_map(|b| b.variables(&input_start)).collect()
}

/// A model's table of Real variables: `NAME = block` defines `pub const NAME: u32`, the block's
/// first value reference (the sum of the sizes before it, from 0), and `pub const TABLE`, the
/// blocks in that order. Entries may carry doc comments.
///
/// ```
/// use fmi::table::Block;
/// fmi::variable_table! {
///     R = Block::input("r", 3, "m", "position {k}"),
///     Q = Block::output("q", 4, "", "orientation ({k})").labels(&["w", "x", "y", "z"]),
///     GAIN = Block::parameter("gain", 1.0, "", "gain"),
/// }
/// assert_eq!((R, Q, GAIN), (0, 3, 7));
/// assert_eq!(TABLE[1].name_of(0), "q[1]");
/// assert_eq!(TABLE[1].description_of(0), "orientation (w)");
/// assert_eq!(TABLE[2].name_of(0), "gain");
/// ```
#[macro_export]
macro_rules! variable_table {
    ($($(#[$doc:meta])* $name:ident = $block:expr),* $(,)?) => {
        $crate::variable_table!(@from 0; $($(#[$doc])* $name = $block,)*);
        /// The blocks in value-reference order.
        pub const TABLE: &[$crate::table::Block] = &[$(($block).at($name),)*];
    };
    (@from $at:expr; $(#[$doc:meta])* $name:ident = $block:expr, $($rest:tt)*) => {
        $(#[$doc])*
        pub const $name: u32 = $at;
        $crate::variable_table!(@from $name + ($block).count; $($rest)*);
    };
    (@from $at:expr;) => {};
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::Value;

    // the table's items are `pub`, as in a model's public `vr` module
    #[allow(unreachable_pub)]
    mod vr {
        use super::Block;
        crate::variable_table! {
            U = Block::input("u", 2, "m", "input {k}").range(-1.0, 1.0),
            Y = Block::output("y", 3, "N", "output ({k})").labels(&["a", "b", "c"]),
            P = Block::parameter("p", -1.0, "s", "a parameter"),
        }
    }

    #[test]
    fn blocks_follow_each_other_and_give_every_scalar_variable() {
        assert_eq!((vr::U, vr::Y, vr::P), (0, 2, 5));
        assert_eq!(count(vr::TABLE, Causality::Input), 2);
        assert_eq!(count(vr::TABLE, Causality::Output), 3);
        assert_eq!(names(vr::TABLE, Causality::Output), ["y[1]", "y[2]", "y[3]"]);
        let v = variables(vr::TABLE, |vr| 10.0 + vr as f64);
        let refs: Vec<u32> = v.iter().map(|v| v.value_reference).collect();
        assert_eq!(refs, [0, 1, 2, 3, 4, 5]);
        assert_eq!(
            (v[1].name.as_str(), v[1].start.clone(), v[1].min, v[1].max),
            ("u[2]", Some(Value::Real(11.0)), Some(-1.0), Some(1.0))
        );
        assert_eq!(
            (v[3].description.as_str(), v[3].unit.as_deref(), v[3].start.clone()),
            ("output (b)", Some("N"), None)
        );
        assert_eq!(
            (v[5].name.as_str(), v[5].causality, v[5].start.clone()),
            ("p", Causality::Parameter, Some(Value::Real(-1.0)))
        );
        assert_eq!(v[0].description, "input 1");
    }
}
