//! The importer against an FMU this workspace did not build: a minimal C implementation
//! (tests/foreign/foreign.c, compiled here with the system C compiler) with a hand-written
//! modelDescription.xml. Checks printf-style log formatting with real arguments, fmi2Discard,
//! and that capabilities the FMU does not declare are refused before any call.

use std::path::PathBuf;
use std::process::Command;

use fmi::description::{Causality, VarType};
use fmi::ffi::Status;
use fmi::import::{Capability, Error, Fmu};

const HERE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/foreign");

/// Unpacked FMU directory with the freshly compiled binary.
fn build() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fmi2-foreign-{}", std::process::id()));
    let bin = dir.join("binaries/linux64");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::create_dir_all(dir.join("resources")).unwrap();
    std::fs::copy(format!("{HERE}/modelDescription.xml"), dir.join("modelDescription.xml")).unwrap();
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let out = Command::new(&cc)
        .args(["-shared", "-fPIC", "-O1", "-fvisibility=hidden", "-o"])
        .arg(bin.join("foreign.so"))
        .arg(format!("{HERE}/foreign.c"))
        .output()
        .unwrap_or_else(|e| panic!("cannot run the C compiler `{cc}` (needed by this test and by the build): {e}"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    dir
}

#[test]
fn a_c_fmu_runs_through_the_importer() {
    let dir = build();
    let fmu = Fmu::load_unpacked(&dir).unwrap();
    let d = fmu.description();
    assert_eq!(d.model_name, "foreign integrator");
    assert_eq!(d.default_experiment.unwrap().step_size, Some(0.01));
    let mode = fmu.variable("mode").unwrap();
    assert_eq!((mode.var_type, mode.causality), (VarType::Integer, Causality::Local), "defaults and Enumeration");
    assert_eq!(d.variables[1].depends_on, Some(vec![]), "`dependencies=\"\"`: on no input");
    assert_eq!(d.variables[1].start, Some(fmi::Value::Real(0.0)));

    let mut i = fmu.instantiate("c1", true).unwrap();
    let log = i.take_messages();
    let expected = format!(
        "instantiated {} (type 1) with resources at {}, 100% ready",
        d.guid,
        fmi::uri::file_uri(&dir.join("resources"))
    );
    assert_eq!(log[0].text, expected, "formatted by the C library's vsnprintf");
    i.setup_experiment(None, 0.0, Some(1.0)).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    let (u, y) = (fmu.value_reference("u").unwrap(), fmu.value_reference("y").unwrap());
    i.set_real(&[u], &[2.0]).unwrap();
    i.do_step(0.0, 0.01).unwrap();
    i.do_step(0.01, 0.01).unwrap();
    let mut out = [0.0];
    i.get_real(&[y], &mut out).unwrap();
    assert_eq!(out[0], 0.04);

    i.set_real(&[u], &[-1.0]).unwrap();
    let e = i.do_step(0.02, 0.01).unwrap_err();
    assert_eq!(e.status(), Some(Status::Discard));
    assert_eq!(
        e.to_string(),
        "FMU `foreign` (instance `c1`): fmi2DoStep returned fmi2Discard; FMU log: \
         [log] step at t=0.02 refused: negative input u=-1.000"
    );
    let e = i.get_real(&[7], &mut out).unwrap_err();
    assert!(e.to_string().contains("no variable has value reference 7"), "{e}");

    // Undeclared capabilities are refused by the importer, before the FMU is called.
    assert!(matches!(i.get_state(), Err(Error::Capability { capability: Capability::GetSetState, .. })));
    let e = i.directional_derivative(&[y], &[u], &[1.0], &mut out).unwrap_err();
    assert_eq!(
        e.to_string(),
        "FMU `foreign` does not declare providesDirectionalDerivative=\"true\" in modelDescription.xml"
    );
    assert!(i.set_real_input_derivatives(&[u], &[1], &[0.0]).is_err());
    drop(i);
    drop(fmu);
    std::fs::remove_dir_all(&dir).unwrap();
}
