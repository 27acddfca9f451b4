//! The static description of an exported model: identity, capabilities and the variable table.
//!
//! A model writes a [`ModelDescription`] (plain data, built with small helpers); [`ModelInfo::new`]
//! validates it against the FMI 2.0 rules and indexes it. The C layer and the XML writer both use
//! the validated [`ModelInfo`], so `modelDescription.xml` and the code cannot disagree.

use std::collections::HashSet;
use std::fmt;

/// `causality` of a variable (FMI 2.0, 2.2.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// `variability` of a variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

/// `initial` of a variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// The base type of a variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
}

/// A start value; its variant must match the variable's type.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

impl Value {
    pub fn var_type(&self) -> VarType {
        match self {
            Value::Real(_) => VarType::Real,
            Value::Integer(_) => VarType::Integer,
            Value::Boolean(_) => VarType::Boolean,
            Value::String(_) => VarType::String,
        }
    }
}

impl From<f64> for Value {
    fn from(v: f64) -> Value {
        Value::Real(v)
    }
}
impl From<i32> for Value {
    fn from(v: i32) -> Value {
        Value::Integer(v)
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Value {
        Value::Boolean(v)
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Value {
        Value::String(v.to_owned())
    }
}

impl Causality {
    pub fn as_str(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
            Causality::Independent => "independent",
        }
    }
}

impl Variability {
    pub fn as_str(self) -> &'static str {
        match self {
            Variability::Constant => "constant",
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

impl Initial {
    pub fn as_str(self) -> &'static str {
        match self {
            Initial::Exact => "exact",
            Initial::Approx => "approx",
            Initial::Calculated => "calculated",
        }
    }
}

impl VarType {
    pub fn as_str(self) -> &'static str {
        match self {
            VarType::Real => "Real",
            VarType::Integer => "Integer",
            VarType::Boolean => "Boolean",
            VarType::String => "String",
        }
    }
}

/// One row of the variable table.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// Structured name, e.g. `cabin.r[1]`.
    pub name: String,
    pub value_reference: u32,
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    /// `None`: the standard's default for this causality/variability.
    pub initial: Option<Initial>,
    pub start: Option<Value>,
    /// A unit name from [`SI_UNITS`] or [`ModelDescription::extra_units`]; Real variables only.
    pub unit: Option<String>,
    pub description: String,
    /// Outputs only: names of the inputs the output depends on at a communication point in step
    /// mode (direct feedthrough; `None`: on all knowns). Written to `<ModelStructure><Outputs>`.
    pub depends_on: Option<Vec<String>>,
    /// Outputs only: names of the inputs and parameters the output depends on in initialization
    /// mode (`None`: on all knowns). Written to `<ModelStructure><InitialUnknowns>`.
    pub initial_depends_on: Option<Vec<String>>,
}

impl Variable {
    /// A Real input with its start value.
    pub fn real_input(name: impl Into<String>, vr: u32, start: f64, unit: &str) -> Variable {
        Variable::new(name, vr, VarType::Real, Causality::Input, Variability::Continuous).start(start).unit(unit)
    }

    /// A continuous Real output computed by the model (`initial = calculated`).
    pub fn real_output(name: impl Into<String>, vr: u32, unit: &str) -> Variable {
        Variable::new(name, vr, VarType::Real, Causality::Output, Variability::Continuous).unit(unit)
    }

    /// A parameter of any type (`fixed`: set before initialization ends; `tunable`: also between steps).
    pub fn parameter(name: impl Into<String>, vr: u32, start: impl Into<Value>, tunable: bool) -> Variable {
        let start = start.into();
        let variability = if tunable { Variability::Tunable } else { Variability::Fixed };
        Variable::new(name, vr, start.var_type(), Causality::Parameter, variability).start(start)
    }

    pub fn new(
        name: impl Into<String>,
        vr: u32,
        var_type: VarType,
        causality: Causality,
        variability: Variability,
    ) -> Variable {
        Variable {
            name: name.into(),
            value_reference: vr,
            var_type,
            causality,
            variability,
            initial: None,
            start: None,
            unit: None,
            description: String::new(),
            depends_on: None,
            initial_depends_on: None,
        }
    }

    pub fn start(mut self, v: impl Into<Value>) -> Variable {
        self.start = Some(v.into());
        self
    }

    pub fn unit(mut self, unit: &str) -> Variable {
        self.unit = if unit.is_empty() { None } else { Some(unit.to_owned()) };
        self
    }

    pub fn initial(mut self, initial: Initial) -> Variable {
        self.initial = Some(initial);
        self
    }

    pub fn describe(mut self, text: impl Into<String>) -> Variable {
        self.description = text.into();
        self
    }

    /// The inputs this output depends on at a communication point in step mode.
    pub fn depends_on<S: AsRef<str>>(mut self, inputs: &[S]) -> Variable {
        self.depends_on = Some(inputs.iter().map(|s| s.as_ref().to_owned()).collect());
        self
    }

    /// The inputs and parameters this output depends on in initialization mode.
    pub fn initially_depends_on<S: AsRef<str>>(mut self, knowns: &[S]) -> Variable {
        self.initial_depends_on = Some(knowns.iter().map(|s| s.as_ref().to_owned()).collect());
        self
    }
}

/// A unit with its SI base-unit exponents (kg, m, s, A, K, mol, cd, rad), factor 1, offset 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    pub name: String,
    pub exponents: [i32; 8],
}

/// Names of the base units in the order of [`Unit::exponents`], as the XML attributes spell them.
pub const BASE_UNIT_NAMES: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

/// Units every model may use without declaring them: (name, [kg, m, s, A, K, mol, cd, rad]).
pub const SI_UNITS: &[(&str, [i32; 8])] = &[
    ("kg", [1, 0, 0, 0, 0, 0, 0, 0]),
    ("m", [0, 1, 0, 0, 0, 0, 0, 0]),
    ("s", [0, 0, 1, 0, 0, 0, 0, 0]),
    ("rad", [0, 0, 0, 0, 0, 0, 0, 1]),
    ("m/s", [0, 1, -1, 0, 0, 0, 0, 0]),
    ("m/s2", [0, 1, -2, 0, 0, 0, 0, 0]),
    ("rad/s", [0, 0, -1, 0, 0, 0, 0, 1]),
    ("rad/s2", [0, 0, -2, 0, 0, 0, 0, 1]),
    ("Hz", [0, 0, -1, 0, 0, 0, 0, 0]),
    ("N", [1, 1, -2, 0, 0, 0, 0, 0]),
    ("N.m", [1, 2, -2, 0, 0, 0, 0, 0]),
    ("N/m", [1, 0, -2, 0, 0, 0, 0, 0]),
    ("N.s/m", [1, 0, -1, 0, 0, 0, 0, 0]),
    ("N.m/rad", [1, 2, -2, 0, 0, 0, 0, -1]),
    ("kg.m2", [1, 2, 0, 0, 0, 0, 0, 0]),
    ("kg/m", [1, -1, 0, 0, 0, 0, 0, 0]),
    ("Pa", [1, -1, -2, 0, 0, 0, 0, 0]),
    ("J", [1, 2, -2, 0, 0, 0, 0, 0]),
    ("W", [1, 2, -3, 0, 0, 0, 0, 0]),
];

/// `<DefaultExperiment>`.
#[derive(Clone, Debug, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
    pub tolerance: Option<f64>,
}

/// The optional capabilities a model implements. The layer always provides variable
/// communication step sizes and get/set/serialize FMU state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Capabilities {
    /// `providesDirectionalDerivative`: the model implements [`crate::export::Model::directional_derivative`].
    pub provides_directional_derivative: bool,
    /// `canInterpolateInputs`: the model implements first-order [`crate::export::Model::set_real_input_derivative`].
    pub can_interpolate_inputs: bool,
    /// The opt-in extension of this workspace: the model implements
    /// [`crate::export::Model::step_map_derivative`], exported as `feedsimGetStepMapDerivative` and
    /// announced by `<VendorAnnotations><Tool name="feedsim"><StepMapDerivative/>`.
    pub provides_step_map_derivative: bool,
}

/// Everything `modelDescription.xml` says, as the model declares it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelDescription {
    pub model_name: String,
    /// C identifier: the name of the shared library and of `CoSimulation@modelIdentifier`.
    pub model_identifier: String,
    /// Identifies this interface; change it whenever the variable table changes.
    pub guid: String,
    pub description: String,
    pub version: String,
    pub capabilities: Capabilities,
    pub default_experiment: Option<DefaultExperiment>,
    /// Units beyond [`SI_UNITS`].
    pub extra_units: Vec<Unit>,
    pub variables: Vec<Variable>,
}

impl ModelDescription {
    /// A Co-Simulation description with this workspace's defaults: model name = identifier,
    /// default experiment 0 … 100 s at 0.01 s, SI units only.
    pub fn co_simulation(
        identifier: &str,
        guid: &str,
        description: &str,
        version: &str,
        capabilities: Capabilities,
        variables: Vec<Variable>,
    ) -> ModelDescription {
        ModelDescription {
            model_name: identifier.into(),
            model_identifier: identifier.into(),
            guid: guid.into(),
            description: description.into(),
            version: version.into(),
            capabilities,
            default_experiment: Some(DefaultExperiment {
                start_time: 0.0,
                stop_time: 100.0,
                step_size: 0.01,
                tolerance: None,
            }),
            extra_units: vec![],
            variables,
        }
    }
}

/// The log categories every exported FMU declares (name, description).
pub const LOG_CATEGORIES: [(&str, &str); 3] = [
    (
        "logError",
        "Errors: calls in the wrong state, unknown value references, invalid values, model failures; and why a step was discarded",
    ),
    ("logInfo", "Informational messages: instantiation, mode changes"),
    ("logAll", "All of the above"),
];

/// A rule of the standard that the description breaks.
#[derive(Clone, Debug, PartialEq)]
pub struct DescriptionError(pub String);

impl fmt::Display for DescriptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid model description: {}", self.0)
    }
}

impl std::error::Error for DescriptionError {}

/// A validated variable: the declared row plus the effective `initial`, its 1-based index in
/// `ModelVariables`, and its resolved output dependencies (1-based indices).
#[derive(Clone, Debug)]
pub struct VarInfo {
    pub var: Variable,
    /// `None` for inputs and the independent variable (the attribute is not allowed there).
    pub initial: Option<Initial>,
    pub index: usize,
    pub dependencies: Option<Vec<usize>>,
    /// Resolved initialization-mode dependencies (1-based indices).
    pub initial_dependencies: Option<Vec<usize>>,
}

impl VarInfo {
    /// May `fmi2Set*` change this variable in the given phase? (FMI 2.0 CS state table.)
    pub fn settable_in(&self, phase: SetPhase) -> bool {
        let v = &self.var;
        if v.variability == Variability::Constant {
            return false;
        }
        let input = v.causality == Causality::Input;
        match phase {
            SetPhase::Instantiated => input || matches!(self.initial, Some(Initial::Exact | Initial::Approx)),
            SetPhase::InitializationMode => input || self.initial == Some(Initial::Exact),
            SetPhase::StepMode => {
                input || (v.causality == Causality::Parameter && v.variability == Variability::Tunable)
            }
        }
    }
}

/// The phases in which `fmi2Set*` is allowed at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetPhase {
    Instantiated,
    InitializationMode,
    StepMode,
}

/// A validated, indexed model description.
#[derive(Clone, Debug)]
pub struct ModelInfo {
    pub description: ModelDescription,
    pub vars: Vec<VarInfo>,
    /// Units used by some variable, in first-use order.
    pub units: Vec<Unit>,
    /// Per type (Real, Integer, Boolean, String): (value reference, position in `vars`), sorted.
    by_vr: [Vec<(u32, usize)>; 4],
}

fn type_slot(t: VarType) -> usize {
    match t {
        VarType::Real => 0,
        VarType::Integer => 1,
        VarType::Boolean => 2,
        VarType::String => 3,
    }
}

impl ModelInfo {
    /// Check every rule of the standard the layer relies on; index the table.
    pub fn new(description: ModelDescription) -> Result<ModelInfo, DescriptionError> {
        let d = &description;
        let err = |msg: String| Err(DescriptionError(msg));
        if d.model_name.trim().is_empty() {
            return err("`modelName` is empty".into());
        }
        if !is_c_identifier(&d.model_identifier) {
            return err(format!("modelIdentifier `{}` is not a C identifier", d.model_identifier));
        }
        if d.guid.trim().is_empty() {
            return err("`guid` is empty".into());
        }
        if let Some(e) = &d.default_experiment {
            let finite = e.start_time.is_finite() && e.stop_time.is_finite() && e.step_size.is_finite();
            if !finite || e.stop_time <= e.start_time || e.step_size <= 0.0 {
                return err(format!(
                    "DefaultExperiment needs finite startTime < stopTime and stepSize > 0, got {} .. {}, step {}",
                    e.start_time, e.stop_time, e.step_size
                ));
            }
            if let Some(t) = e.tolerance
                && !(t.is_finite() && t > 0.0)
            {
                return err(format!("DefaultExperiment tolerance must be positive, got {t}"));
            }
        }
        for u in &d.extra_units {
            if u.name.trim().is_empty() || SI_UNITS.iter().any(|(n, _)| *n == u.name) {
                return err(format!("extra unit `{}` is empty or redefines a built-in unit", u.name));
            }
        }

        let mut names = HashSet::new();
        let mut by_vr: [Vec<(u32, usize)>; 4] = Default::default();
        let mut vars = Vec::with_capacity(d.variables.len());
        let mut units: Vec<Unit> = Vec::new();
        let mut independents = 0;
        for (pos, v) in d.variables.iter().enumerate() {
            let initial = check_variable(v).map_err(|m| DescriptionError(format!("variable `{}`: {m}", v.name)))?;
            if !names.insert(v.name.as_str()) {
                return err(format!("variable name `{}` is used twice", v.name));
            }
            by_vr[type_slot(v.var_type)].push((v.value_reference, pos));
            if v.causality == Causality::Independent {
                independents += 1;
            }
            if let Some(unit) = &v.unit {
                let found = SI_UNITS
                    .iter()
                    .find(|(n, _)| n == unit)
                    .map(|(n, e)| Unit { name: (*n).to_owned(), exponents: *e })
                    .or_else(|| d.extra_units.iter().find(|u| &u.name == unit).cloned());
                match found {
                    Some(u) => {
                        if !units.iter().any(|x| x.name == u.name) {
                            units.push(u)
                        }
                    }
                    None => return err(format!("variable `{}`: unit `{unit}` is not defined", v.name)),
                }
            }
            vars.push(VarInfo {
                var: v.clone(),
                initial,
                index: pos + 1,
                dependencies: None,
                initial_dependencies: None,
            });
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
        // Output dependencies: names → 1-based indices. In step mode the knowns are the inputs;
        // in initialization mode also the parameters (FMI 2.0, 2.2.8).
        for i in 0..vars.len() {
            for initial in [false, true] {
                let v = &vars[i].var;
                let Some(deps) = (if initial { &v.initial_depends_on } else { &v.depends_on }) else { continue };
                if v.causality != Causality::Output {
                    return err(format!("variable `{}`: only outputs may list dependencies", v.name));
                }
                let mut indices = Vec::with_capacity(deps.len());
                for name in deps {
                    match vars.iter().find(|x| &x.var.name == name) {
                        Some(x) if x.var.causality == Causality::Input => indices.push(x.index),
                        Some(x) if initial && x.var.causality == Causality::Parameter => indices.push(x.index),
                        Some(_) => {
                            let allowed = if initial { "an input or a parameter" } else { "an input" };
                            return err(format!("output `{}` depends on `{name}`, which is not {allowed}", v.name));
                        }
                        None => {
                            return err(format!("output `{}` depends on unknown variable `{name}`", v.name));
                        }
                    }
                }
                indices.sort_unstable();
                indices.dedup();
                if initial {
                    vars[i].initial_dependencies = Some(indices);
                } else {
                    vars[i].dependencies = Some(indices);
                }
            }
        }
        Ok(ModelInfo { description, vars, units, by_vr })
    }

    /// The variable of this type with this value reference.
    pub fn lookup(&self, t: VarType, vr: u32) -> Option<&VarInfo> {
        let list = &self.by_vr[type_slot(t)];
        list.binary_search_by_key(&vr, |&(r, _)| r).ok().map(|i| &self.vars[list[i].1])
    }

    pub fn by_name(&self, name: &str) -> Option<&VarInfo> {
        self.vars.iter().find(|v| v.var.name == name)
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
pub fn check_structured_name(name: &str) -> Result<(), String> {
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

    fn desc(vars: Vec<Variable>) -> ModelDescription {
        ModelDescription {
            model_name: "t".into(),
            model_identifier: "t".into(),
            guid: "{g}".into(),
            description: String::new(),
            version: "1".into(),
            capabilities: Capabilities::default(),
            default_experiment: None,
            extra_units: vec![],
            variables: vars,
        }
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
        assert_eq!(info.vars[0].initial, None);
        assert_eq!(info.vars[1].initial, Some(Initial::Calculated));
        assert_eq!(info.vars[1].dependencies, Some(vec![1]));
        assert_eq!(info.vars[2].initial, Some(Initial::Exact));
        assert_eq!(info.vars[6].initial, Some(Initial::Calculated));
        assert_eq!(info.vars[7].initial, Some(Initial::Exact));
        assert_eq!(info.lookup(VarType::Integer, 0).unwrap().var.name, "n");
        assert_eq!(info.lookup(VarType::Real, 2).unwrap().var.name, "p");
        assert!(info.lookup(VarType::Real, 99).is_none());
        assert_eq!(info.units.iter().map(|u| u.name.as_str()).collect::<Vec<_>>(), ["N", "m"]);
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
        d.extra_units.push(Unit { name: "furlong".into(), exponents: [0, 1, 0, 0, 0, 0, 0, 0] });
        assert_eq!(ModelInfo::new(d).unwrap().units[0].name, "furlong");
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
            Some(DefaultExperiment { start_time: 1.0, stop_time: 0.0, step_size: 0.1, tolerance: None });
        assert!(ModelInfo::new(d).unwrap_err().0.contains("DefaultExperiment"));
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
