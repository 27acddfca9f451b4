//! Shared set-up of the end-to-end tests: the oscillator packaged and imported.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use fmi::import::{Fmu, Instance};
use fmi_testmodel::Oscillator;

/// The cdylib cargo built beside this test binary (`target/<profile>/deps/`).
pub(crate) fn library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    for dir in [deps, deps.parent().unwrap()] {
        let p = dir.join("libfmi_testmodel.so");
        if p.is_file() {
            return p;
        }
    }
    panic!("libfmi_testmodel.so not found next to {}", exe.display());
}

/// Packaged once per test binary into a private directory.
pub(crate) fn archive() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("fmi2-testmodel-{}", std::process::id()));
        fmi::package::package_model::<Oscillator>(&dir, &library()).unwrap()
    })
}

pub(crate) fn fmu() -> Fmu {
    Fmu::load(archive()).unwrap()
}

pub(crate) fn ready(fmu: &Fmu, name: &str) -> Instance {
    let mut i = fmu.instantiate(name, false).unwrap();
    i.setup_experiment(None, 0.0, None).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    i
}
