//! The exporter's checks of a [`ModelDescription`] against the FMI 2.0 rules, and the indexed
//! view ([`ModelInfo`]) the C layer works from.

use std::collections::{HashMap, HashSet};

use super::{Causality, CoSimulationFlags, Initial, ModelDescription, Value, VarType, Variability, Variable};

/// A rule of the standard (or of the export layer) that the description breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid model description: {0}")]
pub struct DescriptionError(pub String);

/// A validated variable: its 1-based index in `ModelVariables` and its dependencies as
/// 1-based indices.
#[derive(Clone, Debug)]
pub struct VarInfo {
    /// The variable, `initial` filled in with the standard's default.
    pub var: Variable,
    pub index: usize,
    pub dependencies: Option<Vec<usize>>,
    pub initial_dependencies: Option<Vec<usize>>,
}

impl VarInfo {
    /// May `fmi2Set*` change this variable in the given phase? (FMI 2.0 CS state table.)
    pub(crate) fn settable_in(&self, phase: SetPhase) -> bool {
        let v = &self.var;
        if v.variability == Variability::Constant {
            return false;
        }
        let input = v.causality == Causality::Input;
        match phase {
            SetPhase::Instantiated => input || matches!(v.initial, Some(Initial::Exact | Initial::Approx)),
            SetPhase::InitializationMode => input || v.initial == Some(Initial::Exact),
            SetPhase::StepMode => {
                input || (v.causality == Causality::Parameter && v.variability == Variability::Tunable)
            }
        }
    }
}

/// The phases in which `fmi2Set*` is allowed at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SetPhase {
    Instantiated,
    InitializationMode,
    StepMode,
}

/// A validated, indexed model description.
#[derive(Clone, Debug)]
pub struct ModelInfo {
    /// The description as it is written: every `initial` the standard allows filled in, and
    /// the dependencies in `ModelVariables` order without repetitions.
    pub description: ModelDescription,
    /// The variables in `ModelVariables` order.
    pub vars: Vec<VarInfo>,
    /// Per type (Real, Integer, Boolean, String): (value reference, position in `vars`), sorted.
    by_vr: [Vec<(u32, usize)>; 4],
    /// Per type, position in `vars` + 1 indexed by value reference (0: none), where the value
    /// references are dense enough (the get/set/derivative paths look one up per value).
    direct: [Vec<u32>; 4],
}

/// A type's direct table when its largest value reference is below this many entries per
/// variable (plus a constant): memory stays proportional to the variables.
const DIRECT_PER_VARIABLE: usize = 4;
const DIRECT_EXTRA: usize = 256;

/// Position + 1 by value reference, or nothing if the references are too sparse for a table.
fn direct_table(list: &[(u32, usize)]) -> Vec<u32> {
    let Some(&(largest, _)) = list.last() else { return Vec::new() };
    let len = largest as usize + 1;
    if len > DIRECT_PER_VARIABLE * list.len() + DIRECT_EXTRA {
        return Vec::new();
    }
    let mut table = vec![0; len];
    for &(vr, pos) in list {
        table[vr as usize] = u32::try_from(pos + 1).expect("fewer than 2^32 variables");
    }
    table
}

fn type_slot(t: VarType) -> usize {
    match t {
        VarType::Real => 0,
        VarType::Integer => 1,
        VarType::Boolean => 2,
        VarType::String => 3,
    }
}

/// The `<CoSimulation>` flags the export layer decides; a model sets only the others.
fn layer_flags(f: &CoSimulationFlags) -> CoSimulationFlags {
    CoSimulationFlags {
        can_interpolate_inputs: false,
        provides_directional_derivative: false,
        provides_step_map_derivative: false,
        ..*f
    }
}

impl ModelInfo {
    /// Check every rule of the standard the layer relies on; index the table.
    pub fn new(description: ModelDescription) -> Result<ModelInfo, DescriptionError> {
        let mut d = description;
        let err = |msg: String| Err(DescriptionError(msg));
        if d.fmi_version != "2.0" {
            return err(format!("fmiVersion `{}`: the exporter writes FMI 2.0 (`2.0`)", d.fmi_version));
        }
        if d.model_name.trim().is_empty() {
            return err("`modelName` is empty".into());
        }
        if !is_c_identifier(&d.model_identifier) {
            return err(format!("modelIdentifier `{}` is not a C identifier", d.model_identifier));
        }
        if d.guid.trim().is_empty() {
            return err("`guid` is empty".into());
        }
        // a Model Exchange only description has no <CoSimulation> flags: none are written
        if !d.co_simulation && d.flags != CoSimulationFlags::default() {
            return err("a description without Co-Simulation has no <CoSimulation> flags: leave them default".into());
        }
        if d.co_simulation && layer_flags(&d.flags) != CoSimulationFlags::EXPORTED {
            return err(format!(
                "the <CoSimulation> flags {:?} are not what the export layer implements; start from \
                 `CoSimulationFlags::EXPORTED` and set only canInterpolateInputs, providesDirectionalDerivative \
                 and the step-map extension",
                d.flags
            ));
        }
        if let Some(e) = &d.default_experiment {
            for (name, x) in [("startTime", e.start_time), ("stopTime", e.stop_time), ("stepSize", e.step_size)] {
                if let Some(x) = x
                    && !x.is_finite()
                {
                    return err(format!("DefaultExperiment {name} = {x} is not finite"));
                }
            }
            if let (Some(a), Some(b)) = (e.start_time, e.stop_time)
                && b <= a
            {
                return err(format!("DefaultExperiment needs startTime < stopTime, got {a} .. {b}"));
            }
            for (name, x) in [("stepSize", e.step_size), ("tolerance", e.tolerance)] {
                if let Some(x) = x
                    && !(x.is_finite() && x > 0.0)
                {
                    return err(format!("DefaultExperiment {name} must be positive, got {x}"));
                }
            }
        }
        let mut unit_names = HashSet::new();
        for u in &d.units {
            if u.name.trim().is_empty() || !unit_names.insert(u.name.as_str()) {
                return err(format!("unit `{}` is empty or defined twice", u.name));
            }
        }

        let mut names = HashMap::new();
        let mut by_vr: [Vec<(u32, usize)>; 4] = Default::default();
        let mut independents = 0;
        for (pos, v) in d.variables.iter_mut().enumerate() {
            let initial = check_variable(v).map_err(|m| DescriptionError(format!("variable `{}`: {m}", v.name)))?;
            v.initial = initial;
            if names.insert(v.name.clone(), pos).is_some() {
                return err(format!("variable name `{}` is used twice", v.name));
            }
            by_vr[type_slot(v.var_type)].push((v.value_reference, pos));
            if v.causality == Causality::Independent {
                independents += 1;
            }
            if let Some(unit) = &v.unit
                && !unit_names.contains(unit.as_str())
            {
                return err(format!("variable `{}`: unit `{unit}` is not defined in the unit definitions", v.name));
            }
        }
        if independents > 1 {
            return err("more than one variable has causality `independent`".into());
        }
        for (slot, list) in by_vr.iter_mut().enumerate() {
            list.sort_unstable();
            if let Some(w) = list.windows(2).find(|w| w[0].0 == w[1].0) {
                let kind = ["Real", "Integer", "Boolean", "String"][slot];
                return err(format!(
                    "{kind} value reference {} is used by both `{}` and `{}` (aliases are not supported)",
                    w[0].0, d.variables[w[0].1].name, d.variables[w[1].1].name
                ));
            }
        }
        if let Some(me) = &d.model_exchange {
            if !is_c_identifier(&me.model_identifier) {
                return err(format!("ModelExchange modelIdentifier `{}` is not a C identifier", me.model_identifier));
            }
            let real =
                |vr: u32| by_vr[0].binary_search_by_key(&vr, |&(r, _)| r).ok().map(|i| &d.variables[by_vr[0][i].1]);
            for s in &me.states {
                let (Some(x), Some(dx)) = (real(s.state), real(s.derivative)) else {
                    return err(format!(
                        "continuous state {} / derivative {}: no Real variable has that value reference",
                        s.state, s.derivative
                    ));
                };
                if dx.variability != Variability::Continuous || x.variability != Variability::Continuous {
                    return err(format!(
                        "continuous state `{}` and its derivative `{}` must be continuous",
                        x.name, dx.name
                    ));
                }
            }
            if me.event_indicator_variables.len() != me.event_indicators
                || me.event_indicator_variables.iter().any(|&vr| real(vr).is_none())
            {
                return err("every event indicator must be a Real variable, named once".into());
            }
        }
        // Dependencies: names → 1-based indices, and the names put in index order. In step mode
        // the knowns are the inputs; in initialization mode also the parameters (FMI 2.0, 2.2.8).
        let mut vars = Vec::with_capacity(d.variables.len());
        for pos in 0..d.variables.len() {
            let mut resolved = [None, None];
            for (slot, initial) in [false, true].into_iter().enumerate() {
                let v = &d.variables[pos];
                let Some(deps) = (if initial { &v.initial_depends_on } else { &v.depends_on }) else { continue };
                if v.causality != Causality::Output {
                    return err(format!("variable `{}`: only outputs may list dependencies", v.name));
                }
                let mut indices = Vec::with_capacity(deps.len());
                for name in deps {
                    let Some(&k) = names.get(name) else {
                        return err(format!("output `{}` depends on unknown variable `{name}`", v.name));
                    };
                    match d.variables[k].causality {
                        Causality::Input => indices.push(k + 1),
                        Causality::Parameter if initial => indices.push(k + 1),
                        _ => {
                            let allowed = if initial { "an input or a parameter" } else { "an input" };
                            return err(format!("output `{}` depends on `{name}`, which is not {allowed}", v.name));
                        }
                    }
                }
                indices.sort_unstable();
                indices.dedup();
                let ordered = indices.iter().map(|&i| d.variables[i - 1].name.clone()).collect();
                let v = &mut d.variables[pos];
                *(if initial { &mut v.initial_depends_on } else { &mut v.depends_on }) = Some(ordered);
                resolved[slot] = Some(indices);
            }
            let [dependencies, initial_dependencies] = resolved;
            vars.push(VarInfo { var: d.variables[pos].clone(), index: pos + 1, dependencies, initial_dependencies });
        }
        let direct = [0, 1, 2, 3].map(|slot| direct_table(&by_vr[slot]));
        Ok(ModelInfo { description: d, vars, by_vr, direct })
    }

    /// The variable of this type with this value reference.
    pub fn lookup(&self, t: VarType, vr: u32) -> Option<&VarInfo> {
        let slot = type_slot(t);
        let table = &self.direct[slot];
        if !table.is_empty() {
            return match table.get(vr as usize) {
                Some(&p) if p > 0 => Some(&self.vars[p as usize - 1]),
                _ => None,
            };
        }
        let list = &self.by_vr[slot];
        list.binary_search_by_key(&vr, |&(r, _)| r).ok().map(|i| &self.vars[list[i].1])
    }
}

/// The rules for one variable; returns its effective `initial`.
fn check_variable(v: &Variable) -> Result<Option<Initial>, String> {
    use Causality as C;
    use Initial as I;
    use Variability as V;
    check_structured_name(&v.name)?;
    let (c, var) = (v.causality, v.variability);
    let combination_ok = match var {
        V::Constant => matches!(c, C::Output | C::Local),
        V::Fixed | V::Tunable => matches!(c, C::Parameter | C::CalculatedParameter | C::Local),
        V::Discrete => matches!(c, C::Input | C::Output | C::Local),
        V::Continuous => matches!(c, C::Input | C::Output | C::Local | C::Independent),
    };
    if !combination_ok {
        return Err(format!("causality `{}` with variability `{}` is not allowed", c.as_str(), var.as_str()));
    }
    if var == V::Continuous && v.var_type != VarType::Real {
        return Err(format!("a {} variable cannot be continuous (only Real)", v.var_type.as_str()));
    }
    if c == C::Independent && v.var_type != VarType::Real {
        return Err("the independent variable must be Real".into());
    }
    if (v.min.is_some() || v.max.is_some()) && v.var_type != VarType::Real {
        return Err("min and max are declared for Real variables only".into());
    }
    if let (Some(lo), Some(hi)) = (v.min, v.max)
        && !(lo <= hi)
    {
        return Err(format!("min {lo} is above max {hi}"));
    }
    if let Some(crate::Value::Real(s)) = v.start
        && let Some(why) = v.outside_range(s)
    {
        return Err(format!("start {why}"));
    }
    // Allowed `initial` values and the default (FMI 2.0, table in section 2.2.7).
    let (allowed, default): (&[I], Option<I>) = match (c, var) {
        (C::Input | C::Independent, _) => (&[], None),
        (C::Parameter, _) => (&[I::Exact], Some(I::Exact)),
        (C::CalculatedParameter, _) => (&[I::Approx, I::Calculated], Some(I::Calculated)),
        (_, V::Constant) => (&[I::Exact], Some(I::Exact)),
        (C::Local, V::Fixed | V::Tunable) => (&[I::Calculated, I::Approx], Some(I::Calculated)),
        (C::Output | C::Local, _) => (&[I::Calculated, I::Exact, I::Approx], Some(I::Calculated)),
    };
    let initial = match v.initial {
        None => default,
        Some(i) if allowed.contains(&i) => Some(i),
        Some(i) => {
            return Err(format!(
                "initial `{}` is not allowed for causality `{}` with variability `{}`",
                i.as_str(),
                c.as_str(),
                var.as_str()
            ));
        }
    };
    let needs_start = c == C::Input || matches!(initial, Some(I::Exact | I::Approx));
    match (&v.start, needs_start) {
        (None, true) => return Err("a start value is required (input, or initial exact/approx)".into()),
        (Some(_), false) => {
            return Err("a start value is not allowed (initial calculated, or independent)".into());
        }
        _ => {}
    }
    if let Some(s) = &v.start {
        if s.var_type() != v.var_type {
            return Err(format!("start value {s:?} does not match type {}", v.var_type.as_str()));
        }
        if let Value::Real(x) = s
            && !x.is_finite()
        {
            return Err(format!("start value {x} is not finite"));
        }
    }
    if v.unit.is_some() && v.var_type != VarType::Real {
        return Err("only Real variables have units".into());
    }
    Ok(initial)
}

fn is_c_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `variableNamingConvention="structured"` (subset): `ident ('[' int (',' int)* ']')? ('.' ...)*`
/// with `ident = [A-Za-z_][A-Za-z0-9_]*` and array indices ≥ 1.
fn check_structured_name(name: &str) -> Result<(), String> {
    let bad = |why: &str| Err(format!("name `{name}` is not a structured name ({why})"));
    if name.is_empty() {
        return bad("empty");
    }
    for part in name.split('.') {
        let (ident, rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if !is_c_identifier(ident) {
            return bad("each part must start with a letter or `_` and contain only letters, digits and `_`");
        }
        if rest.is_empty() {
            continue;
        }
        let Some(inner) = rest.strip_prefix('[').and_then(|r| r.strip_suffix(']')) else {
            return bad("an array index must be `[n]` at the end of a part");
        };
        for idx in inner.split(',') {
            let ok = !idx.is_empty()
                && idx.chars().all(|c| c.is_ascii_digit())
                && !idx.starts_with('0')
                && idx.parse::<u32>().is_ok();
            if !ok {
                return bad("array indices are integers ≥ 1");
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{DefaultExperiment, Unit};

    /// A description with the variables and the SI units they use, no default experiment.
    fn desc(vars: Vec<Variable>) -> ModelDescription {
        let mut d = ModelDescription::co_simulation("t", "{g}", "", "1", CoSimulationFlags::EXPORTED, vars);
        d.default_experiment = None;
        d
    }

    fn check(v: Variable) -> Result<ModelInfo, String> {
        ModelInfo::new(desc(vec![v])).map_err(|e| e.0)
    }

    fn rejects(v: Variable, fragment: &str) {
        match check(v) {
            Ok(_) => panic!("accepted, expected an error containing `{fragment}`"),
            Err(m) => assert!(m.contains(fragment), "error `{m}` does not contain `{fragment}`"),
        }
    }

    #[test]
    fn legal_variables_are_accepted_with_default_initial() {
        let info = ModelInfo::new(desc(vec![
            Variable::real_input("u", 0, 0.0, "N"),
            Variable::real_output("y", 1, "m").depends_on(&["u"]),
            Variable::parameter("p", 2, 1.5, true),
            Variable::parameter("n", 0, 3, false),
            Variable::parameter("flag", 0, true, false),
            Variable::parameter("file", 0, "a.toml", false),
            Variable::new("cp", 3, VarType::Real, Causality::CalculatedParameter, Variability::Fixed),
            Variable::new("k", 4, VarType::Real, Causality::Output, Variability::Constant).start(2.0),
        ]))
        .unwrap();
        let initial = |i: usize| info.vars[i].var.initial;
        assert_eq!(initial(0), None);
        assert_eq!(initial(1), Some(Initial::Calculated));
        assert_eq!(info.vars[1].dependencies, Some(vec![1]));
        assert_eq!(initial(2), Some(Initial::Exact));
        assert_eq!(initial(6), Some(Initial::Calculated));
        assert_eq!(initial(7), Some(Initial::Exact));
        assert_eq!(info.description.variables[6].initial, Some(Initial::Calculated), "the description is normalized");
        assert_eq!(info.lookup(VarType::Integer, 0).unwrap().var.name, "n");
        assert_eq!(info.lookup(VarType::Real, 2).unwrap().var.name, "p");
        assert!(info.lookup(VarType::Real, 99).is_none());
        assert!(info.lookup(VarType::Boolean, 1).is_none());
        assert_eq!(info.description.units.iter().map(|u| u.name.as_str()).collect::<Vec<_>>(), ["N", "m"]);
    }

    #[test]
    fn lookup_by_table_and_by_search_agree() {
        // dense references get a direct table; a reference far beyond the variable count does not
        let dense: Vec<Variable> = (0..40).map(|k| Variable::real_input(format!("u{k}"), 2 * k, 0.0, "N")).collect();
        let mut sparse = dense.clone();
        sparse.push(Variable::real_input("far", 4_000_000_000, 0.0, "N"));
        for (vars, table) in [(dense, true), (sparse, false)] {
            let n = vars.len();
            let info = ModelInfo::new(desc(vars)).unwrap();
            assert_eq!(!info.direct[0].is_empty(), table);
            for k in 0..40u32 {
                assert_eq!(info.lookup(VarType::Real, 2 * k).unwrap().var.name, format!("u{k}"));
                assert!(info.lookup(VarType::Real, 2 * k + 1).is_none());
                assert!(info.lookup(VarType::Integer, 2 * k).is_none());
            }
            assert!(info.lookup(VarType::Real, 80).is_none());
            assert!(info.lookup(VarType::Real, u32::MAX).is_none());
            assert_eq!(info.lookup(VarType::Real, 4_000_000_000).is_some(), n == 41);
        }
    }

    #[test]
    fn illegal_causality_variability_combinations_are_rejected() {
        let r = VarType::Real;
        use Causality as C;
        use Variability as V;
        rejects(Variable::new("a", 0, r, C::Parameter, V::Continuous).start(1.0), "not allowed");
        rejects(Variable::new("a", 0, r, C::Parameter, V::Constant).start(1.0), "not allowed");
        rejects(Variable::new("a", 0, r, C::Input, V::Fixed).start(1.0), "not allowed");
        rejects(Variable::new("a", 0, r, C::Input, V::Constant).start(1.0), "not allowed");
        rejects(Variable::new("a", 0, r, C::Output, V::Tunable), "not allowed");
        rejects(Variable::new("a", 0, r, C::CalculatedParameter, V::Discrete), "not allowed");
        rejects(Variable::new("a", 0, r, C::Independent, V::Discrete), "not allowed");
    }

    #[test]
    fn only_real_variables_are_continuous() {
        rejects(
            Variable::new("a", 0, VarType::Integer, Causality::Input, Variability::Continuous).start(1),
            "cannot be continuous",
        );
        rejects(
            Variable::new("a", 0, VarType::Boolean, Causality::Output, Variability::Continuous),
            "cannot be continuous",
        );
    }

    #[test]
    fn illegal_initial_values_are_rejected() {
        rejects(Variable::real_input("u", 0, 0.0, "").initial(Initial::Exact), "initial `exact` is not allowed");
        rejects(Variable::parameter("p", 0, 1.0, false).initial(Initial::Calculated), "initial `calculated`");
        rejects(Variable::parameter("p", 0, 1.0, false).initial(Initial::Approx), "initial `approx`");
        let cp = Variable::new("c", 0, VarType::Real, Causality::CalculatedParameter, Variability::Fixed);
        rejects(cp.initial(Initial::Exact).start(1.0), "initial `exact`");
        let k = Variable::new("k", 0, VarType::Real, Causality::Local, Variability::Constant).start(1.0);
        rejects(k.initial(Initial::Calculated), "initial `calculated`");
    }

    #[test]
    fn start_values_exactly_where_required() {
        let input = Variable::new("u", 0, VarType::Real, Causality::Input, Variability::Continuous);
        rejects(input, "start value is required");
        rejects(Variable::new("p", 0, VarType::Real, Causality::Parameter, Variability::Fixed), "required");
        rejects(Variable::real_output("y", 0, "").start(1.0), "not allowed");
        let approx = Variable::real_output("y", 0, "").initial(Initial::Approx);
        rejects(approx.clone(), "required");
        assert!(check(approx.start(0.5)).is_ok());
        let t = Variable::new("time", 0, VarType::Real, Causality::Independent, Variability::Continuous);
        assert!(check(t.clone()).is_ok());
        rejects(t.start(0.0), "not allowed");
    }

    #[test]
    fn start_values_match_type_and_are_finite() {
        rejects(Variable::real_input("u", 0, f64::NAN, ""), "not finite");
        rejects(Variable::real_input("u", 0, 0.0, "").start(1), "does not match type Real");
    }

    #[test]
    fn units_must_be_defined_and_real() {
        rejects(Variable::real_input("u", 0, 0.0, "furlong"), "unit `furlong` is not defined");
        rejects(Variable::parameter("n", 0, 1, false).unit("m"), "only Real variables have units");
        let mut d = desc(vec![Variable::real_input("u", 0, 0.0, "furlong")]);
        d.units.push(Unit { name: "furlong".into(), base_unit: None });
        assert!(ModelInfo::new(d.clone()).is_ok());
        d.units.push(Unit { name: "furlong".into(), base_unit: None });
        assert!(ModelInfo::new(d).unwrap_err().0.contains("defined twice"));
    }

    #[test]
    fn names_and_value_references_are_unique_per_type() {
        let dup = desc(vec![Variable::real_input("u", 0, 0.0, ""), Variable::real_output("u", 1, "")]);
        assert!(ModelInfo::new(dup).unwrap_err().0.contains("used twice"));
        let vr = desc(vec![Variable::real_input("u", 7, 0.0, ""), Variable::real_output("y", 7, "")]);
        assert!(ModelInfo::new(vr).unwrap_err().0.contains("value reference 7"));
        let other_types = desc(vec![Variable::real_input("u", 7, 0.0, ""), Variable::parameter("n", 7, 1, false)]);
        assert!(ModelInfo::new(other_types).is_ok());
    }

    #[test]
    fn dependencies_name_inputs_of_outputs() {
        let bad = desc(vec![Variable::real_output("y", 0, "").depends_on(&["nope"])]);
        assert!(ModelInfo::new(bad).unwrap_err().0.contains("unknown variable `nope`"));
        let on_output =
            desc(vec![Variable::real_output("x", 0, ""), Variable::real_output("y", 1, "").depends_on(&["x"])]);
        assert!(ModelInfo::new(on_output).unwrap_err().0.contains("not an input"));
        let on_param = desc(vec![Variable::parameter("p", 0, 1.0, false).depends_on(&["p"])]);
        assert!(ModelInfo::new(on_param).unwrap_err().0.contains("only outputs"));
        let twice_unordered = desc(vec![
            Variable::real_input("a", 0, 0.0, ""),
            Variable::real_input("b", 1, 0.0, ""),
            Variable::real_output("y", 2, "").depends_on(&["b", "a", "b"]),
        ]);
        let info = ModelInfo::new(twice_unordered).unwrap();
        assert_eq!(info.vars[2].dependencies, Some(vec![1, 2]));
        assert_eq!(info.description.variables[2].depends_on, Some(vec!["a".to_owned(), "b".to_owned()]));
    }

    #[test]
    fn structured_names() {
        for ok in ["x", "cabin.r[1]", "wrench.f[3]", "a_b.c2[1,2].d", "_x"] {
            assert!(check_structured_name(ok).is_ok(), "{ok}");
        }
        for bad in ["", "1x", "a-b", "a.", ".a", "a[0]", "a[]", "a[1]b", "a b", "a[x]", "a..b", "a[01]"] {
            assert!(check_structured_name(bad).is_err(), "{bad}");
        }
        rejects(Variable::real_input("cable-1", 0, 0.0, ""), "not a structured name");
    }

    #[test]
    fn identity_rules() {
        let mut d = desc(vec![]);
        d.model_identifier = "my-model".into();
        assert!(ModelInfo::new(d).unwrap_err().0.contains("not a C identifier"));
        let mut d = desc(vec![]);
        d.guid = " ".into();
        assert!(ModelInfo::new(d).unwrap_err().0.contains("guid"));
        let mut d = desc(vec![]);
        d.default_experiment =
            Some(DefaultExperiment { start_time: Some(1.0), stop_time: Some(0.0), ..Default::default() });
        assert!(ModelInfo::new(d).unwrap_err().0.contains("DefaultExperiment"));
        let mut d = desc(vec![]);
        d.default_experiment = Some(DefaultExperiment { step_size: Some(0.0), ..Default::default() });
        assert!(ModelInfo::new(d).unwrap_err().0.contains("stepSize must be positive"));
        let mut d = desc(vec![]);
        d.fmi_version = "3.0".into();
        assert!(ModelInfo::new(d).unwrap_err().0.contains("fmiVersion"));
    }

    #[test]
    fn flags_the_layer_decides_cannot_be_changed() {
        let mut d = desc(vec![]);
        d.flags.provides_directional_derivative = true;
        d.flags.provides_step_map_derivative = true;
        assert!(ModelInfo::new(d.clone()).is_ok());
        d.flags.max_output_derivative_order = 1;
        assert!(ModelInfo::new(d).unwrap_err().0.contains("CoSimulationFlags::EXPORTED"));
    }

    #[test]
    fn settable_phases_follow_the_standard() {
        let info = ModelInfo::new(desc(vec![
            Variable::real_input("u", 0, 0.0, ""),
            Variable::parameter("fixed", 1, 1.0, false),
            Variable::parameter("tunable", 2, 1.0, true),
            Variable::real_output("y", 3, ""),
            Variable::real_output("ya", 4, "").initial(Initial::Approx).start(0.0),
        ]))
        .unwrap();
        let s = |i: usize, p| info.vars[i].settable_in(p);
        use SetPhase::*;
        assert!(s(0, Instantiated) && s(0, InitializationMode) && s(0, StepMode));
        assert!(s(1, Instantiated) && s(1, InitializationMode) && !s(1, StepMode));
        assert!(s(2, Instantiated) && s(2, InitializationMode) && s(2, StepMode));
        assert!(!s(3, Instantiated) && !s(3, InitializationMode) && !s(3, StepMode));
        assert!(s(4, Instantiated) && !s(4, InitializationMode) && !s(4, StepMode));
    }
}
