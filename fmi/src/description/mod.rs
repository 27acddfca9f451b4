//! What `modelDescription.xml` says, as plain data: one set of types for both directions. A
//! model builds a [`ModelDescription`] and the exporter writes it ([`crate::xml`]); the
//! importer reads any FMU's file into the same types. [`ModelInfo`] is the exporter's
//! validated, indexed view of a description.
//!
//! The subset held is what Co-Simulation needs: identity, the `<CoSimulation>` flags, unit
//! definitions (base units), the default experiment, the variables (type, causality,
//! variability, initial, start, unit) and the model structure as each output's dependencies.
//! Type definitions, display units, log categories and `<Derivatives>` are not kept.

mod validate;

pub(crate) use validate::SetPhase;
pub use validate::{DescriptionError, ModelInfo, VarInfo};

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

/// The base type of a variable (`Enumeration` variables are read as Integer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
}

/// A start value; its variant matches the variable's type.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// The spelling of each enum in the XML, both ways.
macro_rules! xml_names {
    ($ty:ty { $($variant:ident = $text:literal,)* }) => {
        impl $ty {
            /// As `modelDescription.xml` spells it.
            pub fn as_str(self) -> &'static str {
                match self { $(Self::$variant => $text,)* }
            }
            /// The value the XML spelling names.
            pub(crate) fn from_xml(text: &str) -> Option<Self> {
                match text { $($text => Some(Self::$variant),)* _ => None }
            }
        }
    };
}

xml_names!(Causality {
    Parameter = "parameter",
    CalculatedParameter = "calculatedParameter",
    Input = "input",
    Output = "output",
    Local = "local",
    Independent = "independent",
});
xml_names!(Variability {
    Constant = "constant",
    Fixed = "fixed",
    Tunable = "tunable",
    Discrete = "discrete",
    Continuous = "continuous",
});
xml_names!(Initial { Exact = "exact", Approx = "approx", Calculated = "calculated", });
xml_names!(VarType { Real = "Real", Integer = "Integer", Boolean = "Boolean", String = "String", });

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

/// The `start` attribute's text (unescaped): Reals in the shortest form that reads back to the
/// same number.
impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Real(x) => write!(f, "{x:?}"),
            Value::Integer(i) => write!(f, "{i}"),
            Value::Boolean(b) => write!(f, "{b}"),
            Value::String(s) => f.write_str(s),
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

/// One `<ScalarVariable>`.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// Structured name, e.g. `cabin.r[1]`.
    pub name: String,
    pub value_reference: u32,
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    /// As written; `None` where the attribute is absent (a model leaves it `None` for the
    /// standard's default, which the exporter writes out).
    pub initial: Option<Initial>,
    pub start: Option<Value>,
    /// A unit of [`ModelDescription::units`]; Real variables only.
    pub unit: Option<String>,
    /// The declared range `[min, max]` (Real only; either end may be absent): the exporter
    /// refuses a value set outside it.
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub description: String,
    /// Outputs: the inputs this output depends on at a communication point in step mode (direct
    /// feedthrough), by name, in `ModelVariables` order (`<ModelStructure><Outputs>`; `None`: on
    /// all knowns).
    pub depends_on: Option<Vec<String>>,
    /// Initial unknowns: the inputs and parameters this variable depends on in initialization
    /// mode, by name (`<ModelStructure><InitialUnknowns>`; `None`: on all knowns).
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
            min: None,
            max: None,
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

    /// The physical range of a Real variable: values set outside it are refused.
    pub fn range(mut self, min: f64, max: f64) -> Variable {
        (self.min, self.max) = (Some(min), Some(max));
        self
    }

    /// `None` if `x` lies in the declared range, else why not.
    #[inline]
    pub fn outside_range(&self, x: f64) -> Option<String> {
        let below = self.min.is_some_and(|m| x < m);
        let above = self.max.is_some_and(|m| x > m);
        (below || above).then(|| self.range_message(x))
    }

    #[cold]
    fn range_message(&self, x: f64) -> String {
        let end = |e: Option<f64>| e.map_or_else(String::new, |e| format!("{e:e}"));
        format!(
            "{x:e}: outside the declared range [{}, {}] (min/max in modelDescription.xml)",
            end(self.min),
            end(self.max)
        )
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

/// `name[1]`, …, `name[n]`: the scalar names of a vector variable.
pub fn indexed_names(name: &str, n: usize) -> impl Iterator<Item = String> + '_ {
    (1..=n).map(move |k| format!("{name}[{k}]"))
}

/// `<Unit>`: a name and, if given, its `<BaseUnit>`.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    pub name: String,
    pub base_unit: Option<BaseUnit>,
}

/// `<BaseUnit>`: value in SI = factor · value + offset, with these SI base-unit exponents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseUnit {
    /// Exponents of kg, m, s, A, K, mol, cd, rad.
    pub exponents: [i32; 8],
    pub factor: f64,
    pub offset: f64,
}

/// Names of the base units in the order of [`BaseUnit::exponents`], as the XML attributes spell them.
pub(crate) const BASE_UNIT_NAMES: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

/// Units [`ModelDescription::co_simulation`] defines for the variables that use them:
/// (name, [kg, m, s, A, K, mol, cd, rad]).
const SI_UNITS: &[(&str, [i32; 8])] = &[
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

impl Unit {
    /// The SI unit of this name (factor 1, offset 0), if it is one [`ModelDescription::co_simulation`] knows.
    pub(crate) fn si(name: &str) -> Option<Unit> {
        SI_UNITS.iter().find(|(n, _)| *n == name).map(|(n, exponents)| Unit {
            name: (*n).to_owned(),
            base_unit: Some(BaseUnit { exponents: *exponents, factor: 1.0, offset: 0.0 }),
        })
    }
}

/// `<DefaultExperiment>`; absent attributes are `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub step_size: Option<f64>,
    pub tolerance: Option<f64>,
}

/// The attributes of `<CoSimulation>`, and this workspace's extension announced in
/// `<VendorAnnotations>`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoSimulationFlags {
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_not_use_memory_management_functions: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    /// This workspace's opt-in extension `feedsimGetStepMapDerivative`, announced by
    /// `<VendorAnnotations><Tool name="feedsim"><StepMapDerivative/>`. An importer counts it
    /// only where the binary also exports the function.
    pub provides_step_map_derivative: bool,
}

impl CoSimulationFlags {
    /// What the export layer provides for every model: variable communication step sizes,
    /// get/set/serialize FMU state, no memory callbacks. A model adds its optional capabilities:
    /// `CoSimulationFlags { provides_directional_derivative: true, ..CoSimulationFlags::EXPORTED }`.
    pub const EXPORTED: CoSimulationFlags = CoSimulationFlags {
        needs_execution_tool: false,
        can_handle_variable_communication_step_size: true,
        can_interpolate_inputs: false,
        max_output_derivative_order: 0,
        can_run_asynchronuously: false,
        can_be_instantiated_only_once_per_process: false,
        can_not_use_memory_management_functions: true,
        can_get_and_set_fmu_state: true,
        can_serialize_fmu_state: true,
        provides_directional_derivative: false,
        provides_step_map_derivative: false,
    };

    /// [`CoSimulationFlags::EXPORTED`] with every optional capability the layer passes on:
    /// directional derivatives, first-order input interpolation and the step-map extension.
    pub const EXPORTED_WITH_DERIVATIVES: CoSimulationFlags = CoSimulationFlags {
        provides_directional_derivative: true,
        can_interpolate_inputs: true,
        provides_step_map_derivative: true,
        ..CoSimulationFlags::EXPORTED
    };
}

/// A continuous state of a Model Exchange FMU and its derivative, by value reference (Real).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContinuousState {
    pub state: u32,
    pub derivative: u32,
}

/// `<ModelExchange>`: what an importer that integrates the FMU needs besides the variables.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelExchange {
    /// The binary's name for this interface (may differ from Co-Simulation's).
    pub model_identifier: String,
    /// `fmi2CompletedIntegratorStep` / `fmi3CompletedIntegratorStep` must be called after every
    /// accepted integrator step (FMI 2.0: `completedIntegratorStepNotNeeded = false`).
    pub needs_completed_integrator_step: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    /// The continuous states in the order of the state vector (FMI 2.0: `<Derivatives>`;
    /// FMI 3.0: `<ContinuousStateDerivative>`).
    pub states: Vec<ContinuousState>,
    /// The number of event indicators.
    pub event_indicators: usize,
    /// The Real variables that are the event indicators, in order (FMI 3.0 names them,
    /// `<EventIndicator>`; FMI 2.0 gives only their number, and this is empty when read).
    pub event_indicator_variables: Vec<u32>,
}

impl ModelExchange {
    /// An exported model's interface with the layer's capabilities: get/set/serialize FMU state,
    /// completed integrator steps not needed.
    pub fn exported(model_identifier: &str, states: Vec<ContinuousState>, event_indicators: Vec<u32>) -> ModelExchange {
        ModelExchange {
            model_identifier: model_identifier.to_owned(),
            needs_completed_integrator_step: false,
            can_get_and_set_fmu_state: true,
            can_serialize_fmu_state: true,
            provides_directional_derivative: false,
            states,
            event_indicators: event_indicators.len(),
            event_indicator_variables: event_indicators,
        }
    }

    /// The capabilities as the importer's flags of the interface in use.
    pub fn flags(&self) -> CoSimulationFlags {
        CoSimulationFlags {
            can_get_and_set_fmu_state: self.can_get_and_set_fmu_state,
            can_serialize_fmu_state: self.can_serialize_fmu_state,
            provides_directional_derivative: self.provides_directional_derivative,
            ..CoSimulationFlags::default()
        }
    }
}

/// Everything this workspace reads from or writes to `modelDescription.xml`.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelDescription {
    /// `2.0` (or `2.0.x` in a file read).
    pub fmi_version: String,
    pub model_name: String,
    /// Identifies this interface; change it whenever the variable table changes.
    pub guid: String,
    pub description: String,
    pub version: String,
    /// C identifier: the name of the shared library and of `CoSimulation@modelIdentifier` (of
    /// `ModelExchange@modelIdentifier` for an FMU without Co-Simulation, or one an importer
    /// loaded as Model Exchange).
    pub model_identifier: String,
    /// The capabilities of `<CoSimulation>` (of the interface in use, for an importer).
    pub flags: CoSimulationFlags,
    /// The FMU offers Co-Simulation (`<CoSimulation>`).
    pub co_simulation: bool,
    /// `<ModelExchange>`, if the FMU offers it.
    pub model_exchange: Option<ModelExchange>,
    /// `<UnitDefinitions>`.
    pub units: Vec<Unit>,
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<Variable>,
}

impl ModelDescription {
    /// An exported Co-Simulation description with this workspace's defaults: model name =
    /// identifier, default experiment 0 … 100 s at 0.01 s, the SI units the variables use.
    pub fn co_simulation(
        identifier: &str,
        guid: &str,
        description: &str,
        version: &str,
        flags: CoSimulationFlags,
        variables: Vec<Variable>,
    ) -> ModelDescription {
        let mut units: Vec<Unit> = Vec::new();
        for name in variables.iter().filter_map(|v| v.unit.as_deref()) {
            if let Some(u) = Unit::si(name).filter(|_| units.iter().all(|u| u.name != name)) {
                units.push(u);
            }
        }
        ModelDescription {
            fmi_version: "2.0".into(),
            model_name: identifier.into(),
            guid: guid.into(),
            description: description.into(),
            version: version.into(),
            model_identifier: identifier.into(),
            flags,
            co_simulation: true,
            model_exchange: None,
            units,
            default_experiment: Some(DefaultExperiment {
                start_time: Some(0.0),
                stop_time: Some(100.0),
                step_size: Some(0.01),
                tolerance: None,
            }),
            variables,
        }
    }

    /// The variable with this name.
    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.variables.iter().find(|v| v.name == name)
    }
}
