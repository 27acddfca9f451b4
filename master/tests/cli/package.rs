//! `master package` writes loadable FMUs; a missing library is a clear error.

use std::path::{Path, PathBuf};
use std::process::Command;

use fmi::import::Fmu;

/// Where cargo put `libfmi_testmodel.so` for this build: beside `master`, or in `deps/`.
fn lib_dir() -> PathBuf {
    let exe = Path::new(env!("CARGO_BIN_EXE_master"));
    let dir = exe.parent().unwrap();
    for d in [dir.to_owned(), dir.join("deps")] {
        if d.join("libfmi_testmodel.so").is_file() {
            return d;
        }
    }
    panic!("libfmi_testmodel.so not found beside {}", exe.display());
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fmi-package-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn package_writes_every_exportable_fmu_and_they_run() {
    let out = scratch("ok");
    let status = Command::new(crate::MASTER)
        .args(["package", "--out"])
        .arg(&out)
        .arg("--lib-dir")
        .arg(lib_dir())
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let fmu = Fmu::load(&out.join("oscillator.fmu")).unwrap();
    assert!(fmu.root().join("resources/oscillator.txt").is_file());
    let (f, x) = (fmu.value_reference("F").unwrap(), fmu.value_reference("x").unwrap());
    let mut i = fmu.instantiate("packaged", false).unwrap();
    i.setup_experiment(None, 0.0, None).unwrap();
    i.enter_initialization_mode().unwrap();
    i.exit_initialization_mode().unwrap();
    i.set_real(&[f], &[1.0]).unwrap();
    i.do_step(0.0, 0.01).unwrap();
    let mut y = [0.0];
    i.get_real(&[x], &mut y).unwrap();
    assert!(y[0] < 0.1, "the spring pulls the mass back from x0 = 0.1: {}", y[0]);
    drop(i);
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_missing_library_names_the_cargo_command() {
    let out = scratch("missing");
    let empty = scratch("empty-libs");
    std::fs::create_dir_all(&empty).unwrap();
    let r =
        Command::new(crate::MASTER).args(["package", "--out"]).arg(&out).arg("--lib-dir").arg(&empty).output().unwrap();
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("libfmi_testmodel.so not found: build it with `cargo build --release -p fmi_testmodel`"),
        "{err}"
    );
    assert!(!out.join("oscillator.fmu").exists());
    std::fs::remove_dir_all(&empty).unwrap();
}
