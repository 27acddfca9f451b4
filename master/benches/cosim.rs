//! Costs of the FMUs as the master sees them: loading, one `fmi2DoStep` of each FMU at
//! h = 0.01 s, a rollback, a directional derivative, one macro step of every coupling scheme,
//! and one step of the monolithic model; the zoo's Dahlquist FMU integrated by the master
//! (Model Exchange; `-- model-exchange` runs that part alone). Needs the libraries of
//! `cargo build --release --workspace`.

use std::path::PathBuf;

use feedcore::benchkit::{bench, human};
use feedcore::scene::Scene;
use fmi::import::Fmu;
use studies::cosim::{Coupled, FmuSystem, JacobianUpdate, Options, Scheme};
use studies::monolithic::Monolithic;

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
    // `cargo bench -p master --bench cosim -- model-exchange`: that part alone
    if std::env::args().any(|a| a == "model-exchange") {
        model_exchange(&dir);
        let _ = std::fs::remove_dir_all(&dir);
        return;
    }
    let cable = fmi::package::package_model::<cable_fmu::CableFmu>(&dir, &library("cable_fmu_cdylib")).unwrap();
    let stewart = fmi::package::package_model::<stewart_fmu::StewartFmu>(&dir, &library("stewart_fmu_cdylib")).unwrap();
    let scene_file = PathBuf::from(format!("{}/../scenes/lt50m_C.toml", env!("CARGO_MANIFEST_DIR")));
    let mut scene = Scene::load(&scene_file).unwrap().to_scene();
    for f in &mut scene.system.as_mut().unwrap().fmus {
        f.path = dir.join(format!("{}_fmu.fmu", f.name)).display().to_string();
    }
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene.to_toml()).unwrap();
    let scene = scene.validated(&file.display().to_string()).unwrap();

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
        let outputs = inst.value_references(fmi::Causality::Output, fmi::VarType::Real);
        let inputs = inst.value_references(fmi::Causality::Input, fmi::VarType::Real);
        let mut col = vec![0.0; outputs.len()];
        bench(&format!("{name}: directional derivative, one input, all outputs"), 1.0, || {
            inst.directional_derivative(&outputs, &inputs[..1], &[1.0], &mut col).unwrap()
        });
    }

    let spec = studies::system::scene_spec(&scene, &file).unwrap();
    let coupled = |scheme, jacobian| {
        let options = Options { scheme, jacobian, ..Options::default() };
        let system = FmuSystem::load(&spec, &studies::system::needs(&options, false)).unwrap();
        Coupled::new(system, options).unwrap()
    };
    println!("One macro step of each scheme at C, h = 0.01 s");
    // The schemes that iterate: the step and its rollback, 1 s into the motion, so that every
    // take starts from the same state (a reused Jacobian and the quasi-Newton history included).
    for (label, scheme, jacobian) in [
        ("iterative", Scheme::Iterative, JacobianUpdate::EveryStep),
        ("ijcsa", Scheme::Ijcsa, JacobianUpdate::EveryStep),
        ("ijcsa, Jacobian reused", Scheme::Ijcsa, JacobianUpdate::Reuse),
        ("iqn-ils", Scheme::IqnIls, JacobianUpdate::EveryStep),
    ] {
        let mut c = coupled(scheme, jacobian);
        for _ in 0..100 {
            c.step(0.01).unwrap();
        }
        bench(&format!("{label}: macro step + rollback"), 2.0, || {
            c.step(0.01).unwrap();
            c.undo_step().unwrap();
        });
    }
    // The explicit schemes cannot roll back, and their coupled motion at C runs away within a
    // second (the added mass): the first 20 steps from the start, five times.
    for (label, scheme) in [("jacobi", Scheme::Jacobi), ("gauss-seidel", Scheme::GaussSeidel { reversed: false })] {
        let mut per_step: Vec<f64> = (0..5)
            .map(|_| {
                let mut c = coupled(scheme, JacobianUpdate::EveryStep);
                let start = std::time::Instant::now();
                for _ in 0..20 {
                    c.step(0.01).unwrap();
                }
                start.elapsed().as_secs_f64() / 20.0
            })
            .collect();
        per_step.sort_by(f64::total_cmp);
        println!(
            "{:<48} {:>12} per call  (median of 5 runs of 20 steps)",
            format!("{label}: macro step"),
            human(per_step[2])
        );
    }
    let mut m = Monolithic::new(&scene).unwrap();
    bench("monolithic step (eq. 7, sparse LU)", 2.0, || m.step(0.01).unwrap());

    model_exchange(&dir);

    let _ = std::fs::remove_dir_all(&dir);
}

/// The zoo's Dahlquist FMU (ẋ = −x + 1 from 0) as a Model Exchange unit the master integrates:
/// its default 10 s run, 100 Jacobi macro steps of 0.1 s, timed from a fresh system (loading
/// not counted), at the default tolerance and at rtol 1e-10; its error against 1 − e^{−10}.
fn model_exchange(dir: &std::path::Path) {
    use studies::cosim::system::spec::{Component, Endpoint, Parameter, Value};
    let fmu =
        fmi::package::package_model::<zoo_fmus::dahlquist::DahlquistFmu>(&dir.join("zoo"), &library("zoo_dahlquist"))
            .unwrap();
    let real = |v: &str, x: f64| Parameter {
        target: Endpoint { component: "d".into(), variable: v.into() },
        value: Value::Typed(fmi::Value::Real(x)),
    };
    let spec = studies::cosim::SystemSpec {
        origin: "dahlquist as Model Exchange".into(),
        components: vec![Component {
            name: "d".into(),
            source: fmu,
            interface: Some(fmi::import::Interface::ModelExchange),
        }],
        connections: Vec::new(),
        parameters: vec![real("x0", 0.0), real("u", 1.0)],
        connectors: Vec::new(),
        observed: vec!["d.x".into()],
        watch: Vec::new(),
        kink_at_start: false,
    };
    println!("Dahlquist (zoo FMU) as Model Exchange: 10 s in 100 Jacobi macro steps, stepping only");
    for (method, rtol, atol) in [
        (cosim::me::Method::Dopri5, 1e-6, 1e-8),
        (cosim::me::Method::Dopri5, 1e-10, 1e-12),
        (cosim::me::Method::Esdirk3, 1e-6, 1e-8),
    ] {
        let options = Options { scheme: Scheme::Jacobi, ..Options::default() };
        let needs = studies::cosim::Needs {
            model_exchange: cosim::me::MeOptions { method, tol: cosim::me::Tolerances { rtol, atol } },
            ..studies::system::needs(&options, false)
        };
        let mut runs: Vec<(f64, f64, u64)> = (0..31)
            .map(|_| {
                let mut c = Coupled::new(FmuSystem::load(&spec, &needs).unwrap(), options).unwrap();
                let start = std::time::Instant::now();
                for _ in 0..100 {
                    c.step(0.1).unwrap();
                }
                let elapsed = start.elapsed().as_secs_f64();
                let names = &studies::cosim::Units::layout(c.units()).output_names;
                let x = c.outputs()[names.iter().position(|n| n == "d.x").expect("d.x is observed")];
                (elapsed, (x - (1.0 - (-10.0_f64).exp())).abs(), c.units().model_exchange_stats()[0].2.steps)
            })
            .collect();
        runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (median, error, steps) = runs[15];
        println!(
            "{:<48} {:>12} per run   (median of 31; {steps} integrator steps, |x(10) - (1 - e^-10)| = {error:.1e})",
            format!("{}, rtol {rtol:e}", method.name()),
            human(median)
        );
    }
}
