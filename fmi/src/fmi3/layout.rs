//! The FMI 3.0 view of a model's variables: the scalar variables of its [`ModelDescription`]
//! (what [`Model`](crate::export::Model) gets and sets) grouped into FMI 3.0 variables — a
//! vector `name[1]`…`name[n]` becomes one array variable `name` with `<Dimension start="n"/>` —
//! with value references unique across all types, as FMI 3.0 asks.
//!
//! Value references: a Float64 variable keeps the model's value reference (of its first element);
//! Int32, Boolean and String variables add [`TYPE_OFFSET`] times 1, 2, 3; the independent
//! variable `time` is [`TIME_VR`]. The model's Real value references must lie below
//! [`TYPE_OFFSET`].

use std::collections::HashMap;

use crate::description::{Causality, DescriptionError, Initial, ModelDescription, Value, VarType, Variability};

/// Added (times 1, 2, 3) to the model's Integer, Boolean and String value references.
pub const TYPE_OFFSET: u32 = 1 << 28;
/// The value reference of the independent variable `time`.
pub const TIME_VR: u32 = 4 << 28;

/// One FMI 3.0 variable: a scalar or a one-dimensional array of the model's scalars.
#[derive(Clone, Debug, PartialEq)]
pub struct Var3 {
    /// Without the element index: `cabin.r` for `cabin.r[1]`…`cabin.r[3]`.
    pub name: String,
    pub vr: u32,
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub initial: Option<Initial>,
    /// One per element, or empty.
    pub start: Vec<Value>,
    pub unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub description: String,
    /// `Some(n)`: an array of `n` elements; `None`: a scalar.
    pub dimension: Option<usize>,
    /// The model's value references of the elements, in order (empty for `time`).
    pub elements: Vec<u32>,
    /// FMI 3.0 value references this output depends on at communication points (`None`: all).
    pub depends_on: Option<Vec<u32>>,
    /// ... and in initialization mode.
    pub initial_depends_on: Option<Vec<u32>>,
}

impl Var3 {
    /// The number of values it holds.
    pub fn len(&self) -> usize {
        self.dimension.unwrap_or(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The independent variable.
    pub fn is_time(&self) -> bool {
        self.causality == Causality::Independent
    }
}

/// The FMI 3.0 variables of a validated description, in `ModelVariables` order (`time` first).
#[derive(Clone, Debug, PartialEq)]
pub struct Layout3 {
    pub variables: Vec<Var3>,
    by_vr: HashMap<u32, usize>,
}

/// `base` and `k` of a name `base[k]`.
fn indexed(name: &str) -> Option<(&str, usize)> {
    let open = name.rfind('[')?;
    let k = name.strip_suffix(']')?.get(open + 1..)?.parse().ok()?;
    Some((&name[..open], k))
}

fn type_offset(t: VarType) -> u32 {
    match t {
        VarType::Real => 0,
        VarType::Integer => TYPE_OFFSET,
        VarType::Boolean => 2 * TYPE_OFFSET,
        VarType::String => 3 * TYPE_OFFSET,
    }
}

impl Layout3 {
    /// Groups the variables of a description that [`crate::ModelInfo::new`] has validated.
    pub fn new(d: &ModelDescription) -> Result<Layout3, DescriptionError> {
        let err = |m: String| DescriptionError(format!("{} as FMI 3.0: {m}", d.model_identifier));
        let time = Var3 {
            name: "time".into(),
            vr: TIME_VR,
            var_type: VarType::Real,
            causality: Causality::Independent,
            variability: Variability::Continuous,
            initial: None,
            start: Vec::new(),
            unit: Some("s".into()),
            min: None,
            max: None,
            description: "Simulation time".into(),
            dimension: None,
            elements: Vec::new(),
            depends_on: None,
            initial_depends_on: None,
        };
        let mut variables = vec![time];
        // the FMI 3.0 variable and element of each scalar, by name
        let mut home: HashMap<&str, usize> = HashMap::new();
        let mut i = 0;
        while i < d.variables.len() {
            let first = &d.variables[i];
            if first.causality == Causality::Independent {
                return Err(err(format!("`{}`: the layer adds the independent variable `time` itself", first.name)));
            }
            if first.value_reference >= TYPE_OFFSET {
                return Err(err(format!("`{}`: value reference ≥ 2^28", first.name)));
            }
            // a run `base[1]`, `base[2]`, … of consecutive value references and equal attributes
            let mut n = 1;
            if let Some((base, 1)) = indexed(&first.name) {
                while let Some(next) = d.variables.get(i + n) {
                    let same = indexed(&next.name) == Some((base, n + 1))
                        && next.value_reference == first.value_reference + n as u32
                        && (next.var_type, next.causality, next.variability, next.initial)
                            == (first.var_type, first.causality, first.variability, first.initial)
                        && (&next.unit, next.min, next.max) == (&first.unit, first.min, first.max)
                        && next.start.is_some() == first.start.is_some();
                    if !same {
                        break;
                    }
                    n += 1;
                }
            }
            // an array only if the run holds every element of that name
            let whole = |base: &str| {
                let outside = d.variables[..i].iter().chain(&d.variables[i + n..]);
                outside.filter_map(|v| indexed(&v.name)).all(|(b, _)| b != base)
            };
            let (name, dimension) = match indexed(&first.name) {
                Some((base, 1)) if whole(base) => (base.to_owned(), Some(n)),
                _ => {
                    n = 1;
                    (first.name.clone(), None)
                }
            };
            let group = &d.variables[i..i + n];
            let description = if group.iter().all(|v| v.description == first.description) {
                first.description.clone()
            } else {
                group.iter().map(|v| v.description.as_str()).collect::<Vec<_>>().join("; ")
            };
            for v in group {
                home.insert(&v.name, variables.len());
            }
            variables.push(Var3 {
                name,
                vr: first.value_reference + type_offset(first.var_type),
                var_type: first.var_type,
                causality: first.causality,
                variability: first.variability,
                initial: first.initial,
                start: group.iter().filter_map(|v| v.start.clone()).collect(),
                unit: first.unit.clone(),
                min: first.min,
                max: first.max,
                description,
                dimension,
                elements: group.iter().map(|v| v.value_reference).collect(),
                depends_on: None,
                initial_depends_on: None,
            });
            i += n;
        }
        // Dependencies of the whole variable, the union of its elements'. At communication
        // points FMI 3.0 counts parameters among the knowns: an output depends on the inputs it
        // declares and on the tunable parameters it depends on in initialization mode.
        let tunable = |name: &str| {
            d.variable(name)
                .is_some_and(|v| v.causality == Causality::Parameter && v.variability == Variability::Tunable)
        };
        let mut at = 0;
        for k in 1..variables.len() {
            let n = variables[k].elements.len();
            let group = &d.variables[at..at + n];
            at += n;
            let union = |names: &mut dyn Iterator<Item = &String>| -> Vec<u32> {
                let mut out: Vec<usize> = names.map(|name| home[name.as_str()]).collect();
                out.sort_unstable();
                out.dedup();
                out.into_iter().map(|j| variables[j].vr).collect()
            };
            let step_mode = group.iter().map(|v| v.depends_on.as_ref()).collect::<Option<Vec<_>>>().map(|deps| {
                let initially = group.iter().flat_map(|v| v.initial_depends_on.iter().flatten());
                union(&mut deps.into_iter().flatten().chain(initially.filter(|n| tunable(n))))
            });
            let initial = group
                .iter()
                .map(|v| v.initial_depends_on.as_ref())
                .collect::<Option<Vec<_>>>()
                .map(|deps| union(&mut deps.into_iter().flatten()));
            (variables[k].depends_on, variables[k].initial_depends_on) = (step_mode, initial);
        }
        let mut by_vr = HashMap::new();
        for (k, v) in variables.iter().enumerate() {
            if by_vr.insert(v.vr, k).is_some() {
                return Err(err(format!("value reference {} is used twice", v.vr)));
            }
            if variables[..k].iter().any(|w| w.name == v.name) {
                return Err(err(format!("the name `{}` is used twice", v.name)));
            }
        }
        Ok(Layout3 { variables, by_vr })
    }

    /// The variable with this FMI 3.0 value reference.
    pub fn get(&self, vr: u32) -> Option<&Var3> {
        self.by_vr.get(&vr).map(|&k| &self.variables[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{CoSimulationFlags, ModelInfo, Variable};

    fn sample() -> ModelDescription {
        ModelDescription::co_simulation(
            "s",
            "{1}",
            "",
            "1",
            CoSimulationFlags::EXPORTED,
            vec![
                Variable::real_input("r[1]", 0, 1.0, "m").describe("r x"),
                Variable::real_input("r[2]", 1, 2.0, "m").describe("r y"),
                Variable::real_output("f[1]", 2, "N").depends_on(&["r[2]"]).describe("f"),
                Variable::real_output("f[2]", 3, "N").depends_on(&["r[1]"]).describe("f"),
                Variable::real_output("g", 4, "N").depends_on::<&str>(&[]),
                Variable::parameter("scene", 0, "a.toml", false),
                Variable::parameter("n", 0, 3, false),
            ],
        )
    }

    #[test]
    fn vectors_become_arrays_and_value_references_are_unique() {
        let info = ModelInfo::new(sample()).unwrap();
        let l = Layout3::new(&info.description).unwrap();
        let names: Vec<(&str, u32, Option<usize>)> =
            l.variables.iter().map(|v| (v.name.as_str(), v.vr, v.dimension)).collect();
        assert_eq!(
            names,
            [
                ("time", TIME_VR, None),
                ("r", 0, Some(2)),
                ("f", 2, Some(2)),
                ("g", 4, None),
                ("scene", 3 * TYPE_OFFSET, None),
                ("n", TYPE_OFFSET, None)
            ]
        );
        let r = l.get(0).unwrap();
        assert_eq!((r.elements.clone(), r.start.clone()), (vec![0, 1], vec![Value::Real(1.0), Value::Real(2.0)]));
        assert_eq!(r.description, "r x; r y");
        let f = l.get(2).unwrap();
        assert_eq!((f.description.as_str(), f.depends_on.clone()), ("f", Some(vec![0])));
        assert_eq!(l.get(4).unwrap().depends_on, Some(vec![]));
    }

    #[test]
    fn a_broken_run_of_indices_stays_apart() {
        let mut d = sample();
        d.variables[1].value_reference = 7; // r[2] not next to r[1]
        let l = Layout3::new(&ModelInfo::new(d).unwrap().description).unwrap();
        let names: Vec<&str> = l.variables.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names[..4], ["time", "r[1]", "r[2]", "f"]);
    }
}
