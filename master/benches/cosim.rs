//! Costs of the FMUs as the master sees them: loading, one `fmi2DoStep` of each FMU at
//! h = 0.01 s, a rollback, a directional derivative, and one co-simulation macro step (IJCSA),
//! next to one step of the monolithic model. Needs the libraries of
//! `cargo build --release --workspace`.

use std::path::PathBuf;

use feedcore::benchkit::bench;
use feedcore::scene::Scene;
use fmi2::import::Fmu;
use master::cosim::{Coupled, FmuSystem, Options, Scheme};
use master::monolithic::Monolithic;

fn library(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    [deps, deps.parent().unwrap()]
        .iter()
        .map(|d| d.join(format!("lib{name}.so")))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("lib{name}.so not found: run `cargo build --release --workspace` first"))
}

fn main() {
    let dir = std::env::temp_dir().join(format!("master-bench-{}", std::process::id()));
    let cable = fmi2::package::package_model::<cable_fmu::CableFmu>(&dir, &library("cable_fmu_cdylib")).unwrap();
    let stewart =
        fmi2::package::package_model::<stewart_fmu::StewartFmu>(&dir, &library("stewart_fmu_cdylib")).unwrap();
    let scene_file = PathBuf::from(format!("{}/../scenes/lt50m_C.toml", env!("CARGO_MANIFEST_DIR")));
    let mut scene = Scene::load(&scene_file).unwrap();
    for f in &mut scene.system.as_mut().unwrap().fmus {
        f.path = dir.join(format!("{}_fmu.fmu", f.name)).display().to_string();
    }
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene.to_toml()).unwrap();

    println!("FMUs of scene C (20 elements per cable), h = 0.01 s");
    bench("load cable_fmu.fmu (unzip + XML + dlopen)", 2.0, || Fmu::load(&cable).unwrap());
    let unpacked = Fmu::load(&cable).unwrap();
    bench("load cable_fmu, already unpacked", 1.0, || Fmu::load_unpacked(unpacked.root()).unwrap());
    bench("load stewart_fmu.fmu (unzip + XML + dlopen)", 2.0, || Fmu::load(&stewart).unwrap());

    for (name, path) in [("cable_fmu", &cable), ("stewart_fmu", &stewart)] {
        let fmu = Fmu::load(path).unwrap();
        let mut inst = fmu.instantiate("bench", false).unwrap();
        inst.setup_experiment(None, 0.0, None).unwrap();
        inst.enter_initialization_mode().unwrap();
        inst.exit_initialization_mode().unwrap();
        let mut t = 0.0;
        bench(&format!("{name}: fmi2DoStep"), 1.0, || {
            inst.do_step(t, 0.01).unwrap();
            t += 0.01;
        });
        let state = inst.get_state().unwrap();
        bench(&format!("{name}: fmi2GetFMUstate (in place) + fmi2SetFMUstate"), 1.0, || {
            inst.update_state(&state).unwrap();
            inst.set_state(&state).unwrap();
        });
        let outputs = inst.value_references(fmi2::Causality::Output, fmi2::VarType::Real);
        let inputs = inst.value_references(fmi2::Causality::Input, fmi2::VarType::Real);
        let mut col = vec![0.0; outputs.len()];
        bench(&format!("{name}: directional derivative, one input, all outputs"), 1.0, || {
            inst.directional_derivative(&outputs, &inputs[..1], &[1.0], &mut col).unwrap()
        });
    }

    let options = Options { scheme: Scheme::Ijcsa, ..Options::default() };
    let spec = master::system::scene_spec(&scene, &file).unwrap();
    let system = FmuSystem::load(&spec, &master::system::needs(&options, false)).unwrap();
    let mut c = Coupled::new(system, options).unwrap();
    bench("ijcsa macro step (2 iterations + Jacobian)", 2.0, || c.step(0.01).unwrap());
    let mut m = Monolithic::new(&scene).unwrap();
    bench("monolithic step (eq. 7, sparse LU)", 2.0, || m.step(0.01).unwrap());

    let _ = std::fs::remove_dir_all(&dir);
}
