//! FMI 3.0 `modelDescription.xml`: written from a model's description through its
//! [`Layout3`], and read from any FMI 3.0 Co-Simulation FMU into the scalar view the importer
//! works with ([`Description3`]).

use std::fmt::Write;

use roxmltree::{Document, Node};

use super::layout::{Layout3, Var3};
use crate::description::{
    Causality, CoSimulationFlags, ContinuousState, Initial, ModelDescription, ModelExchange, Value, VarType,
    Variability, Variable,
};
use crate::xml::read::{ReadError, at, attr, boolean, fail, flag, parse_document, read_common, real, required};
use crate::xml::write::{bool_attr, default_experiment, escape, log_categories, units};
use crate::xml::{STEP_MAP_ANNOTATION, VENDOR_TOOL};

/// The FMI 3.0 element name of a type.
fn element(t: VarType) -> &'static str {
    match t {
        VarType::Real => "Float64",
        VarType::Integer => "Int32",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    }
}

fn vr_list(vrs: &[u32]) -> String {
    vrs.iter().map(u32::to_string).collect::<Vec<_>>().join(" ")
}

/// The text of the FMI 3.0 `modelDescription.xml` of a validated description and its layout.
pub fn model_description_xml3(d: &ModelDescription, layout: &Layout3) -> String {
    let mut x = String::with_capacity(4096 + 300 * layout.variables.len());
    // `write!` to a String cannot fail.
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="3.0" modelName="{}" instantiationToken="{}" description="{}" version="{}" generationTool="feedsim fmi {}" variableNamingConvention="structured">"#,
        escape(&d.model_name),
        escape(&d.guid),
        escape(&d.description),
        escape(&d.version),
        env!("CARGO_PKG_VERSION"),
    );
    let f = &d.flags;
    if let Some(me) = &d.model_exchange {
        let _ = writeln!(
            x,
            r#"  <ModelExchange modelIdentifier="{}" needsCompletedIntegratorStep="{}" canGetAndSetFMUState="{}" canSerializeFMUState="{}" providesDirectionalDerivatives="{}"/>"#,
            escape(&me.model_identifier),
            bool_attr(me.needs_completed_integrator_step),
            bool_attr(me.can_get_and_set_fmu_state),
            bool_attr(me.can_serialize_fmu_state),
            bool_attr(me.provides_directional_derivative),
        );
    }
    if d.co_simulation {
        let _ = writeln!(
            x,
            r#"  <CoSimulation modelIdentifier="{}" needsExecutionTool="{}" canBeInstantiatedOnlyOncePerProcess="{}" canGetAndSetFMUState="{}" canSerializeFMUState="{}" providesDirectionalDerivatives="{}" canHandleVariableCommunicationStepSize="{}" maxOutputDerivativeOrder="0" hasEventMode="false"/>"#,
            escape(&d.model_identifier),
            bool_attr(f.needs_execution_tool),
            bool_attr(f.can_be_instantiated_only_once_per_process),
            bool_attr(f.can_get_and_set_fmu_state),
            bool_attr(f.can_serialize_fmu_state),
            bool_attr(f.provides_directional_derivative),
            bool_attr(f.can_handle_variable_communication_step_size),
        );
    }
    units(&mut x, d);
    log_categories(&mut x);
    default_experiment(&mut x, d);
    x.push_str("  <ModelVariables>\n");
    let states = d.model_exchange.as_ref().map_or(&[][..], |m| &m.states[..]);
    // the FMI 3.0 variable holding exactly the model's Real scalar `vr`
    let scalar = |vr: u32| {
        layout.variables.iter().find(|v| v.var_type == VarType::Real && v.dimension.is_none() && v.elements == [vr])
    };
    for v in &layout.variables {
        let of = states.iter().find(|s| v.var_type == VarType::Real && v.elements == [s.derivative]);
        variable(&mut x, v, of.and_then(|s| scalar(s.state)).map(|s| s.vr));
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n");
    for v in layout.variables.iter().filter(|v| v.causality == Causality::Output) {
        unknown(&mut x, "Output", v.vr, v.depends_on.as_deref());
    }
    for s in states {
        if let Some(v) = scalar(s.derivative) {
            unknown(&mut x, "ContinuousStateDerivative", v.vr, None);
        }
    }
    // the outputs with initial approx/calculated and the calculated parameters, and the
    // continuous states and their derivatives with initial approx/calculated
    let is_state = |v: &Var3| states.iter().any(|s| v.elements == [s.state] || v.elements == [s.derivative]);
    for v in layout.variables.iter().filter(|v| {
        let calculated = matches!(v.initial, Some(Initial::Approx | Initial::Calculated));
        (calculated && (v.causality == Causality::Output || (v.var_type == VarType::Real && is_state(v))))
            || v.causality == Causality::CalculatedParameter
    }) {
        unknown(&mut x, "InitialUnknown", v.vr, v.initial_depends_on.as_deref());
    }
    // the schema's order: outputs, derivatives, (clocked states,) initial unknowns, indicators
    for &z in d.model_exchange.iter().flat_map(|m| &m.event_indicator_variables) {
        if let Some(v) = scalar(z) {
            unknown(&mut x, "EventIndicator", v.vr, None);
        }
    }
    x.push_str("  </ModelStructure>\n");
    if f.provides_step_map_derivative {
        let _ = writeln!(
            x,
            r#"  <Annotations><Annotation type="{VENDOR_TOOL}"><{STEP_MAP_ANNOTATION}/></Annotation></Annotations>"#
        );
    }
    x.push_str("</fmiModelDescription>\n");
    x
}

fn variable(x: &mut String, v: &Var3, derivative_of: Option<u32>) {
    let _ = write!(x, r#"    <{} name="{}" valueReference="{}""#, element(v.var_type), escape(&v.name), v.vr);
    if !v.description.is_empty() {
        let _ = write!(x, r#" description="{}""#, escape(&v.description));
    }
    let _ = write!(x, r#" causality="{}" variability="{}""#, v.causality.as_str(), v.variability.as_str());
    if let Some(i) = v.initial {
        let _ = write!(x, r#" initial="{}""#, i.as_str());
    }
    if let Some(u) = v.unit.as_deref().filter(|_| !v.is_time()) {
        let _ = write!(x, r#" unit="{}""#, escape(u));
    }
    if let Some(state) = derivative_of {
        let _ = write!(x, r#" derivative="{state}""#);
    }
    for (name, bound) in [("min", v.min), ("max", v.max)] {
        if let Some(b) = bound {
            let _ = write!(x, r#" {name}="{}""#, Value::Real(b));
        }
    }
    if !v.start.is_empty() && v.var_type != VarType::String {
        let list: Vec<String> = v.start.iter().map(Value::to_string).collect();
        let _ = write!(x, r#" start="{}""#, list.join(" "));
    }
    let strings = if v.var_type == VarType::String { v.start.as_slice() } else { &[] };
    if v.dimension.is_none() && strings.is_empty() {
        x.push_str("/>\n");
        return;
    }
    x.push_str(">\n");
    if let Some(n) = v.dimension {
        let _ = writeln!(x, r#"      <Dimension start="{n}"/>"#);
    }
    for s in strings {
        let _ = writeln!(x, r#"      <Start value="{}"/>"#, escape(&s.to_string()));
    }
    let _ = writeln!(x, "    </{}>", element(v.var_type));
}

fn unknown(x: &mut String, tag: &str, vr: u32, dependencies: Option<&[u32]>) {
    let _ = write!(x, r#"    <{tag} valueReference="{vr}""#);
    if let Some(d) = dependencies {
        let _ = write!(x, r#" dependencies="{}""#, vr_list(d));
    }
    x.push_str("/>\n");
}

/// The most scalars the importer's view of one FMU holds: a description declaring arrays of
/// more elements is refused (its sizes are the FMU's word, the view is allocated from them).
pub const MAX_VIEW_SCALARS: usize = 1 << 22;

/// Where one scalar of the importer's view lives in an FMI 3.0 FMU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Element {
    /// The FMI 3.0 variable's value reference.
    pub vr: u32,
    /// The element's position in the variable (row-major), and the variable's number of elements.
    pub index: usize,
    pub len: usize,
}

/// An FMI 3.0 FMU's description as the importer sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Description3 {
    /// One scalar variable per element (`name[k]` for the elements of a one-dimensional array,
    /// `name[i,j]` of a matrix), numbered 0, 1, 2, … in `ModelVariables` order: its
    /// `value_reference` is its position here, and its element is `elements[position]`. Float64
    /// is `Real`, Int32 `Integer`; `guid` holds the instantiation token.
    pub view: ModelDescription,
    pub elements: Vec<Element>,
    /// Variables left out of the view (name, why): types this importer does not exchange,
    /// arrays whose size is a structural parameter.
    pub skipped: Vec<(String, String)>,
}

/// Reads the text of an FMI 3.0 `modelDescription.xml` into the importer's view.
pub fn parse_model_description3(text: &str) -> Result<Description3, ReadError> {
    read_model_description3(&parse_document(text)?)
}

/// Reads an FMI 3.0 description from its parsed document.
pub(crate) fn read_model_description3(doc: &Document<'_>) -> Result<Description3, ReadError> {
    let version = |v: &str| match v.starts_with("3.") {
        true => Ok(()),
        false => Err(format!("fmiVersion is `{v}`, expected 3.x")),
    };
    let annotated = |n: Node| {
        n.children().filter(|a| a.has_tag_name("Annotations")).flat_map(|a| a.children()).any(|a| {
            a.has_tag_name("Annotation")
                && a.attribute("type") == Some(VENDOR_TOOL)
                && a.children().any(|c| c.has_tag_name(STEP_MAP_ANNOTATION))
        })
    };
    let common = read_common(doc, version, "instantiationToken", |root, cs| {
        Ok(CoSimulationFlags {
            needs_execution_tool: flag(cs, "needsExecutionTool")?,
            can_handle_variable_communication_step_size: flag(cs, "canHandleVariableCommunicationStepSize")?,
            can_interpolate_inputs: false,
            max_output_derivative_order: attr(cs, "maxOutputDerivativeOrder", "an integer", |v| v.parse().ok())?
                .unwrap_or(0),
            can_run_asynchronuously: false,
            can_be_instantiated_only_once_per_process: flag(cs, "canBeInstantiatedOnlyOncePerProcess")?,
            can_not_use_memory_management_functions: true,
            can_get_and_set_fmu_state: flag(cs, "canGetAndSetFMUState")?,
            can_serialize_fmu_state: flag(cs, "canSerializeFMUState")?,
            provides_directional_derivative: flag(cs, "providesDirectionalDerivatives")?,
            provides_step_map_derivative: annotated(root) || annotated(cs),
        })
    })?;
    let mv = common.model_variables;
    let (mut variables, mut elements, mut skipped) = (Vec::new(), Vec::new(), Vec::new());
    // each FMI 3.0 variable's scalars in the view: value reference → (first, count)
    let mut scalars: std::collections::HashMap<u32, (usize, usize)> = std::collections::HashMap::new();
    // the `derivative` attribute of each variable that has one: its state's value reference
    let mut derivative_of: std::collections::HashMap<u32, (u32, Node)> = std::collections::HashMap::new();
    for node in mv.children().filter(Node::is_element) {
        if let Some(vr) = attr(node, "valueReference", "an unsigned integer", |v| v.parse::<u32>().ok())?
            && let Some(of) = attr(node, "derivative", "a value reference", |v| v.parse::<u32>().ok())?
        {
            derivative_of.insert(vr, (of, node));
        }
        let first = variables.len();
        let vr = parse_variable(node, &mut variables, &mut elements, &mut skipped)?;
        if scalars.insert(vr, (first, variables.len() - first)).is_some() {
            return fail(format!("<{}> at {}: value reference {vr} is used twice", node.tag_name().name(), at(node)));
        }
    }
    let (mut states, mut indicators) = (Vec::new(), Vec::new());
    if let Some(ms) = common.child("ModelStructure") {
        for u in ms.children().filter(Node::is_element) {
            let initial = match u.tag_name().name() {
                "Output" => false,
                "InitialUnknown" => true,
                "ContinuousStateDerivative" | "EventIndicator" => {
                    let vr = attr(u, "valueReference", "a value reference", |v| v.parse::<u32>().ok())?;
                    let Some((vr, &(first, n))) = vr.and_then(|vr| Some((vr, scalars.get(&vr)?))) else {
                        return fail(format!(
                            "<{}> at {}: no variable has this valueReference",
                            u.tag_name().name(),
                            at(u)
                        ));
                    };
                    if u.tag_name().name() == "EventIndicator" {
                        indicators.extend(first..first + n);
                        continue;
                    }
                    let Some(&(of, node)) = derivative_of.get(&vr) else {
                        return fail(format!(
                            "<ContinuousStateDerivative> at {}: its variable has no `derivative` attribute",
                            at(u)
                        ));
                    };
                    let Some(&(s, _)) = scalars.get(&of).filter(|&&(_, m)| m == n) else {
                        return fail(format!(
                            "variable at {}: `derivative` = {of} names no variable of as many elements",
                            at(node)
                        ));
                    };
                    for k in 0..n {
                        if variables[s + k].var_type != VarType::Real || variables[first + k].var_type != VarType::Real
                        {
                            return fail(format!(
                                "<ContinuousStateDerivative> at {}: state and derivative must be Float64",
                                at(u)
                            ));
                        }
                        states.push(ContinuousState { state: (s + k) as u32, derivative: (first + k) as u32 });
                    }
                    continue;
                }
                _ => continue,
            };
            let vr = attr(u, "valueReference", "a value reference", |v| v.parse::<u32>().ok())?;
            let Some(&(first, n)) = vr.and_then(|vr| scalars.get(&vr)) else {
                return fail(format!("<{}> at {}: no variable has this valueReference", u.tag_name().name(), at(u)));
            };
            let deps = match u.attribute("dependencies") {
                None => None,
                Some(text) => {
                    let mut names = Vec::new();
                    for d in text.split_whitespace() {
                        let Some(&(f, m)) = d.parse::<u32>().ok().and_then(|d| scalars.get(&d)) else {
                            return fail(format!(
                                "<{}> at {}: dependency `{d}` is no variable's value reference",
                                u.tag_name().name(),
                                at(u)
                            ));
                        };
                        names.extend(variables[f..f + m].iter().map(|v: &Variable| v.name.clone()));
                    }
                    Some(names)
                }
            };
            for v in &mut variables[first..first + n] {
                *(if initial { &mut v.initial_depends_on } else { &mut v.depends_on }) = deps.clone();
            }
        }
    }
    let model_exchange = match common.me_node {
        None => None,
        Some(me) => Some(ModelExchange {
            model_identifier: required(me, "modelIdentifier")?,
            needs_completed_integrator_step: flag(me, "needsCompletedIntegratorStep")?,
            can_get_and_set_fmu_state: flag(me, "canGetAndSetFMUState")?,
            can_serialize_fmu_state: flag(me, "canSerializeFMUState")?,
            provides_directional_derivative: flag(me, "providesDirectionalDerivatives")?,
            states,
            event_indicators: indicators.len(),
            event_indicator_variables: indicators.iter().map(|&i| i as u32).collect(),
        }),
    };
    let view = common.description(variables, model_exchange);
    Ok(Description3 { view, elements, skipped })
}

/// The view's scalars of one FMI 3.0 variable, appended; returns its value reference.
fn parse_variable(
    n: Node,
    variables: &mut Vec<Variable>,
    elements: &mut Vec<Element>,
    skipped: &mut Vec<(String, String)>,
) -> Result<u32, ReadError> {
    let tag = n.tag_name().name();
    let name = required(n, "name")?;
    let ctx = |what: String| ReadError { message: format!("variable `{name}` at {}: {what}", at(n)) };
    let vr = attr(n, "valueReference", "an unsigned integer", |v| v.parse::<u32>().ok())?
        .ok_or_else(|| ctx("no valueReference".into()))?;
    let var_type = match tag {
        "Float64" => VarType::Real,
        "Int32" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        other => {
            skipped.push((name, format!("type {other}: this importer exchanges Float64, Int32, Boolean and String")));
            return Ok(vr);
        }
    };
    let causality = n.attribute("causality").unwrap_or("local");
    if causality == "structuralParameter" {
        skipped.push((name, "a structural parameter (this importer does not use configuration mode)".into()));
        return Ok(vr);
    }
    let causality = Causality::from_xml(causality).ok_or_else(|| ctx(format!("unknown causality `{causality}`")))?;
    let default_variability = if var_type == VarType::Real { "continuous" } else { "discrete" };
    let variability = n.attribute("variability").unwrap_or(default_variability);
    let variability =
        Variability::from_xml(variability).ok_or_else(|| ctx(format!("unknown variability `{variability}`")))?;
    let initial = match n.attribute("initial") {
        None => None,
        Some(i) => Some(Initial::from_xml(i).ok_or_else(|| ctx(format!("unknown initial `{i}`")))?),
    };
    let mut dims = Vec::new();
    for d in n.children().filter(|c| c.has_tag_name("Dimension")) {
        match attr(d, "start", "an unsigned integer", |v| v.parse::<usize>().ok())? {
            Some(size) if d.attribute("valueReference").is_none() => dims.push(size),
            _ => {
                skipped.push((name, "an array whose size is a structural parameter".into()));
                return Ok(vr);
            }
        }
    }
    let len = dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|&n| variables.len() + n <= MAX_VIEW_SCALARS)
        .ok_or_else(|| {
            ctx(format!("dimensions {dims:?}: more than the {MAX_VIEW_SCALARS} scalars this importer takes in all"))
        })?;
    let parse = |text: &str| -> Result<Value, ReadError> {
        let t = text.trim();
        let value = match var_type {
            VarType::Real => real(t).map(Value::Real),
            VarType::Integer => t.parse().ok().map(Value::Integer),
            VarType::Boolean => boolean(t).map(Value::Boolean),
            VarType::String => Some(Value::String(text.to_owned())),
        };
        value.ok_or_else(|| ctx(format!("start `{text}` is not a {tag} value")))
    };
    let starts: Vec<Value> = if var_type == VarType::String {
        let values = n.children().filter(|c| c.has_tag_name("Start")).map(|s| s.attribute("value").unwrap_or(""));
        values.map(parse).collect::<Result<_, _>>()?
    } else {
        n.attribute("start").map_or(Ok(Vec::new()), |s| s.split_whitespace().map(parse).collect())?
    };
    if !(starts.is_empty() || starts.len() == 1 || starts.len() == len) {
        return Err(ctx(format!("{} start values for {len} elements", starts.len())));
    }
    let bound = |b: &str| attr(n, b, "a number", real).map(|x| x.filter(|_| var_type == VarType::Real));
    let (min, max) = (bound("min")?, bound("max")?);
    let unit = n.attribute("unit").map(str::to_owned);
    let description = n.attribute("description").unwrap_or("").to_owned();
    for k in 0..len {
        let element_name = match dims.len() {
            0 => name.clone(),
            1 => format!("{name}[{}]", k + 1),
            _ => {
                // row-major indices from 1
                let (mut rest, mut idx) = (k, vec![0; dims.len()]);
                for (i, d) in dims.iter().enumerate().rev() {
                    idx[i] = rest % d + 1;
                    rest /= d;
                }
                format!("{name}[{}]", idx.iter().map(usize::to_string).collect::<Vec<_>>().join(","))
            }
        };
        let start = starts.get(if starts.len() == 1 { 0 } else { k }).cloned();
        let position = variables.len() as u32;
        variables.push(Variable {
            name: element_name,
            value_reference: position,
            var_type,
            causality,
            variability,
            initial,
            start,
            unit: unit.clone(),
            min,
            max,
            description: description.clone(),
            depends_on: None,
            initial_depends_on: None,
        });
        elements.push(Element { vr, index: k, len });
    }
    Ok(vr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::ModelInfo;

    const SAMPLE: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="{t}">
  <CoSimulation modelIdentifier="m" canGetAndSetFMUState="true" providesDirectionalDerivatives="true"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="u" valueReference="5" causality="input" start="1 2 3"><Dimension start="3"/></Float64>
    <Float64 name="A" valueReference="6" causality="parameter" variability="fixed" start="1 2 3 4"><Dimension start="2"/><Dimension start="2"/></Float64>
    <Float32 name="f" valueReference="7" causality="output"/>
    <Int32 name="n" valueReference="8" causality="parameter" variability="fixed" start="4"/>
    <String name="s" valueReference="9" causality="parameter" variability="fixed"><Start value="a&amp;b"/></String>
    <Float64 name="y" valueReference="10" causality="output" initial="calculated"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="7"/>
    <Output valueReference="10" dependencies="5 8"/>
    <InitialUnknown valueReference="10"/>
  </ModelStructure>
  <Annotations><Annotation type="feedsim"><StepMapDerivative/></Annotation></Annotations>
</fmiModelDescription>"#;

    #[test]
    fn arrays_are_seen_as_scalars() {
        let d = parse_model_description3(SAMPLE).unwrap();
        let names: Vec<&str> = d.view.variables.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["time", "u[1]", "u[2]", "u[3]", "A[1,1]", "A[1,2]", "A[2,1]", "A[2,2]", "n", "s", "y"]);
        assert_eq!(d.elements[2], Element { vr: 5, index: 1, len: 3 });
        assert_eq!(d.elements[6], Element { vr: 6, index: 2, len: 4 });
        assert_eq!(d.view.variables[3].start, Some(Value::Real(3.0)));
        assert_eq!(d.view.variables[9].start, Some(Value::String("a&b".into())));
        assert_eq!(d.view.variables[8].variability, Variability::Fixed);
        assert_eq!(
            d.view.variables[10].depends_on,
            Some(vec!["u[1]".into(), "u[2]".into(), "u[3]".into(), "n".into()])
        );
        assert_eq!(
            d.skipped,
            [("f".to_owned(), "type Float32: this importer exchanges Float64, Int32, Boolean and String".to_owned())]
        );
        assert!(d.view.flags.can_get_and_set_fmu_state && !d.view.flags.can_serialize_fmu_state);
        assert!(d.view.flags.provides_directional_derivative && d.view.flags.provides_step_map_derivative);
        assert_eq!((d.view.guid.as_str(), d.view.fmi_version.as_str()), ("{t}", "3.0"));
    }

    #[test]
    fn structural_parameters_are_left_out() {
        let xml = SAMPLE.replace(
            r#"name="n" valueReference="8" causality="parameter""#,
            r#"name="n" valueReference="8" causality="structuralParameter""#,
        );
        let d = parse_model_description3(&xml).unwrap();
        assert!(
            d.view.variable("n").is_none() && d.skipped.iter().any(|(n, why)| n == "n" && why.contains("structural"))
        );
        assert_eq!(d.view.variable("y").unwrap().depends_on, Some(vec!["u[1]".into(), "u[2]".into(), "u[3]".into()]));
    }

    #[test]
    fn malformed_descriptions_give_located_errors() {
        let cases = [
            (SAMPLE.replace(r#"fmiVersion="3.0""#, r#"fmiVersion="2.0""#), "expected 3.x"),
            (SAMPLE.replace(r#"start="1 2 3""#, r#"start="1 2""#), "2 start values for 3 elements"),
            (SAMPLE.replace(r#"dependencies="5 8""#, r#"dependencies="5 99""#), "dependency `99`"),
            (SAMPLE.replace(r#"valueReference="9""#, r#"valueReference="8""#), "used twice"),
            (SAMPLE.replace(r#"start="4""#, r#"start="four""#), "start `four` is not a Int32 value"),
            (SAMPLE.replace(r#"<Dimension start="3"/>"#, r#"<Dimension start="100000000"/>"#), "more than the 4194304"),
            (
                SAMPLE.replace(
                    r#"<Dimension start="3"/>"#,
                    r#"<Dimension start="4294967296"/><Dimension start="4294967296"/>"#,
                ),
                "more than the 4194304",
            ),
        ];
        for (xml, fragment) in cases {
            let e = parse_model_description3(&xml).unwrap_err().to_string();
            assert!(e.contains(fragment), "`{e}` does not contain `{fragment}`");
        }
    }

    /// Careless and hostile descriptions: every byte of a written one replaced by characters that
    /// break XML, numbers or lists, and the text cut at every point — read or refused, never a
    /// panic (and nothing allocated from a size the text claims beyond the limit).
    #[test]
    fn mutated_descriptions_are_read_or_refused() {
        let info = ModelInfo::new(crate::xml::tests::sample()).unwrap();
        let text = model_description_xml3(&info.description, &Layout3::new(&info.description).unwrap());
        let bytes = text.as_bytes();
        let mut outcomes = [0usize; 2];
        for i in 0..bytes.len() {
            for b in [b'<', b'"', b'9', b' ', b'-', b'x'] {
                let mut m = bytes.to_vec();
                m[i] = b;
                let Ok(t) = std::str::from_utf8(&m) else { continue };
                outcomes[usize::from(parse_model_description3(t).is_ok())] += 1;
            }
            if text.is_char_boundary(i) {
                outcomes[usize::from(parse_model_description3(&text[..i]).is_ok())] += 1;
            }
        }
        assert!(outcomes[0] > 1000 && outcomes[1] > 100, "refused, read: {outcomes:?}");
        let huge = SAMPLE.replace(r#"<Dimension start="3"/>"#, r#"<Dimension start="18446744073709551615"/>"#);
        assert!(parse_model_description3(&huge).is_err());
        let empty = SAMPLE.replace(r#"start="1 2 3"><Dimension start="3"/>"#, r#"><Dimension start="0"/>"#);
        let d = parse_model_description3(&empty).unwrap();
        assert!(d.view.variable("u[1]").is_none() && d.view.variable("y").is_some(), "an empty array has no scalars");
    }

    #[test]
    fn what_is_written_reads_back_as_the_model_declares_it() {
        let info = ModelInfo::new(crate::xml::tests::sample()).unwrap();
        let layout = Layout3::new(&info.description).unwrap();
        let text = model_description_xml3(&info.description, &layout);
        let read = parse_model_description3(&text).unwrap();
        assert_eq!(super::super::view_differs(&info.description, &read.view), None, "{text}");
        assert!(text.contains(r#"<String name="scene" valueReference="805306373""#), "{text}");
        assert!(text.contains(r#"<Start value="dir/a&amp;b.toml"/>"#));
        assert!(text.contains(r#"<Output valueReference="1" dependencies="0"/>"#), "{text}");
    }
}
