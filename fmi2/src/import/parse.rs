//! Reading the `modelDescription.xml` of any FMI 2.0 Co-Simulation FMU.

use roxmltree::{Document, Node};

use crate::description::{Causality, Initial, VarType, Variability};

/// The Co-Simulation capability flags an FMU declares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoSimulationFlags {
    pub needs_execution_tool: bool,
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    /// This workspace's opt-in extension: `<VendorAnnotations><Tool name="feedsim">
    /// <StepMapDerivative/>` is present and (once the binary is loaded) it exports
    /// `feedsimGetStepMapDerivative`.
    pub provides_step_map_derivative: bool,
}

/// One `<ScalarVariable>`.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    /// `Enumeration` variables are accessed as Integer.
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub initial: Option<Initial>,
    /// The `start` attribute as written.
    pub start: Option<String>,
    pub unit: Option<String>,
    pub description: String,
}

/// `<DefaultExperiment>`; absent attributes are `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Experiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub step_size: Option<f64>,
    pub tolerance: Option<f64>,
}

/// What the importer needs from `modelDescription.xml`.
#[derive(Clone, Debug, PartialEq)]
pub struct FmuDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: String,
    pub model_identifier: String,
    pub flags: CoSimulationFlags,
    pub default_experiment: Option<Experiment>,
    pub variables: Vec<ScalarVariable>,
    /// Positions in `variables` of the `<Outputs>` entries, with their dependencies
    /// (positions as well; `None`: depends on all knowns).
    pub outputs: Vec<(usize, Option<Vec<usize>>)>,
}

impl FmuDescription {
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables.iter().find(|v| v.name == name)
    }
}

/// Parse the text of a `modelDescription.xml`. Errors say what is wrong and where (line:column).
pub fn parse_model_description(text: &str) -> Result<FmuDescription, String> {
    let doc = Document::parse(text).map_err(|e| format!("not well-formed XML: {e}"))?;
    let root = doc.root_element();
    let at = |n: Node| {
        let p = doc.text_pos_at(n.range().start);
        format!("line {}:{}", p.row, p.col)
    };
    if root.tag_name().name() != "fmiModelDescription" {
        return Err(format!("root element is <{}>, expected <fmiModelDescription>", root.tag_name().name()));
    }
    let fmi_version = root.attribute("fmiVersion").unwrap_or("").to_owned();
    if !(fmi_version == "2.0" || fmi_version.starts_with("2.0.")) {
        return Err(format!("fmiVersion is `{fmi_version}`; only FMI 2.0 is supported"));
    }
    let required = |n: Node, attr: &str| {
        n.attribute(attr)
            .map(str::to_owned)
            .ok_or_else(|| format!("<{}> at {} has no `{attr}` attribute", n.tag_name().name(), at(n)))
    };
    let model_name = required(root, "modelName")?;
    let guid = required(root, "guid")?;
    let child = |name: &str| root.children().find(|c| c.has_tag_name(name));
    let Some(cs) = child("CoSimulation") else {
        let me = if child("ModelExchange").is_some() { " (it is a Model Exchange FMU)" } else { "" };
        return Err(format!("no <CoSimulation> element{me}; only Co-Simulation FMUs are supported"));
    };
    let model_identifier = required(cs, "modelIdentifier")?;
    let flag = |attr: &str| -> Result<bool, String> {
        match cs.attribute(attr) {
            None | Some("false") | Some("0") => Ok(false),
            Some("true") | Some("1") => Ok(true),
            Some(v) => Err(format!("<CoSimulation> at {}: `{attr}` = `{v}` is not a boolean", at(cs))),
        }
    };
    let flags = CoSimulationFlags {
        needs_execution_tool: flag("needsExecutionTool")?,
        can_handle_variable_communication_step_size: flag("canHandleVariableCommunicationStepSize")?,
        can_interpolate_inputs: flag("canInterpolateInputs")?,
        max_output_derivative_order: match cs.attribute("maxOutputDerivativeOrder") {
            None => 0,
            Some(v) => v.trim().parse().map_err(|_| format!("maxOutputDerivativeOrder = `{v}` is not an integer"))?,
        },
        can_run_asynchronuously: flag("canRunAsynchronuously")?,
        can_be_instantiated_only_once_per_process: flag("canBeInstantiatedOnlyOncePerProcess")?,
        can_get_and_set_fmu_state: flag("canGetAndSetFMUstate")?,
        can_serialize_fmu_state: flag("canSerializeFMUstate")?,
        provides_directional_derivative: flag("providesDirectionalDerivative")?,
        provides_step_map_derivative: child("VendorAnnotations").is_some_and(|va| {
            va.children()
                .filter(|t| t.has_tag_name("Tool") && t.attribute("name") == Some(crate::xml::VENDOR_TOOL))
                .any(|t| t.children().any(|c| c.has_tag_name(crate::xml::STEP_MAP_ANNOTATION)))
        }),
    };
    let real_attr = |n: Node, a: &str| -> Result<Option<f64>, String> {
        n.attribute(a)
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("<{}> at {}: `{a}` = `{v}` is not a number", n.tag_name().name(), at(n)))
            })
            .transpose()
    };
    let default_experiment = match child("DefaultExperiment") {
        None => None,
        Some(n) => Some(Experiment {
            start_time: real_attr(n, "startTime")?,
            stop_time: real_attr(n, "stopTime")?,
            step_size: real_attr(n, "stepSize")?,
            tolerance: real_attr(n, "tolerance")?,
        }),
    };
    let Some(mv) = child("ModelVariables") else {
        return Err("no <ModelVariables> element".into());
    };
    let mut variables = Vec::new();
    for sv in mv.children().filter(|c| c.has_tag_name("ScalarVariable")) {
        variables.push(parse_variable(sv, &at)?);
    }
    let mut outputs = Vec::new();
    if let Some(outs) = child("ModelStructure").and_then(|ms| ms.children().find(|c| c.has_tag_name("Outputs"))) {
        for u in outs.children().filter(|c| c.has_tag_name("Unknown")) {
            let index = parse_index(u, &required(u, "index")?, variables.len(), &at)?;
            let deps = match u.attribute("dependencies") {
                None => None,
                Some(list) => Some(
                    list.split_whitespace()
                        .map(|d| parse_index(u, d, variables.len(), &at))
                        .collect::<Result<Vec<_>, _>>()?,
                ),
            };
            outputs.push((index, deps));
        }
    }
    Ok(FmuDescription {
        fmi_version,
        model_name,
        guid,
        description: root.attribute("description").unwrap_or("").to_owned(),
        model_identifier,
        flags,
        default_experiment,
        variables,
        outputs,
    })
}

/// A 1-based index into ModelVariables → 0-based position.
fn parse_index(n: Node, text: &str, count: usize, at: &dyn Fn(Node) -> String) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(i) if (1..=count).contains(&i) => Ok(i - 1),
        _ => Err(format!("<Unknown> at {}: index `{text}` is not in 1..={count}", at(n))),
    }
}

fn parse_variable(sv: Node, at: &dyn Fn(Node) -> String) -> Result<ScalarVariable, String> {
    let name = sv.attribute("name").ok_or_else(|| format!("<ScalarVariable> at {} has no name", at(sv)))?.to_owned();
    let ctx = |what: String| format!("variable `{name}` at {}: {what}", at(sv));
    let vr_text = sv.attribute("valueReference").ok_or_else(|| ctx("no valueReference".into()))?;
    let value_reference = vr_text
        .trim()
        .parse::<u32>()
        .map_err(|_| ctx(format!("valueReference `{vr_text}` is not an unsigned integer")))?;
    let causality = match sv.attribute("causality").unwrap_or("local") {
        "parameter" => Causality::Parameter,
        "calculatedParameter" => Causality::CalculatedParameter,
        "input" => Causality::Input,
        "output" => Causality::Output,
        "local" => Causality::Local,
        "independent" => Causality::Independent,
        other => return Err(ctx(format!("unknown causality `{other}`"))),
    };
    let variability = match sv.attribute("variability").unwrap_or("continuous") {
        "constant" => Variability::Constant,
        "fixed" => Variability::Fixed,
        "tunable" => Variability::Tunable,
        "discrete" => Variability::Discrete,
        "continuous" => Variability::Continuous,
        other => return Err(ctx(format!("unknown variability `{other}`"))),
    };
    let initial = match sv.attribute("initial") {
        None => None,
        Some("exact") => Some(Initial::Exact),
        Some("approx") => Some(Initial::Approx),
        Some("calculated") => Some(Initial::Calculated),
        Some(other) => return Err(ctx(format!("unknown initial `{other}`"))),
    };
    let Some(ty) = sv.children().find(|c| c.is_element()) else {
        return Err(ctx("no type element (<Real>, <Integer>, ...)".into()));
    };
    let var_type = match ty.tag_name().name() {
        "Real" => VarType::Real,
        "Integer" | "Enumeration" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        other => return Err(ctx(format!("unknown type element <{other}>"))),
    };
    Ok(ScalarVariable {
        name: name.clone(),
        value_reference,
        var_type,
        causality,
        variability,
        initial,
        start: ty.attribute("start").map(str::to_owned),
        unit: ty.attribute("unit").map(str::to_owned),
        description: sv.attribute("description").unwrap_or("").to_owned(),
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
        assert_eq!(d.variables.len(), 3);
        assert_eq!(d.variables[0].causality, Causality::Input);
        assert_eq!(d.variables[1].causality, Causality::Output);
        assert_eq!(d.variables[1].variability, Variability::Continuous);
        assert_eq!(d.variables[1].unit.as_deref(), Some("m"));
        assert_eq!(d.variables[2].var_type, VarType::Integer);
        assert_eq!(d.variables[2].causality, Causality::Local);
        assert_eq!(d.outputs, vec![(1, Some(vec![0]))]);
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
    }

    #[test]
    fn malformed_descriptions_give_located_errors() {
        let cases = [
            ("<fmiModelDescription", "not well-formed XML"),
            (r#"<x fmiVersion="2.0"/>"#, "expected <fmiModelDescription>"),
            (r#"<fmiModelDescription fmiVersion="3.0" modelName="m" guid="g"/>"#, "only FMI 2.0"),
            (r#"<fmiModelDescription fmiVersion="2.0" guid="g"/>"#, "no `modelName`"),
            (
                r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g"><ModelExchange modelIdentifier="m"/></fmiModelDescription>"#,
                "Model Exchange",
            ),
        ];
        for (xml, fragment) in cases {
            let e = parse_model_description(xml).unwrap_err();
            assert!(e.contains(fragment), "`{e}` does not contain `{fragment}`");
        }
        let bad_vr = MINIMAL.replace(r#"name="y" valueReference="1""#, r#"name="y" valueReference="-1""#);
        let e = parse_model_description(&bad_vr).unwrap_err();
        assert!(e.contains("variable `y` at line 7") && e.contains("`-1`"), "{e}");
        let bad_index = MINIMAL.replace(r#"index="2""#, r#"index="4""#);
        assert!(parse_model_description(&bad_index).unwrap_err().contains("not in 1..=3"));
        let bad_flag = MINIMAL.replace(r#"canGetAndSetFMUstate="true""#, r#"canGetAndSetFMUstate="yes""#);
        assert!(parse_model_description(&bad_flag).unwrap_err().contains("not a boolean"));
    }
}
