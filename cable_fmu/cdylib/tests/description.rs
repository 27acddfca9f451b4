//! cable_fmu's modelDescription.xml as the exporter writes it reads back, through the importer's
//! parser, as exactly the description the model declares (validated and normalized).

use fmi::export::Model;

#[test]
fn the_model_description_reads_back_equal() {
    let declared = fmi::ModelInfo::new(cable_fmu::CableFmu::description().unwrap()).unwrap().description;
    let text = fmi::xml::model_description_xml(&declared).unwrap();
    assert_eq!(fmi::xml::parse_model_description(&text).unwrap(), declared);
    assert_eq!(declared.variables.len(), 6 + 31 + 5, "inputs, outputs, parameters");
}
