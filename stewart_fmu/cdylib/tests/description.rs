//! stewart_fmu's modelDescription.xml as the exporter writes it reads back, through the
//! importer's parser, as exactly the description the model declares (validated and normalized).

use fmi::export::Model;

#[test]
fn the_model_description_reads_back_equal() {
    let declared = fmi::ModelInfo::new(stewart_fmu::StewartFmu::description().unwrap()).unwrap();
    let text = fmi::xml::model_description_xml(&declared.description).unwrap();
    let read = fmi::xml::parse_model_description(&text).unwrap();
    assert_eq!(read, declared.description);
    assert_eq!(
        read.variables.len(),
        19 + 38 + 5,
        "inputs, outputs (wrench, actuators, platform, legs, feed, estimate), parameters"
    );
}
