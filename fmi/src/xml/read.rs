//! Reading the `modelDescription.xml` of any FMI 2.0 Co-Simulation FMU into the types the
//! exporter writes from.

use roxmltree::{Document, Node};

use super::{STEP_MAP_ANNOTATION, VENDOR_TOOL};
use crate::description::{
    BASE_UNIT_NAMES, BaseUnit, Causality, CoSimulationFlags, ContinuousState, DefaultExperiment, Initial,
    ModelDescription, ModelExchange, Unit, Value, VarType, Variability, Variable,
};

/// What is wrong with a `modelDescription.xml`, and where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ReadError {
    /// Says what and where (line:column).
    pub message: String,
}

pub(crate) fn fail<T>(message: String) -> Result<T, ReadError> {
    Err(ReadError { message })
}

/// Where a node starts, `line L:C`.
pub(crate) fn at(n: Node) -> String {
    let p = n.document().text_pos_at(n.range().start);
    format!("line {}:{}", p.row, p.col)
}

/// An attribute parsed by `parse`, or `None` where absent; an error names element, place and value.
pub(crate) fn attr<T>(
    n: Node,
    name: &str,
    what: &str,
    parse: impl Fn(&str) -> Option<T>,
) -> Result<Option<T>, ReadError> {
    match n.attribute(name) {
        None => Ok(None),
        Some(v) => match parse(v.trim()) {
            Some(x) => Ok(Some(x)),
            None => fail(format!("<{}> at {}: `{name}` = `{v}` is not {what}", n.tag_name().name(), at(n))),
        },
    }
}

pub(crate) fn required(n: Node, name: &str) -> Result<String, ReadError> {
    match n.attribute(name) {
        Some(v) => Ok(v.to_owned()),
        None => fail(format!("<{}> at {} has no `{name}` attribute", n.tag_name().name(), at(n))),
    }
}

pub(crate) fn boolean(v: &str) -> Option<bool> {
    match v {
        "true" | "1" => Some(true),
        "false" | "0" => Some(false),
        _ => None,
    }
}

pub(crate) fn real(v: &str) -> Option<f64> {
    v.parse().ok()
}

/// Parse the text of a `modelDescription.xml`. Errors say what is wrong and where (line:column).
pub fn parse_model_description(text: &str) -> Result<ModelDescription, ReadError> {
    read_model_description(&parse_document(text)?)
}

/// The XML document of a description's text.
pub(crate) fn parse_document(text: &str) -> Result<Document<'_>, ReadError> {
    Document::parse(text).map_err(|e| ReadError { message: format!("not well-formed XML: {e}") })
}

/// What FMI 2.0 and 3.0 descriptions hold alike, read in the same order: the root element and its
/// attributes, the interfaces (the Co-Simulation flags read by the version's `flags`), units, the
/// default experiment and where `<ModelVariables>` is.
pub(crate) struct Common<'a, 'input> {
    pub(crate) root: Node<'a, 'input>,
    pub(crate) me_node: Option<Node<'a, 'input>>,
    pub(crate) model_variables: Node<'a, 'input>,
    /// Without variables and Model Exchange part.
    description: ModelDescription,
}

/// Reads the [`Common`] part of a description: `version` refuses an `fmiVersion` of another
/// version (with the message why), `guid` names the GUID's attribute, `flags` reads the
/// Co-Simulation flags from the root and `<CoSimulation>` (if the FMU offers it).
pub(crate) fn read_common<'a, 'input>(
    doc: &'a Document<'input>,
    version: impl Fn(&str) -> Result<(), String>,
    guid: &str,
    flags: impl FnOnce(Node, Node) -> Result<CoSimulationFlags, ReadError>,
) -> Result<Common<'a, 'input>, ReadError> {
    let root = doc.root_element();
    if root.tag_name().name() != "fmiModelDescription" {
        return fail(format!("root element is <{}>, expected <fmiModelDescription>", root.tag_name().name()));
    }
    let fmi_version = root.attribute("fmiVersion").unwrap_or("").to_owned();
    version(&fmi_version).map_err(|message| ReadError { message })?;
    let model_name = required(root, "modelName")?;
    let guid = required(root, guid)?;
    let child = |name: &str| root.children().find(|c| c.has_tag_name(name));
    let (cs_node, me_node) = (child("CoSimulation"), child("ModelExchange"));
    let Some(interface) = cs_node.or(me_node) else {
        return fail("neither <CoSimulation> nor <ModelExchange>: the FMU offers no interface".into());
    };
    let model_identifier = required(interface, "modelIdentifier")?;
    let flags = match cs_node {
        None => CoSimulationFlags::default(),
        Some(cs) => flags(root, cs)?,
    };
    let (units, default_experiment) = (parse_units(root)?, parse_default_experiment(root)?);
    let Some(model_variables) = child("ModelVariables") else {
        return fail("no <ModelVariables> element".into());
    };
    let description = ModelDescription {
        fmi_version,
        model_name,
        guid,
        description: root.attribute("description").unwrap_or("").to_owned(),
        version: root.attribute("version").unwrap_or("").to_owned(),
        model_identifier,
        flags,
        co_simulation: cs_node.is_some(),
        model_exchange: None,
        units,
        default_experiment,
        variables: Vec::new(),
    };
    Ok(Common { root, me_node, model_variables, description })
}

impl<'a, 'input> Common<'a, 'input> {
    /// The root's child element of this name.
    pub(crate) fn child(&self, name: &str) -> Option<Node<'a, 'input>> {
        self.root.children().find(|c| c.has_tag_name(name))
    }

    /// The description: these parts, and the variables and Model Exchange part the version read.
    pub(crate) fn description(
        self,
        variables: Vec<Variable>,
        model_exchange: Option<ModelExchange>,
    ) -> ModelDescription {
        ModelDescription { variables, model_exchange, ..self.description }
    }
}

/// A boolean attribute, false where absent.
pub(crate) fn flag(n: Node, name: &str) -> Result<bool, ReadError> {
    attr(n, name, "a boolean", boolean).map(|b| b.unwrap_or(false))
}

/// Reads an FMI 2.0 description from its parsed document.
pub(crate) fn read_model_description(doc: &Document<'_>) -> Result<ModelDescription, ReadError> {
    let version = |v: &str| match v == "2.0" || v.starts_with("2.0.") {
        true => Ok(()),
        false => Err(format!("fmiVersion is `{v}`; only FMI 2.0 is supported")),
    };
    let common = read_common(doc, version, "guid", |root, cs| {
        let annotated = |va: Node| {
            va.children()
                .filter(|t| t.has_tag_name("Tool") && t.attribute("name") == Some(VENDOR_TOOL))
                .any(|t| t.children().any(|c| c.has_tag_name(STEP_MAP_ANNOTATION)))
        };
        Ok(CoSimulationFlags {
            needs_execution_tool: flag(cs, "needsExecutionTool")?,
            can_handle_variable_communication_step_size: flag(cs, "canHandleVariableCommunicationStepSize")?,
            can_interpolate_inputs: flag(cs, "canInterpolateInputs")?,
            max_output_derivative_order: attr(cs, "maxOutputDerivativeOrder", "an integer", |v| v.parse().ok())?
                .unwrap_or(0),
            can_run_asynchronuously: flag(cs, "canRunAsynchronuously")?,
            can_be_instantiated_only_once_per_process: flag(cs, "canBeInstantiatedOnlyOncePerProcess")?,
            can_not_use_memory_management_functions: flag(cs, "canNotUseMemoryManagementFunctions")?,
            can_get_and_set_fmu_state: flag(cs, "canGetAndSetFMUstate")?,
            can_serialize_fmu_state: flag(cs, "canSerializeFMUstate")?,
            provides_directional_derivative: flag(cs, "providesDirectionalDerivative")?,
            provides_step_map_derivative: root
                .children()
                .find(|c| c.has_tag_name("VendorAnnotations"))
                .is_some_and(annotated),
        })
    })?;
    let (root, mv) = (common.root, common.model_variables);
    let mut variables = Vec::new();
    for sv in mv.children().filter(|c| c.has_tag_name("ScalarVariable")) {
        variables.push(parse_variable(sv)?);
    }
    if let Some(ms) = common.child("ModelStructure") {
        for (list, initial) in [("Outputs", false), ("InitialUnknowns", true)] {
            for u in ms.children().filter(|c| c.has_tag_name(list)).flat_map(|l| l.children()) {
                if !u.has_tag_name("Unknown") {
                    continue;
                }
                let index = parse_index(u, &required(u, "index")?, variables.len())?;
                let deps = match u.attribute("dependencies") {
                    None => None,
                    Some(text) => Some(
                        text.split_whitespace()
                            .map(|d| Ok(variables[parse_index(u, d, variables.len())?].name.clone()))
                            .collect::<Result<Vec<_>, ReadError>>()?,
                    ),
                };
                let v = &mut variables[index];
                *(if initial { &mut v.initial_depends_on } else { &mut v.depends_on }) = deps;
            }
        }
    }
    let model_exchange = match common.me_node {
        None => None,
        Some(me) => Some(read_model_exchange(root, me, &variables)?),
    };
    Ok(common.description(variables, model_exchange))
}

/// `<ModelExchange>` of an FMI 2.0 description: its capabilities, the number of event
/// indicators, and the continuous states — the variables whose derivatives `<Derivatives>`
/// lists (each derivative's `derivative` attribute: the 1-based index of its state).
fn read_model_exchange(root: Node, me: Node, variables: &[Variable]) -> Result<ModelExchange, ReadError> {
    let event_indicators =
        attr(root, "numberOfEventIndicators", "an unsigned integer", |v| v.parse::<usize>().ok())?.unwrap_or(0);
    if event_indicators > crate::fmi3::xml::MAX_VIEW_SCALARS {
        return fail(format!("numberOfEventIndicators = {event_indicators}: more than this importer takes"));
    }
    // the `derivative` attribute of every <Real>, by variable position
    let mv = root.children().find(|c| c.has_tag_name("ModelVariables"));
    let nodes: Vec<Node> =
        mv.map(|mv| mv.children().filter(|c| c.has_tag_name("ScalarVariable")).collect()).unwrap_or_default();
    let mut states = Vec::new();
    let structure = root.children().find(|c| c.has_tag_name("ModelStructure"));
    let derivatives = structure
        .into_iter()
        .flat_map(|ms| ms.children().filter(|c| c.has_tag_name("Derivatives")))
        .flat_map(|d| d.children().filter(|u| u.has_tag_name("Unknown")));
    for u in derivatives {
        let d = parse_index(u, &required(u, "index")?, variables.len())?;
        let real = nodes.get(d).and_then(|n| n.children().find(|c| c.has_tag_name("Real")));
        let Some(of) = real.and_then(|r| r.attribute("derivative")) else {
            return fail(format!(
                "<Derivatives> at {}: variable `{}` has no `derivative` attribute naming its state",
                at(u),
                variables[d].name
            ));
        };
        let s = parse_index(u, of, variables.len())?;
        if variables[s].var_type != VarType::Real || variables[d].var_type != VarType::Real {
            return fail(format!("<Derivatives> at {}: state and derivative must be Real", at(u)));
        }
        states.push(ContinuousState { state: variables[s].value_reference, derivative: variables[d].value_reference });
    }
    Ok(ModelExchange {
        model_identifier: required(me, "modelIdentifier")?,
        needs_completed_integrator_step: !flag(me, "completedIntegratorStepNotNeeded")?,
        can_get_and_set_fmu_state: flag(me, "canGetAndSetFMUstate")?,
        can_serialize_fmu_state: flag(me, "canSerializeFMUstate")?,
        provides_directional_derivative: flag(me, "providesDirectionalDerivative")?,
        states,
        event_indicators,
        event_indicator_variables: Vec::new(),
    })
}

/// `<UnitDefinitions>` of the description `root` (the same in FMI 2.0 and 3.0).
pub(crate) fn parse_units(root: Node) -> Result<Vec<Unit>, ReadError> {
    let defs = root.children().filter(|c| c.has_tag_name("UnitDefinitions"));
    defs.flat_map(|d| d.children().filter(|c| c.has_tag_name("Unit"))).map(parse_unit).collect()
}

/// `<DefaultExperiment>` of the description `root`, if any (the same in FMI 2.0 and 3.0).
pub(crate) fn parse_default_experiment(root: Node) -> Result<Option<DefaultExperiment>, ReadError> {
    let Some(n) = root.children().find(|c| c.has_tag_name("DefaultExperiment")) else { return Ok(None) };
    Ok(Some(DefaultExperiment {
        start_time: attr(n, "startTime", "a number", real)?,
        stop_time: attr(n, "stopTime", "a number", real)?,
        step_size: attr(n, "stepSize", "a number", real)?,
        tolerance: attr(n, "tolerance", "a number", real)?,
    }))
}

fn parse_unit(u: Node) -> Result<Unit, ReadError> {
    let name = required(u, "name")?;
    let base_unit = match u.children().find(|c| c.has_tag_name("BaseUnit")) {
        None => None,
        Some(b) => {
            let mut exponents = [0; 8];
            for (e, base) in exponents.iter_mut().zip(BASE_UNIT_NAMES) {
                *e = attr(b, base, "an integer", |v| v.parse().ok())?.unwrap_or(0);
            }
            Some(BaseUnit {
                exponents,
                factor: attr(b, "factor", "a number", real)?.unwrap_or(1.0),
                offset: attr(b, "offset", "a number", real)?.unwrap_or(0.0),
            })
        }
    };
    Ok(Unit { name, base_unit })
}

/// A 1-based index into ModelVariables → 0-based position.
fn parse_index(n: Node, text: &str, count: usize) -> Result<usize, ReadError> {
    match text.trim().parse::<usize>() {
        Ok(i) if (1..=count).contains(&i) => Ok(i - 1),
        _ => fail(format!("<Unknown> at {}: index `{text}` is not in 1..={count}", at(n))),
    }
}

fn parse_variable(sv: Node) -> Result<Variable, ReadError> {
    let name = sv
        .attribute("name")
        .ok_or_else(|| ReadError { message: format!("<ScalarVariable> at {} has no name", at(sv)) })?;
    let ctx = |what: String| ReadError { message: format!("variable `{name}` at {}: {what}", at(sv)) };
    let vr_text = sv.attribute("valueReference").ok_or_else(|| ctx("no valueReference".into()))?;
    let value_reference = vr_text
        .trim()
        .parse::<u32>()
        .map_err(|_| ctx(format!("valueReference `{vr_text}` is not an unsigned integer")))?;
    let causality = sv.attribute("causality").unwrap_or("local");
    let causality = Causality::from_xml(causality).ok_or_else(|| ctx(format!("unknown causality `{causality}`")))?;
    let variability = sv.attribute("variability").unwrap_or("continuous");
    let variability =
        Variability::from_xml(variability).ok_or_else(|| ctx(format!("unknown variability `{variability}`")))?;
    let initial = match sv.attribute("initial") {
        None => None,
        Some(i) => Some(Initial::from_xml(i).ok_or_else(|| ctx(format!("unknown initial `{i}`")))?),
    };
    let Some(ty) = sv.children().find(|c| c.is_element()) else {
        return Err(ctx("no type element (<Real>, <Integer>, ...)".into()));
    };
    let var_type = match ty.tag_name().name() {
        "Enumeration" => VarType::Integer,
        other => VarType::from_xml(other).ok_or_else(|| ctx(format!("unknown type element <{other}>")))?,
    };
    let start = match ty.attribute("start") {
        None => None,
        Some(text) => Some(parse_value(var_type, text).ok_or_else(|| {
            ctx(format!(
                "start `{text}` is not a{} {} value",
                if var_type == VarType::Integer { "n" } else { "" },
                var_type.as_str()
            ))
        })?),
    };
    let bound = |name: &str| -> Result<Option<f64>, _> {
        match ty.attribute(name).filter(|_| var_type == VarType::Real) {
            None => Ok(None),
            Some(text) => {
                text.trim().parse().map(Some).map_err(|_| ctx(format!("{name} `{text}` is not a Real value")))
            }
        }
    };
    Ok(Variable {
        name: name.to_owned(),
        value_reference,
        var_type,
        causality,
        variability,
        initial,
        start,
        unit: ty.attribute("unit").map(str::to_owned),
        min: bound("min")?,
        max: bound("max")?,
        description: sv.attribute("description").unwrap_or("").to_owned(),
        depends_on: None,
        initial_depends_on: None,
    })
}

/// A `start` attribute as a value of the variable's type.
fn parse_value(var_type: VarType, text: &str) -> Option<Value> {
    let t = text.trim();
    Some(match var_type {
        VarType::Real => Value::Real(real(t)?),
        VarType::Integer => Value::Integer(t.parse().ok()?),
        VarType::Boolean => Value::Boolean(boolean(t)?),
        VarType::String => Value::String(text.to_owned()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{g}">
  <CoSimulation modelIdentifier="m" canGetAndSetFMUstate="true" maxOutputDerivativeOrder="1"/>
  <DefaultExperiment stopTime="2.5"/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="1" causality="output"><Real unit="m"/></ScalarVariable>
    <ScalarVariable name="e" valueReference="0" variability="discrete"><Enumeration declaredType="E" start="1"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2" dependencies="1"/></Outputs></ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn reads_a_minimal_description() {
        let d = parse_model_description(MINIMAL).unwrap();
        assert_eq!((d.model_name.as_str(), d.guid.as_str(), d.model_identifier.as_str()), ("m", "{g}", "m"));
        assert!(d.flags.can_get_and_set_fmu_state && !d.flags.can_serialize_fmu_state);
        assert_eq!(d.flags.max_output_derivative_order, 1);
        assert_eq!(d.default_experiment.unwrap().stop_time, Some(2.5));
        assert_eq!(d.default_experiment.unwrap().start_time, None);
        assert_eq!(d.variables.len(), 3);
        assert_eq!(d.variables[0].causality, Causality::Input);
        assert_eq!(d.variables[1].causality, Causality::Output);
        assert_eq!(d.variables[1].variability, Variability::Continuous);
        assert_eq!(d.variables[1].unit.as_deref(), Some("m"));
        assert_eq!(d.variables[2].var_type, VarType::Integer);
        assert_eq!(d.variables[2].causality, Causality::Local);
        assert_eq!(d.variables[1].depends_on, Some(vec!["u".to_owned()]));
        assert_eq!(d.variables[0].depends_on, None);
        assert_eq!(d.variables[0].start, Some(Value::Real(1.0)));
        assert_eq!(d.variables[2].start, Some(Value::Integer(1)));
        assert_eq!(d.variable("y").map(|v| v.value_reference), Some(1));
        assert!(!d.flags.provides_step_map_derivative);
        let annotated = MINIMAL.replace(
            "<ModelVariables>",
            r#"<VendorAnnotations><Tool name="other"/><Tool name="feedsim"><StepMapDerivative/></Tool></VendorAnnotations><ModelVariables>"#,
        );
        assert!(parse_model_description(&annotated).unwrap().flags.provides_step_map_derivative);
        let other_tool = MINIMAL.replace(
            "<ModelVariables>",
            r#"<VendorAnnotations><Tool name="x"><StepMapDerivative/></Tool></VendorAnnotations><ModelVariables>"#,
        );
        assert!(!parse_model_description(&other_tool).unwrap().flags.provides_step_map_derivative);
        let ranged = MINIMAL.replace(r#"<Real start="1"/>"#, r#"<Real min="-2.5" max="1e3" start="1"/>"#);
        let u = &parse_model_description(&ranged).unwrap().variables[0];
        assert_eq!((u.min, u.max), (Some(-2.5), Some(1e3)));
        assert!(u.outside_range(1e3).is_none() && u.outside_range(1001.0).is_some());
        let bad = MINIMAL.replace(r#"<Real start="1"/>"#, r#"<Real min="low" start="1"/>"#);
        assert!(parse_model_description(&bad).unwrap_err().to_string().contains("min `low` is not a Real value"));
    }

    #[test]
    fn malformed_descriptions_give_located_errors() {
        let cases = [
            ("<fmiModelDescription", "not well-formed XML"),
            (r#"<x fmiVersion="2.0"/>"#, "expected <fmiModelDescription>"),
            (r#"<fmiModelDescription fmiVersion="3.0" modelName="m" guid="g"/>"#, "only FMI 2.0"),
            (r#"<fmiModelDescription fmiVersion="2.0" guid="g"/>"#, "no `modelName`"),
            (r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g"/>"#, "no interface"),
        ];
        for (xml, fragment) in cases {
            let e = parse_model_description(xml).unwrap_err().to_string();
            assert!(e.contains(fragment), "`{e}` does not contain `{fragment}`");
        }
        let bad_vr = MINIMAL.replace(r#"name="y" valueReference="1""#, r#"name="y" valueReference="-1""#);
        let e = parse_model_description(&bad_vr).unwrap_err().to_string();
        assert!(e.contains("variable `y` at line 7") && e.contains("`-1`"), "{e}");
        let bad_index = MINIMAL.replace(r#"index="2""#, r#"index="4""#);
        assert!(parse_model_description(&bad_index).unwrap_err().message.contains("not in 1..=3"));
        let bad_flag = MINIMAL.replace(r#"canGetAndSetFMUstate="true""#, r#"canGetAndSetFMUstate="yes""#);
        assert!(parse_model_description(&bad_flag).unwrap_err().message.contains("not a boolean"));
        let bad_start = MINIMAL.replace(r#"<Real start="1"/>"#, r#"<Real start="one"/>"#);
        let e = parse_model_description(&bad_start).unwrap_err().message;
        assert!(e.contains("variable `u` at line 6") && e.contains("start `one` is not a Real value"), "{e}");
    }
}
