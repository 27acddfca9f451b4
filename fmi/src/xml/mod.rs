//! `modelDescription.xml` ↔ [`ModelDescription`](crate::description::ModelDescription): the
//! generator the exporter uses and the parser the importer uses, over the same types, so that
//! what is written reads back equal (tested for every FMU of the workspace).

pub(crate) mod read;
pub(crate) mod write;

pub use read::{ReadError, parse_model_description};
pub use write::{escape, model_description_xml};

/// `<VendorAnnotations><Tool name=...>` of this workspace's extensions.
pub(crate) const VENDOR_TOOL: &str = "feedsim";
/// The element inside the tool's annotation that announces `feedsimGetStepMapDerivative`.
pub(crate) const STEP_MAP_ANNOTATION: &str = "StepMapDerivative";

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::description::{
        BaseUnit, CoSimulationFlags, DefaultExperiment, Initial, ModelDescription, ModelInfo, Unit, Variable,
    };

    /// Escapes in every text, SI and extra units, dependencies in both modes, all start types.
    pub(crate) fn sample() -> ModelDescription {
        let mut d = ModelDescription::co_simulation(
            "ab",
            "{1234}",
            "quote \" and 'apostrophe'",
            "0.1",
            CoSimulationFlags {
                provides_directional_derivative: true,
                provides_step_map_derivative: true,
                ..CoSimulationFlags::EXPORTED
            },
            vec![
                Variable::parameter("scene", 5, "dir/a&b.toml", false),
                Variable::real_input("u", 0, 1e-9, "N"),
                Variable::real_output("y", 1, "m").depends_on(&["u"]).initially_depends_on(&["u", "scene"]),
                Variable::real_output("z", 2, "m").depends_on::<&str>(&[]),
                Variable::parameter("k", 3, 2.5, true).unit("N/m").describe("spring <stiffness>\n& more"),
                Variable::parameter("n", 0, -3, false),
                Variable::parameter("on", 0, true, false),
                Variable::real_output("w", 4, "degF").initial(Initial::Approx).start(1.0 / 3.0),
            ],
        );
        d.model_name = "A & B <model>".into();
        d.default_experiment = Some(DefaultExperiment { stop_time: Some(10.0), ..d.default_experiment.unwrap() });
        d.units.push(Unit {
            name: "degF".into(),
            base_unit: Some(BaseUnit { exponents: [0, 0, 0, 0, 1, 0, 0, 0], factor: 5.0 / 9.0, offset: 255.372 }),
        });
        d
    }

    /// Generate → parse → equal to the validated description.
    pub(crate) fn assert_round_trip(d: ModelDescription) {
        let expected = ModelInfo::new(d).expect("a valid description").description;
        let text = model_description_xml(&expected).unwrap();
        let read = parse_model_description(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(read, expected, "{text}");
    }

    #[test]
    fn what_is_written_reads_back_equal() {
        assert_round_trip(sample());
        let mut plain = sample();
        plain.flags = CoSimulationFlags::EXPORTED;
        plain.default_experiment = None;
        plain.description.clear();
        assert_round_trip(plain);
    }

    #[test]
    fn the_parser_fills_what_the_model_left_to_the_standard() {
        // A model may leave `initial` and the order of dependencies to the layer; the file has both.
        let mut d = sample();
        d.variables[2].initial_depends_on = Some(vec!["scene".into(), "u".into(), "u".into()]);
        let text = model_description_xml(&d).unwrap();
        let read = parse_model_description(&text).unwrap();
        assert_eq!(read.variables[2].initial, Some(Initial::Calculated));
        assert_eq!(read.variables[2].initial_depends_on, Some(vec!["scene".to_owned(), "u".to_owned()]));
        assert_eq!(read.variables[1].initial, None, "inputs have no initial attribute");
    }
}
