//! `master run` and `master compare` from the command line: outputs, files and exit codes.

use crate::{common, master};

#[test]
fn run_writes_json_csv_and_plot() {
    let (_, file) = common::scene("lt50m_C.toml", "cli", |_| {});
    let dir = common::fmu_dir();
    let (csv, svg) = (dir.join("run.csv"), dir.join("run.svg"));
    let out = master(&[
        "run",
        "--scene",
        file.to_str().unwrap(),
        "--scheme",
        "ijcsa",
        "--t-end",
        "1",
        "--json",
        "--out",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "scheme",
        "dt",
        "t_end",
        "steps",
        "wall_time_s",
        "max_abs_disp_mm",
        "mean_iterations",
        "max_interface_residual",
    ] {
        assert!(v.get(key).is_some(), "JSON key `{key}` missing: {v}");
    }
    assert_eq!(v["steps"], 100);
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    for col in ["t", "dx_mm", "dy_mm", "dz_mm", "rx_mrad", "fx_n", "mz_nm"] {
        assert!(header.split(',').any(|c| c == col), "column {col} missing: {header}");
    }
    assert_eq!(text.lines().count(), 1 + 101);
    // the JSON peak is the CSV's
    let peak_x =
        text.lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse::<f64>().unwrap().abs()).fold(0.0, f64::max);
    assert_eq!(peak_x, v["max_abs_disp_mm"][0].as_f64().unwrap());
    let svg_text = std::fs::read_to_string(&svg).unwrap();
    assert!(svg_text.starts_with("<svg") || svg_text.starts_with("<?xml"));
}

#[test]
fn failures_exit_non_zero_with_a_reason() {
    let (_, file) = common::scene("lt50m_C.toml", "cli-fail", |_| {});
    let f = file.to_str().unwrap();
    let out = master(&["run", "--scene", f, "--scheme", "jacobi", "--t-end", "5", "--quiet"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("jacobi diverged") && err.contains("t = ") && err.contains("unstable"), "{err}");
    let out = master(&["run", "--scene", f, "--scheme", "iterative", "--max-iter", "2", "--t-end", "1", "--quiet"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("did not converge in 2 iterations"));
    let out = master(&["run", "--scene", f, "--scheme", "newton", "--quiet"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("'newton'") && err.contains("ijcsa") && err.contains("monolithic"), "{err}");
    let out = master(&["run", "--scene", f, "--scheme", "ijcsa", "--plot", "x.png", "--t-end", "0.02", "--quiet"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("only SVG"));
}

/// An FMU that returns an error stops the run with a message naming the FMU and the problem.
#[test]
fn an_fmu_error_names_the_fmu() {
    let (_, file) = common::scene("lt50m_C.toml", "cli-fmu-error", |s| s.motion.radius_m = 1.5);
    let out = master(&["run", "--scene", file.to_str().unwrap(), "--scheme", "ijcsa", "--quiet"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("FMU `stewart_fmu`") && err.contains("leg") && err.contains("t = "), "{err}");
}

#[test]
fn missing_fmus_say_how_to_build_them() {
    let mut s = feedcore::scene::Scene::load(common::scene_path("lt50m_C.toml")).unwrap().to_scene();
    s.system.as_mut().unwrap().fmus[0].path = "/nonexistent/cable_fmu.fmu".into();
    let file = common::fmu_dir().join("missing.toml");
    std::fs::write(&file, s.to_toml()).unwrap();
    let out = master(&["run", "--scene", file.to_str().unwrap(), "--scheme", "ijcsa", "--quiet"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent/cable_fmu.fmu") && err.contains("master package"), "{err}");
}

#[test]
fn compare_lists_every_scheme_against_monolithic() {
    let (_, file) = common::scene("lt50m_B.toml", "cli-compare", |_| {});
    let out = master(&[
        "compare",
        "--scene",
        file.to_str().unwrap(),
        "--schemes",
        "ijcsa,jacobi,decoupled",
        "--t-end",
        "1",
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["schemes"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert!(rows[0]["max_error_mm"].as_f64().unwrap() < 1e-3);
    // jacobi is unstable on B as well (it breaks down at 0.63 s): reported as failed, not hidden
    assert!(rows[1]["failed"].as_str().unwrap().contains("unstable"), "{}", rows[1]);
    assert!(rows[2]["max_error_mm"].as_f64().unwrap() > 0.0);
}

/// A cable-only scene runs the cable–cabin model alone: no [system], so no FMU can be loaded,
/// and with the damping fitted at given frequencies no eigen solve is needed.
#[test]
fn a_cable_only_scene_loads_and_computes_only_the_cable_model() {
    let path = common::scene_path("lt50m_C_cable_only.toml");
    let scene = feedcore::scene::Scene::load(&path).unwrap();
    assert!(scene.system.is_none());
    assert!(cable::model::CableCabin::build(&scene, 0).unwrap().modes.is_none(), "no eigen solve");
    let csv = common::fmu_dir().join("cable-only.csv");
    let out = master(&[
        "run",
        "--scene",
        path.to_str().unwrap(),
        "--scheme",
        "cable",
        "--t-end",
        "10",
        "--json",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // the 50 N rotating force moves the cabin by millimetres (static compliance ≈ 0.09 mm/N)
    let x = v["max_abs_disp_mm"][0].as_f64().unwrap();
    assert!(x > 1.0 && x < 20.0, "{x}");
    // the scene asks for displacement and rotation only: no wrench columns
    let header = std::fs::read_to_string(&csv).unwrap().lines().next().unwrap().to_string();
    assert_eq!(header, "t,dx_mm,dy_mm,dz_mm,rx_mrad,ry_mrad,rz_mrad");
    let out = master(&["run", "--scene", path.to_str().unwrap(), "--scheme", "ijcsa", "--quiet"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no moving platform"));
}

/// `master stress --quick` runs every stress case on the packaged FMUs and reports it.
#[test]
fn every_stress_case_runs() {
    let (_, c) = common::scene("lt50m_C.toml", "stress", |_| {});
    let (_, b) = common::scene("lt50m_B.toml", "stress", |_| {});
    let out = master(&["stress", "--quick", "--scene-c", c.to_str().unwrap(), "--scene-b", b.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(text.lines().filter(|l| l.contains("  ok  ")).count(), 7, "{text}");
    // the labels give the durations run: 50 times shorter, at least a tenth for the short cases
    for label in [
        "20 s, ijcsa, C",
        "20 s, monolithic, C",
        "E × 10, C, 2 s",
        "50 elements per cable, C, 2 s",
        "B: cable 4 nearly slack, ijcsa 2 s",
        "abrupt against ramp start (5 s), monolithic, C, 6 s",
        "platform held still, ijcsa and monolithic, B, 2 s",
    ] {
        assert!(text.contains(label), "{label} not in {text}");
    }
    assert!(!text.contains("1000 s") && !text.contains("100 s"), "{text}");
}

/// `master compensation` checks its runs as `master run` does, before any runs: a sample rate
/// whose step is not a number is refused by the scene, and --max-steps holds.
#[test]
fn compensation_honours_the_caps() {
    let (_, file) = common::scene("lt50m_C_sampled.toml", "comp-caps", |_| {});
    let out_dir = std::env::temp_dir().join(format!("master-comp-caps-{}", std::process::id()));
    let out = master(&[
        "compensation",
        "--scene",
        file.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--max-steps",
        "1000",
    ]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(e.contains("exceed the cap of 1000 steps") && e.contains("--max-steps"), "{e}");
    assert!(!out_dir.join("compensation.csv").exists(), "nothing written");
    for (k, rate) in [5e-324, 5e10].into_iter().enumerate() {
        let bad = common::scene_file("lt50m_C_sampled.toml", &format!("comp-rate-{k}"), |s| {
            s.control.as_mut().unwrap().sample_rate_hz = Some(rate)
        });
        let out = master(&["compensation", "--scene", bad.to_str().unwrap(), "--out", out_dir.to_str().unwrap()]);
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && e.contains("`control.sample_rate_hz`") && e.contains("1 MHz"), "{e}");
        assert!(!out_dir.join("compensation.csv").exists(), "nothing written");
    }
}

/// The peak and every summary figure come from every step, not from the samples: sampled every
/// 0.3 s (at h = 0.1 s), the JSON peak is that of the same run sampled at every step, which
/// the CSV of the latter confirms.
#[test]
fn the_summary_comes_from_every_step() {
    let dir = common::fmu_dir();
    let run = |interval: f64, csv: &std::path::Path| {
        let (_, file) =
            common::scene("lt50m_C.toml", &format!("every-{interval}"), |s| s.outputs.sample_interval_s = interval);
        let out = master(&[
            "run",
            "--scene",
            file.to_str().unwrap(),
            "--scheme",
            "monolithic",
            "--dt",
            "0.1",
            "--t-end",
            "20",
            "--json",
            "--out",
            csv.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (coarse_csv, fine_csv) = (dir.join("every-coarse.csv"), dir.join("every-fine.csv"));
    let coarse = run(0.25, &coarse_csv);
    let fine = run(0.1, &fine_csv);
    assert_eq!(coarse["sample_interval_s"].as_f64(), Some(0.30000000000000004));
    assert_eq!(fine["sample_interval_s"].as_f64(), Some(0.1));
    // per axis, the largest |displacement| in a CSV; and the largest distance
    let maxima = |csv: &std::path::Path| {
        let mut m = [0.0f64; 4];
        for l in std::fs::read_to_string(csv).unwrap().lines().skip(1) {
            let v: Vec<f64> = l.split(',').skip(1).take(3).map(|x| x.parse().unwrap()).collect();
            for k in 0..3 {
                m[k] = m[k].max(v[k].abs());
            }
            m[3] = m[3].max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
        }
        m
    };
    let (every_step, sampled) = (maxima(&fine_csv), maxima(&coarse_csv));
    for v in [&coarse, &fine] {
        let peak = v["peak_disp_mm"].as_f64().unwrap();
        assert!((peak - every_step[3]).abs() <= 1e-12 * peak, "{peak} against {every_step:?}");
        for k in 0..3 {
            assert_eq!(v["max_abs_disp_mm"][k].as_f64().unwrap(), every_step[k]);
        }
    }
    assert!((0..4).all(|k| sampled[k] <= every_step[k]));
    assert!((0..3).any(|k| sampled[k] < every_step[k]), "the samples miss a peak here: {sampled:?} {every_step:?}");
    assert_eq!(coarse["max_abs_disp_mm"], fine["max_abs_disp_mm"]);
}
