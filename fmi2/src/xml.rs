//! `modelDescription.xml` written from a validated [`ModelInfo`], elements in schema order.

use std::fmt::Write;

use crate::description::{
    BASE_UNIT_NAMES, Causality, DescriptionError, Initial, LOG_CATEGORIES, ModelDescription, ModelInfo, Value,
};

/// `<VendorAnnotations><Tool name=...>` of this workspace's extensions.
pub const VENDOR_TOOL: &str = "feedsim";
/// The element inside the tool's annotation that announces `feedsimGetStepMapDerivative`.
pub const STEP_MAP_ANNOTATION: &str = "StepMapDerivative";

/// The XML text of `modelDescription.xml` for this description (validated first).
pub fn model_description_xml(description: &ModelDescription) -> Result<String, DescriptionError> {
    Ok(write_xml(&ModelInfo::new(description.clone())?))
}

/// Escape text for an attribute value in double quotes.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' => out.push_str("&#9;"),
            c if (c as u32) < 0x20 => {} // not representable in XML 1.0
            c => out.push(c),
        }
    }
    out
}

/// Shortest text that reads back to the same f64 (`xs:double` accepts `1e-9`, `2.0`).
fn real(x: f64) -> String {
    format!("{x:?}")
}

fn bool_attr(b: bool) -> &'static str {
    if b { "true" } else { "false" }
}

pub fn write_xml(info: &ModelInfo) -> String {
    let d = &info.description;
    let mut x = String::with_capacity(4096 + 300 * info.vars.len());
    // `write!` to a String cannot fail.
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="{}" guid="{}" description="{}" version="{}" generationTool="feedsim fmi2 {}" variableNamingConvention="structured" numberOfEventIndicators="0">"#,
        escape(&d.model_name),
        escape(&d.guid),
        escape(&d.description),
        escape(&d.version),
        env!("CARGO_PKG_VERSION"),
    );
    let caps = d.capabilities;
    let _ = writeln!(
        x,
        r#"  <CoSimulation modelIdentifier="{}" needsExecutionTool="false" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="{}" maxOutputDerivativeOrder="0" canRunAsynchronuously="false" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="{}"/>"#,
        escape(&d.model_identifier),
        bool_attr(caps.can_interpolate_inputs),
        bool_attr(caps.provides_directional_derivative),
    );
    if !info.units.is_empty() {
        x.push_str("  <UnitDefinitions>\n");
        for u in &info.units {
            let mut base = String::new();
            for (name, e) in BASE_UNIT_NAMES.iter().zip(u.exponents) {
                if e != 0 {
                    let _ = write!(base, r#" {name}="{e}""#);
                }
            }
            let _ = writeln!(x, r#"    <Unit name="{}"><BaseUnit{base}/></Unit>"#, escape(&u.name));
        }
        x.push_str("  </UnitDefinitions>\n");
    }
    x.push_str("  <LogCategories>\n");
    for (name, text) in LOG_CATEGORIES {
        let _ = writeln!(x, r#"    <Category name="{name}" description="{}"/>"#, escape(text));
    }
    x.push_str("  </LogCategories>\n");
    if let Some(e) = &d.default_experiment {
        let tol = e.tolerance.map(|t| format!(r#" tolerance="{}""#, real(t))).unwrap_or_default();
        let _ = writeln!(
            x,
            r#"  <DefaultExperiment startTime="{}" stopTime="{}" stepSize="{}"{tol}/>"#,
            real(e.start_time),
            real(e.stop_time),
            real(e.step_size)
        );
    }
    if caps.provides_step_map_derivative {
        // Schema order: VendorAnnotations after DefaultExperiment, before ModelVariables.
        x.push_str("  <VendorAnnotations>\n");
        let _ = writeln!(x, r#"    <Tool name="{VENDOR_TOOL}"><{STEP_MAP_ANNOTATION}/></Tool>"#);
        x.push_str("  </VendorAnnotations>\n");
    }
    x.push_str("  <ModelVariables>\n");
    for v in &info.vars {
        let var = &v.var;
        let _ = writeln!(x, "    <!-- index {} -->", v.index);
        let _ =
            write!(x, r#"    <ScalarVariable name="{}" valueReference="{}""#, escape(&var.name), var.value_reference);
        if !var.description.is_empty() {
            let _ = write!(x, r#" description="{}""#, escape(&var.description));
        }
        let _ = write!(x, r#" causality="{}" variability="{}""#, var.causality.as_str(), var.variability.as_str());
        // Write `initial` wherever it is allowed, so readers need not know the defaults.
        if let Some(i) = v.initial {
            let _ = write!(x, r#" initial="{}""#, i.as_str());
        }
        let _ = write!(x, ">\n      <{}", var.var_type.as_str());
        if let Some(u) = &var.unit {
            let _ = write!(x, r#" unit="{}""#, escape(u));
        }
        if let Some(s) = &var.start {
            let text = match s {
                Value::Real(r) => real(*r),
                Value::Integer(i) => i.to_string(),
                Value::Boolean(b) => bool_attr(*b).to_owned(),
                Value::String(s) => escape(s),
            };
            let _ = write!(x, r#" start="{text}""#);
        }
        x.push_str("/>\n    </ScalarVariable>\n");
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n");
    let outputs: Vec<_> = info.vars.iter().filter(|v| v.var.causality == Causality::Output).collect();
    if !outputs.is_empty() {
        x.push_str("    <Outputs>\n");
        for v in &outputs {
            x.push_str(&unknown(v.index, v.dependencies.as_deref()));
        }
        x.push_str("    </Outputs>\n");
    }
    // Exactly the outputs with initial approx/calculated and the calculated parameters
    // (Co-Simulation has no continuous states), with their initialization-mode dependencies.
    let initial_unknowns: Vec<_> = info
        .vars
        .iter()
        .filter(|v| {
            (v.var.causality == Causality::Output && matches!(v.initial, Some(Initial::Approx | Initial::Calculated)))
                || v.var.causality == Causality::CalculatedParameter
        })
        .collect();
    if !initial_unknowns.is_empty() {
        x.push_str("    <InitialUnknowns>\n");
        for v in &initial_unknowns {
            x.push_str(&unknown(v.index, v.initial_dependencies.as_deref()));
        }
        x.push_str("    </InitialUnknowns>\n");
    }
    x.push_str("  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

fn unknown(index: usize, dependencies: Option<&[usize]>) -> String {
    match dependencies {
        None => format!("      <Unknown index=\"{index}\"/>\n"),
        Some(deps) => {
            let list: Vec<String> = deps.iter().map(|d| d.to_string()).collect();
            let kinds = vec!["dependent"; deps.len()];
            format!(
                "      <Unknown index=\"{index}\" dependencies=\"{}\" dependenciesKind=\"{}\"/>\n",
                list.join(" "),
                kinds.join(" ")
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{Capabilities, DefaultExperiment, Variable};

    fn sample() -> ModelDescription {
        ModelDescription {
            model_name: "A & B <model>".into(),
            model_identifier: "ab".into(),
            guid: "{1234}".into(),
            description: "quote \" and 'apostrophe'".into(),
            version: "0.1".into(),
            capabilities: Capabilities {
                provides_directional_derivative: true,
                can_interpolate_inputs: false,
                provides_step_map_derivative: true,
            },
            default_experiment: Some(DefaultExperiment {
                start_time: 0.0,
                stop_time: 10.0,
                step_size: 0.01,
                tolerance: None,
            }),
            extra_units: vec![],
            variables: vec![
                Variable::parameter("scene", 5, "dir/a&b.toml", false),
                Variable::real_input("u", 0, 1e-9, "N"),
                Variable::real_output("y", 1, "m").depends_on(&["u"]).initially_depends_on(&["u", "scene"]),
                Variable::real_output("z", 2, "m").depends_on::<&str>(&[]),
                Variable::parameter("k", 3, 2.5, true).unit("N/m"),
            ],
        }
    }

    #[test]
    fn escaping() {
        assert_eq!(escape(r#"a<b>&"c"'d'"#), "a&lt;b&gt;&amp;&quot;c&quot;&apos;d&apos;");
        assert_eq!(escape("x\ny\u{1}"), "x&#10;y");
    }

    #[test]
    fn elements_in_schema_order_and_attributes_escaped() {
        let x = model_description_xml(&sample()).unwrap();
        let pos = |s: &str| x.find(s).unwrap_or_else(|| panic!("missing {s}"));
        let order = [
            "<fmiModelDescription",
            "<CoSimulation",
            "<UnitDefinitions>",
            "<LogCategories>",
            "<DefaultExperiment",
            "<VendorAnnotations>",
            "<ModelVariables>",
            "<ModelStructure>",
            "<Outputs>",
            "<InitialUnknowns>",
        ];
        for w in order.windows(2) {
            assert!(pos(w[0]) < pos(w[1]), "{} must come before {}", w[0], w[1]);
        }
        assert!(x.contains(r#"modelName="A &amp; B &lt;model&gt;""#));
        assert!(x.contains(r#"start="dir/a&amp;b.toml""#));
        assert!(x.contains(r#"fmiVersion="2.0""#));
        assert!(x.contains(r#"providesDirectionalDerivative="true""#));
        assert!(x.contains(r#"canInterpolateInputs="false""#));
        assert!(x.contains(r#"<Unit name="N"><BaseUnit kg="1" m="1" s="-2"/></Unit>"#));
        assert!(x.contains(r#"<Unit name="N/m"><BaseUnit kg="1" s="-2"/></Unit>"#));
        assert!(x.contains(r#"<Real unit="N" start="1e-9"/>"#));
        assert!(x.contains(r#"stepSize="0.01""#));
        assert!(x.contains(r#"<Tool name="feedsim"><StepMapDerivative/></Tool>"#));
    }

    #[test]
    fn model_structure_uses_one_based_indices() {
        let x = model_description_xml(&sample()).unwrap();
        // y is the 3rd variable and depends on u, the 2nd; z has no direct dependency.
        assert!(x.contains(r#"<Unknown index="3" dependencies="2" dependenciesKind="dependent"/>"#), "{x}");
        assert!(x.contains(r#"<Unknown index="4" dependencies="" dependenciesKind=""/>"#));
        let init = &x[x.find("<InitialUnknowns>").unwrap()..];
        assert!(init.contains(r#"<Unknown index="3" dependencies="1 2" dependenciesKind="dependent dependent"/>"#));
        assert!(init.contains(r#"<Unknown index="4"/>"#), "{init}");
        assert!(!init.contains(r#"index="5""#), "parameters are not initial unknowns");
    }

    #[test]
    fn initial_attribute_written_where_allowed_only() {
        let x = model_description_xml(&sample()).unwrap();
        let u = &x[x.find(r#"name="u""#).unwrap()..];
        let u = &u[..u.find("</ScalarVariable>").unwrap()];
        assert!(!u.contains("initial="), "inputs have no initial attribute: {u}");
        assert!(x.contains(r#"causality="parameter" variability="tunable" initial="exact""#));
        assert!(x.contains(r#"causality="output" variability="continuous" initial="calculated">"#));
    }

    #[test]
    fn invalid_tables_give_no_xml() {
        let mut d = sample();
        d.variables.push(Variable::real_output("bad", 9, "").start(1.0));
        assert!(model_description_xml(&d).is_err());
    }

    #[test]
    fn xml_parses_back() {
        let text = model_description_xml(&sample()).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        assert_eq!(doc.root_element().attribute("modelName"), Some("A & B <model>"));
        let n = doc.descendants().filter(|n| n.has_tag_name("ScalarVariable")).count();
        assert_eq!(n, 5);
    }
}
