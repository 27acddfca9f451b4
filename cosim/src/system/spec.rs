//! A system description independent of where it came from (a scene's `[system]` table, an SSP
//! 1.0 `.ssd`): components, connections and parameter values, by name.

use std::path::PathBuf;

/// One FMU of the system.
#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    /// Name used in connections and in output names (`component.variable`).
    pub name: String,
    /// The `.fmu` archive, or a directory holding an unpacked FMU.
    pub source: PathBuf,
    /// The interface to run it as (`None`: Co-Simulation where the FMU offers it, else Model
    /// Exchange).
    pub interface: Option<fmi::import::Interface>,
}

/// A variable of a component.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Endpoint {
    pub component: String,
    pub variable: String,
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}", self.component, self.variable)
    }
}

/// How a connection names its variables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Matching {
    /// One output to one input, by their full names.
    Exact,
    /// Every output whose name starts with `from.variable` (followed by `.`, `[` or nothing)
    /// feeds the input of `to` with `to.variable` and the same suffix (the scene's `[system]`).
    Prefix,
}

/// What follows `prefix` in `name` if `prefix` names it whole or as a prefix ending before a
/// `.` or `[` (`cabin.r` for `cabin.r[1]`, `cabin` for `cabin.r[1]`, not `cab`): how
/// [`Matching::Prefix`] connections and the adaptive step's watched names match variables.
pub(crate) fn prefix_rest<'a>(name: &'a str, prefix: &str) -> Option<&'a str> {
    name.strip_prefix(prefix).filter(|rest| rest.is_empty() || rest.starts_with('.') || rest.starts_with('['))
}

/// `input = factor · output + offset` (SSP `LinearTransformation`, or a unit conversion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linear {
    pub factor: f64,
    pub offset: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Connection {
    pub from: Endpoint,
    pub to: Endpoint,
    pub matching: Matching,
    /// Only for Real connections.
    pub transform: Option<Linear>,
}

/// A parameter value: typed (SSP), or text converted to the variable's type (scene).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Typed(fmi::Value),
    Text(String),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Typed(fmi::Value::String(x)) | Value::Text(x) => write!(f, "\"{x}\""),
            Value::Typed(v) => write!(f, "{v}"),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    pub target: Endpoint,
    pub value: Value,
}

/// A variable as the description declares it (an SSP connector), checked against the FMU.
#[derive(Clone, Debug, PartialEq)]
pub struct Connector {
    pub endpoint: Endpoint,
    pub var_type: fmi::VarType,
    pub unit: Option<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SystemSpec {
    /// Where the description came from, for messages (a file, `scene.toml [system]`).
    pub origin: String,
    pub components: Vec<Component>,
    pub connections: Vec<Connection>,
    /// Applied in order before initialization.
    pub parameters: Vec<Parameter>,
    /// Declared variables to check (may be empty).
    pub connectors: Vec<Connector>,
    /// Real outputs read after every step besides the connected ones (`component.variable`, or
    /// a prefix ending before a `.` or `[`), e.g. a state the adaptive step is to watch; a name
    /// that is no output of its component is left to [`crate::Coupled::watch`] to judge.
    pub observed: Vec<String>,
    /// What an adaptive step should watch unless told otherwise, as the description suggests
    /// (names or prefixes; from the SSP annotation [`crate::ssp::ADAPTIVE_ANNOTATION`]).
    pub watch: Vec<String>,
    /// The motion starts with a kink the units were not initialized for (from the SSP annotation
    /// [`crate::ssp::START_ANNOTATION`]): the first macro step is taken in substeps.
    pub kink_at_start: bool,
}
