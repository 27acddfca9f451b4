//! Shared set-up of the master's system tests: the FMUs packaged from the built libraries into
//! a private directory, and scenes whose [system] section points there.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use feedcore::scene::{Scene, ValidScene};

/// The directory holding `lib<crate>.so`: next to the test binary's `deps/` (cargo puts both
/// in `target/<profile>/`).
fn library(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    for dir in [deps, deps.parent().unwrap()] {
        let p = dir.join(format!("lib{name}.so"));
        if p.is_file() {
            return p;
        }
    }
    panic!("lib{name}.so not found next to {}: run `cargo build --release --workspace` first", exe.display());
}

/// Both FMUs, packaged once per test binary; their FMI 3.0 twins in `fmi3/` below.
pub(crate) fn fmu_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("master-tests-{}", std::process::id()));
        let (cable, stewart) = (library("cable_fmu_cdylib"), library("stewart_fmu_cdylib"));
        fmi2::package::package_model::<cable_fmu::CableFmu>(&dir, &cable).unwrap();
        fmi2::package::package_model::<stewart_fmu::StewartFmu>(&dir, &stewart).unwrap();
        fmi2::package::package_model3::<cable_fmu::CableFmu>(&dir.join("fmi3"), &cable).unwrap();
        fmi2::package::package_model3::<stewart_fmu::StewartFmu>(&dir.join("fmi3"), &stewart).unwrap();
        dir
    })
}

pub(crate) fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR")))
}

/// A reference scene, edited by `edit`, written to a private file whose [system] names the
/// packaged FMUs; returns the scene and its file.
pub(crate) fn scene(name: &str, tag: &str, edit: impl FnOnce(&mut Scene)) -> (ValidScene, PathBuf) {
    let file = scene_file(name, tag, edit);
    (Scene::load(&file).unwrap(), file)
}

/// As [`scene`], without validating the edited scene (for scenes the command must refuse).
pub(crate) fn scene_file(name: &str, tag: &str, edit: impl FnOnce(&mut Scene)) -> PathBuf {
    let mut s = Scene::load(scene_path(name)).unwrap().to_scene();
    edit(&mut s);
    let dir = fmu_dir();
    for f in s.system.iter_mut().flat_map(|system| &mut system.fmus) {
        f.path = dir.join(format!("{}_fmu.fmu", f.name)).display().to_string();
    }
    let file = dir.join(format!("{tag}-{name}"));
    std::fs::write(&file, s.to_toml()).unwrap();
    file
}
