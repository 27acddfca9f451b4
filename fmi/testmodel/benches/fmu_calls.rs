//! Costs of the FMI layer, measured on the test oscillator (whose physics costs ~10 ns):
//! loading an FMU, and one `fmi2DoStep` (plus `fmi2SetReal`/`fmi2GetReal`) through the importer
//! against the same step called in-process. Run: `cargo bench -p fmi_testmodel`.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use fmi::export::Model;
use fmi::import::Fmu;
use fmi_testmodel::{Oscillator, vr};

fn library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    [deps.to_owned(), deps.parent().unwrap().to_owned()]
        .into_iter()
        .map(|d| d.join("libfmi_testmodel.so"))
        .find(|p| p.is_file())
        .expect("libfmi_testmodel.so beside the bench binary")
}

/// Median of `reps` timings of `f`, each divided by `per` (calls per timing), in seconds.
fn median(reps: usize, per: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() / per as f64
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

/// A fresh copy of an unpacked FMU (a new file, so that dlopen really loads it).
fn copy_unpacked(from: &Path, to: &Path) {
    for sub in ["binaries/linux64", "resources"] {
        std::fs::create_dir_all(to.join(sub)).unwrap();
    }
    for f in ["modelDescription.xml", "binaries/linux64/oscillator.so", "resources/oscillator.txt"] {
        std::fs::copy(from.join(f), to.join(f)).unwrap();
    }
}

fn main() {
    let dir = std::env::temp_dir().join(format!("fmi2-bench-{}", std::process::id()));
    let archive = fmi::package::package_model::<Oscillator>(&dir, &library()).unwrap();
    let size = std::fs::metadata(&archive).unwrap().len();

    let load = median(21, 1, || drop(black_box(Fmu::load(&archive).unwrap())));
    let fmu = Fmu::load(&archive).unwrap();
    let copies: Vec<PathBuf> = (0..21).map(|k| dir.join(format!("copy{k}"))).collect();
    for c in &copies {
        copy_unpacked(fmu.root(), c);
    }
    let mut next = copies.iter();
    let load_unpacked = median(21, 1, || drop(black_box(Fmu::load_unpacked(next.next().unwrap()).unwrap())));
    let instantiate = median(21, 100, || {
        for _ in 0..100 {
            let mut i = fmu.instantiate("bench", false).unwrap();
            i.setup_experiment(None, 0.0, None).unwrap();
            i.enter_initialization_mode().unwrap();
            i.exit_initialization_mode().unwrap();
            black_box(&mut i);
        }
    });

    const N: usize = 100_000;
    let h = 0.01;
    let mut inst = fmu.instantiate("bench", false).unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    // A constant force keeps the state away from zero (a decaying oscillation would end in
    // subnormal numbers, which are slow).
    inst.set_real(&[vr::F], &[1.0]).unwrap();
    let mut t = 0.0;
    let do_step = median(9, N, || {
        for _ in 0..N {
            inst.do_step(t, h).unwrap();
            t += h;
        }
    });
    let mut y = [0.0; 3];
    let step_io = median(9, N, || {
        for k in 0..N {
            inst.set_real(&[vr::F], &[1.0 + (k % 7) as f64]).unwrap();
            inst.do_step(t, h).unwrap();
            inst.get_real(&[vr::X, vr::V, vr::A], &mut y).unwrap();
            t += h;
        }
    });
    let state = inst.get_state().unwrap();
    let rollback = median(9, N, || {
        for _ in 0..N {
            inst.update_state(&state).unwrap();
            inst.set_state(&state).unwrap();
        }
    });

    let mut m = Oscillator::instantiate(Some(&fmu.root().join("resources"))).unwrap();
    m.exit_initialization(0.0).unwrap();
    m.set_real(vr::F, 1.0).unwrap();
    let mut tm = 0.0;
    let in_process = median(9, N, || {
        for _ in 0..N {
            m.do_step(black_box(tm), h).unwrap();
            tm += h;
        }
    });

    println!("oscillator.fmu: {:.1} MB", size as f64 / 1e6);
    let rows = [
        ("Fmu::load (unzip + parse XML + dlopen + 34 symbols)", load * 1e3, "ms"),
        ("Fmu::load_unpacked (parse XML + dlopen + 34 symbols)", load_unpacked * 1e3, "ms"),
        ("instantiate + initialize + free", instantiate * 1e6, "µs"),
        ("fmi2DoStep through the importer", do_step * 1e9, "ns"),
        ("  the same step in-process (Model::do_step)", in_process * 1e9, "ns"),
        ("  → layer + FFI overhead per fmi2DoStep", (do_step - in_process) * 1e9, "ns"),
        ("SetReal(F) + DoStep + GetReal(x, v, a)", step_io * 1e9, "ns"),
        ("GetFMUstate (in place) + SetFMUstate", rollback * 1e9, "ns"),
    ];
    for (what, value, unit) in rows {
        println!("{what:<54} {value:>9.3} {unit}");
    }
    drop(inst);
    drop(fmu);
    let _ = std::fs::remove_dir_all(&dir);
}
