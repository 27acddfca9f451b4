//! `modelDescription.xml` written from a validated description, elements in schema order.

use std::collections::HashMap;
use std::fmt::Write;

use super::{STEP_MAP_ANNOTATION, VENDOR_TOOL};
use crate::description::{BASE_UNIT_NAMES, Causality, DescriptionError, Initial, ModelDescription, ModelInfo};
use crate::export::LOG_CATEGORIES;

/// The XML text of `modelDescription.xml` for this description (validated first).
pub fn model_description_xml(description: &ModelDescription) -> Result<String, DescriptionError> {
    Ok(write(&ModelInfo::new(description.clone())?.description))
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

pub(crate) fn bool_attr(b: bool) -> &'static str {
    if b { "true" } else { "false" }
}

/// The text of a description that [`ModelInfo::new`] has validated and normalized (every
/// `initial` the standard allows is written, so readers need not know the defaults).
pub(crate) fn write(d: &ModelDescription) -> String {
    let mut x = String::with_capacity(4096 + 300 * d.variables.len());
    // `write!` to a String cannot fail.
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="{}" modelName="{}" guid="{}" description="{}" version="{}" generationTool="feedsim fmi {}" variableNamingConvention="structured" numberOfEventIndicators="{}">"#,
        escape(&d.fmi_version),
        escape(&d.model_name),
        escape(&d.guid),
        escape(&d.description),
        escape(&d.version),
        env!("CARGO_PKG_VERSION"),
        d.model_exchange.as_ref().map_or(0, |m| m.event_indicators),
    );
    if let Some(me) = &d.model_exchange {
        let _ = writeln!(
            x,
            r#"  <ModelExchange modelIdentifier="{}" completedIntegratorStepNotNeeded="{}" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="{}" canSerializeFMUstate="{}" providesDirectionalDerivative="{}"/>"#,
            escape(&me.model_identifier),
            bool_attr(!me.needs_completed_integrator_step),
            bool_attr(me.can_get_and_set_fmu_state),
            bool_attr(me.can_serialize_fmu_state),
            bool_attr(me.provides_directional_derivative),
        );
    }
    let f = &d.flags;
    if d.co_simulation {
        let _ = writeln!(
            x,
            r#"  <CoSimulation modelIdentifier="{}" needsExecutionTool="{}" canHandleVariableCommunicationStepSize="{}" canInterpolateInputs="{}" maxOutputDerivativeOrder="{}" canRunAsynchronuously="{}" canBeInstantiatedOnlyOncePerProcess="{}" canNotUseMemoryManagementFunctions="{}" canGetAndSetFMUstate="{}" canSerializeFMUstate="{}" providesDirectionalDerivative="{}"/>"#,
            escape(&d.model_identifier),
            bool_attr(f.needs_execution_tool),
            bool_attr(f.can_handle_variable_communication_step_size),
            bool_attr(f.can_interpolate_inputs),
            f.max_output_derivative_order,
            bool_attr(f.can_run_asynchronuously),
            bool_attr(f.can_be_instantiated_only_once_per_process),
            bool_attr(f.can_not_use_memory_management_functions),
            bool_attr(f.can_get_and_set_fmu_state),
            bool_attr(f.can_serialize_fmu_state),
            bool_attr(f.provides_directional_derivative),
        );
    }
    units(&mut x, d);
    log_categories(&mut x);
    default_experiment(&mut x, d);
    if f.provides_step_map_derivative {
        // Schema order: VendorAnnotations after DefaultExperiment, before ModelVariables.
        x.push_str("  <VendorAnnotations>\n");
        let _ = writeln!(x, r#"    <Tool name="{VENDOR_TOOL}"><{STEP_MAP_ANNOTATION}/></Tool>"#);
        x.push_str("  </VendorAnnotations>\n");
    }
    x.push_str("  <ModelVariables>\n");
    let states = d.model_exchange.as_ref().map_or(&[][..], |m| &m.states[..]);
    let real_index = |vr: u32| {
        d.variables.iter().position(|v| v.value_reference == vr && v.var_type == crate::VarType::Real).map(|i| i + 1)
    };
    for (i, var) in d.variables.iter().enumerate() {
        let _ = writeln!(x, "    <!-- index {} -->", i + 1);
        let _ =
            write!(x, r#"    <ScalarVariable name="{}" valueReference="{}""#, escape(&var.name), var.value_reference);
        if !var.description.is_empty() {
            let _ = write!(x, r#" description="{}""#, escape(&var.description));
        }
        let _ = write!(x, r#" causality="{}" variability="{}""#, var.causality.as_str(), var.variability.as_str());
        if let Some(i) = var.initial {
            let _ = write!(x, r#" initial="{}""#, i.as_str());
        }
        let _ = write!(x, ">\n      <{}", var.var_type.as_str());
        if let Some(u) = &var.unit {
            let _ = write!(x, r#" unit="{}""#, escape(u));
        }
        for (name, bound) in [("min", var.min), ("max", var.max)] {
            if let Some(b) = bound {
                let _ = write!(x, r#" {name}="{}""#, crate::Value::Real(b));
            }
        }
        if let Some(s) = &var.start {
            let _ = write!(x, r#" start="{}""#, escape(&s.to_string()));
        }
        let real = var.var_type == crate::VarType::Real;
        let derivative_of = states.iter().find(|s| real && s.derivative == var.value_reference);
        if let Some(index) = derivative_of.and_then(|s| real_index(s.state)) {
            let _ = write!(x, r#" derivative="{index}""#);
        }
        x.push_str("/>\n    </ScalarVariable>\n");
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n");
    let index: HashMap<&str, usize> = d.variables.iter().enumerate().map(|(i, v)| (v.name.as_str(), i + 1)).collect();
    let outputs: Vec<_> = (1..).zip(&d.variables).filter(|(_, v)| v.causality == Causality::Output).collect();
    if !outputs.is_empty() {
        x.push_str("    <Outputs>\n");
        for (i, v) in &outputs {
            unknown(&mut x, *i, v.depends_on.as_deref(), &index);
        }
        x.push_str("    </Outputs>\n");
    }
    if !states.is_empty() {
        x.push_str("    <Derivatives>\n");
        for s in states {
            let i = real_index(s.derivative).expect("validated");
            unknown(&mut x, i, d.variables[i - 1].depends_on.as_deref(), &index);
        }
        x.push_str("    </Derivatives>\n");
    }
    // Exactly the outputs with initial approx/calculated and the calculated parameters, and of
    // Model Exchange the states and derivatives with initial approx/calculated, with their
    // initialization-mode dependencies.
    let is_state = |v: &crate::Variable| {
        v.var_type == crate::VarType::Real
            && states.iter().any(|s| s.state == v.value_reference || s.derivative == v.value_reference)
    };
    let initial_unknowns: Vec<_> = (1..)
        .zip(&d.variables)
        .filter(|(_, v)| {
            let calculated = matches!(v.initial, Some(Initial::Approx | Initial::Calculated));
            (calculated && (v.causality == Causality::Output || is_state(v)))
                || v.causality == Causality::CalculatedParameter
        })
        .collect();
    if !initial_unknowns.is_empty() {
        x.push_str("    <InitialUnknowns>\n");
        for (i, v) in &initial_unknowns {
            unknown(&mut x, *i, v.initial_depends_on.as_deref(), &index);
        }
        x.push_str("    </InitialUnknowns>\n");
    }
    x.push_str("  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

/// `<UnitDefinitions>` (the same elements in FMI 2.0 and 3.0).
pub(crate) fn units(x: &mut String, d: &ModelDescription) {
    if d.units.is_empty() {
        return;
    }
    x.push_str("  <UnitDefinitions>\n");
    for u in &d.units {
        let _ = write!(x, r#"    <Unit name="{}">"#, escape(&u.name));
        if let Some(b) = &u.base_unit {
            x.push_str("<BaseUnit");
            for (name, e) in BASE_UNIT_NAMES.iter().zip(b.exponents) {
                if e != 0 {
                    let _ = write!(x, r#" {name}="{e}""#);
                }
            }
            if b.factor != 1.0 {
                let _ = write!(x, r#" factor="{:?}""#, b.factor);
            }
            if b.offset != 0.0 {
                let _ = write!(x, r#" offset="{:?}""#, b.offset);
            }
            x.push_str("/>");
        }
        x.push_str("</Unit>\n");
    }
    x.push_str("  </UnitDefinitions>\n");
}

/// `<LogCategories>` of the export layer (both versions).
pub(crate) fn log_categories(x: &mut String) {
    x.push_str("  <LogCategories>\n");
    for (name, text) in LOG_CATEGORIES {
        let _ = writeln!(x, r#"    <Category name="{name}" description="{}"/>"#, escape(text));
    }
    x.push_str("  </LogCategories>\n");
}

/// `<DefaultExperiment>`, if any (both versions).
pub(crate) fn default_experiment(x: &mut String, d: &ModelDescription) {
    let Some(e) = &d.default_experiment else { return };
    x.push_str("  <DefaultExperiment");
    for (name, value) in
        [("startTime", e.start_time), ("stopTime", e.stop_time), ("tolerance", e.tolerance), ("stepSize", e.step_size)]
    {
        if let Some(v) = value {
            let _ = write!(x, r#" {name}="{v:?}""#);
        }
    }
    x.push_str("/>\n");
}

/// `<Unknown>` with its dependencies (names validated, so every one has an index).
fn unknown(x: &mut String, index: usize, dependencies: Option<&[String]>, indices: &HashMap<&str, usize>) {
    let _ = write!(x, r#"      <Unknown index="{index}""#);
    if let Some(deps) = dependencies {
        let list: Vec<String> = deps.iter().filter_map(|n| indices.get(n.as_str())).map(|i| i.to_string()).collect();
        let kinds = vec!["dependent"; list.len()];
        let _ = write!(x, r#" dependencies="{}" dependenciesKind="{}""#, list.join(" "), kinds.join(" "));
    }
    x.push_str("/>\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xml::tests::sample;

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
        assert!(x.contains(r#"canGetAndSetFMUstate="true" canSerializeFMUstate="true""#));
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
        d.variables.push(crate::description::Variable::real_output("bad", 9, "").start(1.0));
        assert!(model_description_xml(&d).is_err());
    }

    #[test]
    fn xml_parses_back() {
        let text = model_description_xml(&sample()).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        assert_eq!(doc.root_element().attribute("modelName"), Some("A & B <model>"));
        let n = doc.descendants().filter(|n| n.has_tag_name("ScalarVariable")).count();
        assert_eq!(n, 8);
    }
}
