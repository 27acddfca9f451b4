//! The LT50m system exported with its FMI 3.0 FMUs (`export-ssp --fmi 3`), and a system of one
//! FMU of each version, run by `master run --system` against the FMI 2.0 system: the same
//! calls reach the same models, so the time histories are equal byte for byte.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use crate::{common, master};

/// `export-ssp` of scene B with the FMUs of FMI version `fmi`.
fn export(fmi: &str) -> PathBuf {
    let (_, file) = common::scene("lt50m_B.toml", "fmi3", |_| {});
    let ssp = common::fmu_dir().join(format!("fmi{fmi}-B.ssp"));
    let out = master(&["export-ssp", "--scene", file.to_str().unwrap(), "--out", ssp.to_str().unwrap(), "--fmi", fmi]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    ssp
}

/// The system of `base` with component `cable`'s FMU taken from `other`.
fn mixed(base: &Path, other: &Path) -> PathBuf {
    let entry = |path: &Path, name: &str| {
        let mut z = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
        let mut bytes = Vec::new();
        z.by_name(name).unwrap().read_to_end(&mut bytes).unwrap();
        bytes
    };
    let out = common::fmu_dir().join("mixed-B.ssp");
    let mut z = zip::ZipWriter::new(std::fs::File::create(&out).unwrap());
    for name in ["SystemStructure.ssd", "resources/cable.fmu", "resources/stewart.fmu"] {
        let from = if name == "resources/cable.fmu" { other } else { base };
        z.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
        z.write_all(&entry(from, name)).unwrap();
    }
    z.finish().unwrap();
    out
}

/// The CSV of `run --system` over 0.5 s with `scheme` (and `extra` options).
fn run(ssp: &Path, scheme: &str, extra: &[&str]) -> Vec<u8> {
    let csv = ssp.with_extension(format!("{scheme}{}.csv", extra.join("")));
    let _ = std::fs::remove_file(&csv);
    let mut args = vec!["run", "--system", ssp.to_str().unwrap(), "--scheme", scheme, "--t-end", "0.5"];
    args.extend(extra);
    args.extend(["--out", csv.to_str().unwrap()]);
    let out = master(&args);
    assert!(out.status.success(), "{scheme} {extra:?}: {}", String::from_utf8_lossy(&out.stderr));
    std::fs::read(csv).unwrap()
}

#[test]
fn fmi3_fmus_run_the_system_bit_for_bit_like_fmi2() {
    let (v2, v3) = (export("2"), export("3"));
    let fmu = |ssp: &Path| {
        let mut z = zip::ZipArchive::new(std::fs::File::open(ssp).unwrap()).unwrap();
        let mut bytes = Vec::new();
        z.by_name("resources/cable.fmu").unwrap().read_to_end(&mut bytes).unwrap();
        let path = ssp.with_extension("cable.fmu");
        std::fs::write(&path, bytes).unwrap();
        fmi::import::Fmu::load(&path).unwrap().fmi_major_version()
    };
    assert_eq!((fmu(&v2), fmu(&v3)), (2, 3), "the archives hold the FMUs of the version asked for");
    let both = mixed(&v2, &v3);
    for (scheme, extra) in
        [("ijcsa", &["--dt", "0.01"][..]), ("iqn-ils", &["--dt", "0.01"]), ("ijcsa", &["--adaptive"])]
    {
        let reference = run(&v2, scheme, extra);
        assert!(reference.len() > 1000, "{scheme}: a CSV of some length");
        assert!(run(&v3, scheme, extra) == reference, "{scheme} {extra:?}: FMI 3.0 differs from FMI 2.0");
        assert!(run(&both, scheme, extra) == reference, "{scheme} {extra:?}: the mixed system differs");
    }
}

#[test]
fn export_ssp_fmi3_names_a_missing_twin() {
    let file = common::scene_file("lt50m_B.toml", "fmi3-missing", |_| {});
    let cable = common::fmu_dir().join("cable_fmu.fmu").display().to_string();
    let text = std::fs::read_to_string(&file).unwrap().replace(&cable, "/nonexistent/cable_fmu.fmu");
    std::fs::write(&file, text).unwrap();
    let ssp = common::fmu_dir().join("missing.ssp");
    let out = master(&["export-ssp", "--scene", file.to_str().unwrap(), "--out", ssp.to_str().unwrap(), "--fmi", "3"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("/nonexistent/fmi3/cable_fmu.fmu"), "{err}");
    assert!(err.contains("master package"), "{err}");
    let out = master(&["export-ssp", "--scene", file.to_str().unwrap(), "--out", ssp.to_str().unwrap(), "--fmi", "4"]);
    assert!(!out.status.success() && !ssp.exists());
}

/// The importer sets whole FMI 3.0 arrays: a set of some elements reads the others first, so
/// they keep their values.
#[test]
fn a_set_of_some_elements_of_an_array_keeps_the_others() {
    let fmu = fmi::import::Fmu::load(&common::fmu_dir().join("fmi3/cable_fmu.fmu")).unwrap();
    let f = ["wrench.f[1]", "wrench.f[2]", "wrench.f[3]"].map(|n| fmu.value_reference(n).unwrap());
    let mut i = fmu.instantiate("partial", false).unwrap();
    i.setup_experiment(None, 0.0, None).unwrap();
    i.enter_initialization_mode().unwrap();
    let mut before = [0.0; 3];
    i.get_real(&f, &mut before).unwrap();
    assert!(before[2] < 0.0, "the platform's weight: {before:?}");
    i.set_real(&[f[1]], &[before[1] + 5.0]).unwrap();
    let mut after = [0.0; 3];
    i.get_real(&f, &mut after).unwrap();
    assert_eq!(after, [before[0], before[1] + 5.0, before[2]]);
}
