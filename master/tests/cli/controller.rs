//! The second level as an FMU of its own (`control_fmu`, `export-ssp --controller fmu`): the
//! three-FMU system — cable, Stewart following its command input, the controller at its sample
//! period — against the two-FMU system with the built-in controller (same sample instants, same
//! noise) and against the monolithic model.

use std::path::{Path, PathBuf};

use crate::{common, master};

/// `master export-ssp` of `scene_file` into `dir` (`--controller fmu` when `three`, FMI `version`).
fn export(scene_file: &Path, dir: &Path, three: bool, version: u8) -> PathBuf {
    let ssp = dir.join(format!("{}-fmi{version}.ssp", if three { "three" } else { "two" }));
    let mut args = vec!["export-ssp", "--scene", scene_file.to_str().unwrap(), "--out", ssp.to_str().unwrap()];
    let v = version.to_string();
    args.extend(["--fmi", &v]);
    if three {
        args.extend(["--controller", "fmu"]);
    }
    let out = master(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    ssp
}

/// A CSV the master wrote: its header and its rows.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(str::to_owned).collect();
    let rows = lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    (header, rows)
}

/// The columns `names` of a CSV, row by row.
fn columns(csv: &(Vec<String>, Vec<Vec<f64>>), names: &[&str]) -> Vec<Vec<f64>> {
    let at: Vec<usize> = names
        .iter()
        .map(|n| csv.0.iter().position(|h| h == n).unwrap_or_else(|| panic!("no column {n} in {:?}", csv.0)))
        .collect();
    csv.1.iter().map(|row| at.iter().map(|&j| row[j]).collect()).collect()
}

/// The feed error (m) of every step of `master run --system` of `ssp`.
fn feed_error(ssp: &Path, scheme: &str, t_end: f64, out: &Path) -> Vec<Vec<f64>> {
    let t = t_end.to_string();
    let args = ["run", "--system", ssp.to_str().unwrap(), "--scheme", scheme, "--dt", "0.0025", "--t-end", &t];
    let run = master(&[&args[..], &["--out", out.to_str().unwrap()]].concat());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    columns(&read_csv(out), &["stewart.feed.err[1]", "stewart.feed.err[2]", "stewart.feed.err[3]"])
}

fn largest_gap(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs())).fold(0.0, f64::max)
}

fn peak(a: &[Vec<f64>]) -> f64 {
    a.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max)
}

/// LT50m C compensated over 20 s at the scene's step: the three-FMU system gives the two-FMU
/// system's feed error within 1e-6 of its peak with IJCSA and IQN-ILS, and keeps the monolithic
/// model's feed error at the distance the two-FMU system keeps (about 1.5e-3 of the peak).
#[test]
fn three_fmus_give_the_two_fmu_systems_feed_error() {
    let (_, file) = common::scene("lt50m_C_compensated.toml", "three", |_| {});
    let dir = common::fmu_dir().join("three-fmus");
    std::fs::create_dir_all(&dir).unwrap();
    let (two, three) = (export(&file, &dir, false, 2), export(&file, &dir, true, 2));
    // every component carries its step; the controller its command period, 10 ms (the inertial unit's)
    let loaded = studies::cosim::ssp::read::load(&three).unwrap();
    let steps: Vec<(&str, Option<f64>)> = loaded.spec.components.iter().map(|c| (c.name.as_str(), c.step)).collect();
    assert_eq!(steps, [("cable", Some(0.0025)), ("stewart", Some(0.0025)), ("control", Some(0.01))]);
    let mono = dir.join("mono.csv");
    let run = master(&[
        "run",
        "--scene",
        file.to_str().unwrap(),
        "--scheme",
        "monolithic",
        "--t-end",
        "20",
        "--out",
        mono.to_str().unwrap(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let mono: Vec<Vec<f64>> = columns(&read_csv(&mono), &["feed_err_x_mm", "feed_err_y_mm", "feed_err_z_mm"])
        .into_iter()
        .map(|r| r.iter().map(|x| x * 1e-3).collect())
        .collect();
    for scheme in ["ijcsa", "iqn-ils"] {
        let a = feed_error(&two, scheme, 20.0, &dir.join(format!("two-{scheme}.csv")));
        let b = feed_error(&three, scheme, 20.0, &dir.join(format!("three-{scheme}.csv")));
        let p = peak(&a);
        let gap = largest_gap(&a, &b) / p;
        assert!(gap < 1e-6, "{scheme}: three FMUs against two: {gap:e} of the peak {p:e} m");
        // the monolithic model writes every 4th step (10 ms)
        let every4 = |x: &[Vec<f64>]| x.iter().step_by(4).cloned().collect::<Vec<_>>();
        let (to_two, to_three) = (largest_gap(&every4(&a), &mono) / p, largest_gap(&every4(&b), &mono) / p);
        assert!(to_two < 2e-3 && (to_three - to_two).abs() < 1e-6, "{scheme}: {to_two:e} {to_three:e}");
        eprintln!("{scheme}: peak {p:e} m, three vs two {gap:e}, vs monolithic {to_two:e} / {to_three:e}");
    }
}

/// control_fmu runs whatever law the scene's `[control]` has: the LQG law of `lt50m_C_lqg`
/// (its controller at each reading of its inertial unit, every 10 ms) gives the two-FMU system's
/// feed error within 1e-6 of its peak over 5 s (IJCSA).
#[test]
fn control_fmu_runs_the_lqg_law_as_the_built_in_controller() {
    let (_, file) = common::scene("lt50m_C_lqg.toml", "three-lqg", |_| {});
    let dir = common::fmu_dir().join("three-lqg");
    std::fs::create_dir_all(&dir).unwrap();
    let (two, three) = (export(&file, &dir, false, 2), export(&file, &dir, true, 2));
    let a = feed_error(&two, "ijcsa", 5.0, &dir.join("two.csv"));
    let b = feed_error(&three, "ijcsa", 5.0, &dir.join("three.csv"));
    let (p, gap) = (peak(&a), largest_gap(&a, &b) / peak(&a));
    assert!(p > 1e-5 && gap < 1e-6, "LQG: three FMUs against two: {gap:e} of the peak {p:e} m");
}

/// The FMI 3.0 twins (cable, Stewart, control) give the FMI 2.0 system's run bit for bit.
#[test]
fn the_fmi3_three_fmu_system_equals_the_fmi2_one() {
    let (_, file) = common::scene("lt50m_C_compensated.toml", "three3", |_| {});
    let dir = common::fmu_dir().join("three-fmus-3");
    std::fs::create_dir_all(&dir).unwrap();
    let (two, three) = (export(&file, &dir, true, 2), export(&file, &dir, true, 3));
    let (a, b) = (dir.join("fmi2.csv"), dir.join("fmi3.csv"));
    for (ssp, out) in [(&two, &a), (&three, &b)] {
        let run = master(&[
            "run",
            "--system",
            ssp.to_str().unwrap(),
            "--scheme",
            "ijcsa",
            "--dt",
            "0.0025",
            "--t-end",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    }
    let (a, b) = (read_csv(&a), read_csv(&b));
    assert_eq!(a.0, b.0);
    assert_eq!(a.1.len(), 801);
    let same = a.1.iter().flatten().zip(b.1.iter().flatten()).all(|(x, y)| x.to_bits() == y.to_bits());
    assert!(same, "the FMI 3.0 system's CSV differs from the FMI 2.0 one");
}

/// `--controller fmu` refuses, by name, a scene without a second level to take out and one whose
/// sensor is not sampled; nothing is written.
#[test]
fn a_controller_fmu_needs_a_sampled_second_level() {
    let dir = common::fmu_dir().join("three-refused");
    std::fs::create_dir_all(&dir).unwrap();
    let ssp = dir.join("x.ssp");
    let (_, no_control) = common::scene("lt50m_C.toml", "noctl", |_| {});
    // scene C with an ideal sensor, its [system] pointed at the packaged FMUs as common::scene does
    let ideal = {
        let text = std::fs::read_to_string(common::scene_path("lt50m_C.toml")).unwrap()
            + "\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"hold\"\nsensor = \"ideal\"\n";
        let mut s = feedcore::scene::Scene::from_toml(&text, "ideal.toml").unwrap().to_scene();
        for f in s.system.iter_mut().flat_map(|system| &mut system.fmus) {
            f.path = common::fmu_dir().join(format!("{}_fmu.fmu", f.name)).display().to_string();
        }
        let file = dir.join("ideal.toml");
        std::fs::write(&file, s.to_toml()).unwrap();
        file
    };
    for (file, reason) in [(no_control, "has no [control]"), (ideal, "sensor = \"sampled\"")] {
        let (file, out) = (file.to_str().unwrap(), ssp.to_str().unwrap());
        let run = master(&["export-ssp", "--scene", file, "--out", out, "--controller", "fmu"]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && err.contains("--controller fmu") && err.contains(reason), "{err}");
        assert!(!ssp.exists());
    }
}
