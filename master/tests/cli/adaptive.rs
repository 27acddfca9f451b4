//! The adaptive macro step from the command line: `run --adaptive` (its JSON and CSV against
//! each other, the end time reached exactly, the accuracy against the monolithic model) and
//! `bench --adaptive-rtols` (its table against the fixed-step one).

use crate::{common, master};

/// Rows of a CSV file: the header and the values.
fn csv(path: &std::path::Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    (header, rows)
}

/// `compare`'s JSON: `schemes` with the adaptive step at rtol 1e-3 over 5 s of `scene` against the
/// monolithic model at h = 0.0025.
fn compare_adaptive_at_rtol_1e_3(scene: &str, schemes: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["compare", "--scene", scene, "--schemes", schemes, "--adaptive", "--rtol", "1e-3"];
    args.extend_from_slice(&["--dt", "0.0025", "--t-end", "5", "--json", "--quiet"]);
    args.extend_from_slice(extra);
    let out = master(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// IQN-ILS with the adaptive step over 5 s at C: a CSV row per accepted step with the step that
/// ended there, the steps adding up to the end time, which the last row reaches exactly; the
/// JSON figures are those of the rows; and the response agrees with the monolithic model within
/// rtol of the peak.
#[test]
fn an_adaptive_run_lands_on_the_end_time_and_meets_its_tolerance() {
    let (_, file) = common::scene("lt50m_C.toml", "adaptive-cli", |_| {});
    let f = file.to_str().unwrap();
    let out_csv = common::fmu_dir().join("adaptive-cli.csv");
    let out = master(&[
        "run",
        "--scene",
        f,
        "--scheme",
        "iqn-ils",
        "--adaptive",
        "--rtol",
        "1e-3",
        "--t-end",
        "5",
        "--json",
        "--out",
        out_csv.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["adaptive"], true);
    assert!(v["dt"].is_null() && v["sample_interval_s"].is_null(), "{v}");
    let (header, rows) = csv(&out_csv);
    assert_eq!(&header[..3], ["t", "h_s", "dx_mm"]);
    let steps = v["steps"].as_u64().unwrap();
    assert_eq!(rows.len() as u64, steps + 1, "a row per accepted step and the start");
    assert_eq!((rows[0][0], rows[0][1]), (0.0, 0.0));
    assert_eq!(rows.last().unwrap()[0], 5.0, "the last step lands on the end time");
    for w in rows.windows(2) {
        assert!((w[1][0] - w[0][0] - w[1][1]).abs() <= 1e-12, "{:?} → {:?}", w[0], w[1]);
    }
    let h: Vec<f64> = rows[1..].iter().map(|r| r[1]).collect();
    let (h_min, h_max) = h.iter().fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)));
    assert_eq!((v["h_min_used"].as_f64(), v["h_max_used"].as_f64()), (Some(h_min), Some(h_max)));
    assert!(h_min >= 1e-5 && h_max <= 0.1 && h_max > 100.0 * h_min, "the step adapts: {h_min} … {h_max}");
    assert!(v["rejected_steps"].as_u64().is_some());
    // every accepted step is a row: the JSON maxima are the CSV's
    for k in 0..3 {
        let m = rows.iter().map(|r| r[2 + k].abs()).fold(0.0, f64::max);
        assert_eq!(v["max_abs_disp_mm"][k].as_f64(), Some(m), "axis {k}");
    }

    // against the monolithic model at a fine fixed step
    let c = compare_adaptive_at_rtol_1e_3(f, "iqn-ils", &[]);
    let peak = c["monolithic"]["peak_disp_mm"].as_f64().unwrap();
    let error = c["schemes"][0]["max_error_mm"].as_f64().unwrap();
    eprintln!(
        "adaptive iqn-ils: {steps} steps, h {h_min:.1e} … {h_max:.1e}; {error:.2e} mm from monolithic, peak {peak:.2} mm"
    );
    assert!(peak > 1.0 && error <= 1e-3 * peak, "{error} mm at a peak of {peak} mm");
    assert_eq!(c["schemes"][0]["peak_disp_mm"], v["peak_disp_mm"], "the same run");
}

/// `bench --adaptive-rtols`: a row per scheme that iterates and tolerance; the fixed step it
/// names is the cheapest of the same scheme in bench.csv that is as accurate, and the cost
/// ratio is the ratio of their wall times; the interpolated step is as accurate as the
/// adaptive run where the grid brackets its error.
#[test]
fn bench_compares_the_adaptive_step_with_the_fixed_ones() {
    let (_, file) = common::scene("lt50m_C.toml", "adaptive-bench", |_| {});
    let dir = std::env::temp_dir().join(format!("master-adaptive-bench-{}", std::process::id()));
    let out = master(&[
        "bench",
        "--scene",
        file.to_str().unwrap(),
        "--schemes",
        "ijcsa,jacobi",
        "--dts",
        "0.04,0.02,0.01",
        "--t-end",
        "2",
        "--repeats",
        "1",
        "--adaptive-rtols",
        "1e-3",
        "--out",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let field = |line: &str, k: usize| line.split(',').nth(k).unwrap().to_string();
    let adaptive = std::fs::read_to_string(dir.join("bench_adaptive.csv")).unwrap();
    let lines: Vec<&str> = adaptive.lines().collect();
    assert!(lines[0].starts_with("scheme,rtol,wall_time_s,max_error_mm"), "{}", lines[0]);
    assert_eq!(lines.len(), 2, "ijcsa only (jacobi does not iterate): {adaptive}");
    let row = lines[1];
    assert_eq!((field(row, 0).as_str(), field(row, 1).as_str()), ("ijcsa", "1e-3"));
    let (wall, error): (f64, f64) = (field(row, 2).parse().unwrap(), field(row, 3).parse().unwrap());
    assert!(field(row, 5).parse::<u64>().unwrap() > 0);
    let fixed = std::fs::read_to_string(dir.join("bench.csv")).unwrap();
    // (dt, wall, max error) of the fixed ijcsa runs
    let ijcsa: Vec<(f64, f64, f64)> = fixed
        .lines()
        .filter(|l| l.starts_with("ijcsa,"))
        .map(|l| (field(l, 1).parse().unwrap(), field(l, 2).parse().unwrap(), field(l, 3).parse().unwrap()))
        .collect();
    assert_eq!(ijcsa.len(), 3);
    let cheapest = ijcsa.iter().filter(|r| r.2 <= error).min_by(|a, b| a.1.total_cmp(&b.1));
    match cheapest {
        Some(&(dt, fixed_wall, _)) => {
            assert_eq!(field(row, 9).parse::<f64>().unwrap(), dt);
            assert_eq!(field(row, 10).parse::<f64>().unwrap(), fixed_wall);
            assert_eq!(field(row, 11).parse::<f64>().unwrap(), wall / fixed_wall);
        }
        None => assert_eq!(field(row, 9), "", "no fixed step is as accurate: {row}"),
    }
    // the fixed step exactly as accurate: error and wall time interpolated as powers of h
    // between the two grid steps whose errors bracket the adaptive run's
    let mut sorted = ijcsa.clone();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let w = sorted.windows(2).find(|w| w[0].2 <= error && error <= w[1].2).expect("at rtol 1e-3 the grid brackets it");
    let ((h0, c0, e0), (h1, c1, e1)) = (w[0], w[1]);
    let p = (e1 / e0).ln() / (h1 / h0).ln();
    let h = h0 * (error / e0).powf(1.0 / p);
    let cost = c0 * (c1 / c0).powf((h / h0).ln() / (h1 / h0).ln());
    let (got_h, got_cost): (f64, f64) = (field(row, 12).parse().unwrap(), field(row, 13).parse().unwrap());
    eprintln!("as accurate: h = {got_h} ({h0} … {h1}), {got_cost} s");
    assert!((got_h - h).abs() <= 1e-9 * h && h0 <= got_h && got_h <= h1, "{got_h} against {h}");
    assert!((got_cost - cost).abs() <= 1e-9 * cost, "{got_cost} against {cost}");
    assert_eq!(field(row, 14).parse::<f64>().unwrap(), wall / got_cost);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The monolithic model with the adaptive step, abrupt and ramp start, 10 s at C: within rtol of
/// the peak of the same model at a fine fixed step; small steps right after the abrupt start
/// (its kink) and larger ones once the response is smooth; the JSON step figures are the CSV's.
#[test]
fn the_monolithic_model_steps_adaptively_within_its_tolerance() {
    for start in [feedcore::scene::Start::Abrupt, feedcore::scene::Start::Ramp] {
        let (_, file) = common::scene("lt50m_C.toml", &format!("adaptive-mono-{start:?}"), |s| s.motion.start = start);
        let f = file.to_str().unwrap();
        let out_csv = common::fmu_dir().join(format!("adaptive-mono-{start:?}.csv"));
        let args = ["--scene", f, "--adaptive", "--rtol", "1e-3", "--t-end", "10", "--json", "--quiet"];
        let out = master(&[&["run", "--scheme", "monolithic", "--out", out_csv.to_str().unwrap()], &args[..]].concat());
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!((v["scheme"].as_str(), v["adaptive"].as_bool()), (Some("monolithic"), Some(true)));
        let (_, rows) = csv(&out_csv);
        assert_eq!(rows.len() as u64, v["steps"].as_u64().unwrap() + 1);
        assert_eq!(rows.last().unwrap()[0], 10.0, "the last step lands on the end time");
        let h: Vec<f64> = rows[1..].iter().map(|r| r[1]).collect();
        let (h_min, h_max) = h.iter().fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)));
        assert_eq!((v["h_min_used"].as_f64(), v["h_max_used"].as_f64()), (Some(h_min), Some(h_max)));
        // the mean step over the first 0.5 s against the last 5 s
        let mean = |from: f64, to: f64| {
            let s: Vec<f64> = rows[1..].iter().filter(|r| r[0] > from && r[0] <= to).map(|r| r[1]).collect();
            s.iter().sum::<f64>() / s.len() as f64
        };
        let (early, late) = (mean(0.0, 0.5), mean(5.0, 10.0));
        eprintln!(
            "monolithic adaptive, {start:?} start: {} steps, h {h_min:.1e} … {h_max:.1e}, mean {early:.2e} early, {late:.2e} late",
            h.len()
        );
        assert!(late > 1.5 * early, "{start:?}: the steps grow once the start is past: {early} then {late}");

        let out = master(&[&["compare", "--schemes", "monolithic", "--dt", "0.00125"], &args[..]].concat());
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let c: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let peak = c["monolithic"]["peak_disp_mm"].as_f64().unwrap();
        let error = c["schemes"][0]["max_error_mm"].as_f64().unwrap();
        eprintln!("  {error:.2e} mm from the fixed step 0.00125 s, peak {peak:.2} mm");
        assert!(peak > 1.0 && error <= 1e-3 * peak, "{start:?}: {error} mm at a peak of {peak} mm");
        assert_eq!(c["schemes"][0]["peak_disp_mm"], v["peak_disp_mm"], "the same run");
    }
}

/// The co-simulation's adaptive step watches the cabin pose by default, as the monolithic model
/// watches its own: judged alike, the two take about the same steps (5 s at C, rtol 1e-3), and
/// so do IJCSA and IQN-ILS. `--watch` names other coupled inputs; a name that is none is refused
/// with the inputs there are, and `--watch` without `--adaptive` is refused.
#[test]
fn cosimulation_and_monolithic_model_watch_the_same_pose() {
    let (_, file) = common::scene("lt50m_C.toml", "adaptive-watch", |_| {});
    let f = file.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--scene", f, "--adaptive", "--rtol", "1e-3", "--t-end", "5", "--json"];
        args.extend_from_slice(extra);
        let out = master(&args);
        assert!(out.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["steps"].as_u64().unwrap() as f64
    };
    let monolithic = run(&["--scheme", "monolithic"]);
    for scheme in ["ijcsa", "iqn-ils"] {
        let steps = run(&["--scheme", scheme]);
        eprintln!("{scheme}: {steps} steps, monolithic {monolithic}");
        assert!((steps / monolithic - 1.0).abs() < 0.05, "{scheme}: {steps} steps against {monolithic}");
    }
    // the velocities watched too: more to judge, more steps
    let with_velocities = run(&["--scheme", "ijcsa", "--watch", "stewart.cabin.r,stewart.cabin.q,stewart.cabin.v"]);
    eprintln!("ijcsa watching the velocities too: {with_velocities} steps");
    assert!(with_velocities > 1.2 * monolithic);

    let out =
        master(&["run", "--scene", f, "--scheme", "ijcsa", "--adaptive", "--watch", "stewart.cabin.x", "--t-end", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--watch") && err.contains("`stewart.cabin.x`") && err.contains("`stewart.cabin.r[1]`"),
        "{err}"
    );
    for option in [["--watch", "stewart.cabin.r"], ["--estimate", "doubling"]] {
        let out = master(&["run", "--scene", f, "--scheme", "ijcsa", option[0], option[1], "--t-end", "1"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(option[0]) && err.contains("--adaptive"), "{err}");
    }
}

/// `--estimate doubling` (every step against its two half steps) for the monolithic model and a
/// co-simulation: 5 s at C within rtol of the peak of the monolithic model at a fine fixed step.
#[test]
fn step_doubling_meets_its_tolerance_at_c() {
    let (_, file) = common::scene("lt50m_C.toml", "adaptive-doubling", |_| {});
    let c = compare_adaptive_at_rtol_1e_3(file.to_str().unwrap(), "monolithic,ijcsa", &["--estimate", "doubling"]);
    let peak = c["monolithic"]["peak_disp_mm"].as_f64().unwrap();
    for s in c["schemes"].as_array().unwrap() {
        let error = s["max_error_mm"].as_f64().unwrap();
        eprintln!("{}: {error:.2e} mm at a peak of {peak:.2} mm", s["scheme"]);
        assert!(peak > 1.0 && error <= 1e-3 * peak, "{s}");
    }
    assert_eq!(c["schemes"].as_array().unwrap().len(), 2);
}

/// `export-ssp` writes what an adaptive run watches (the cabin pose) and the kink at the start
/// as this master's SSP annotations, and `run --system` of the archive takes them up: the same
/// steps as the scene's adaptive run (without it, every coupled input would be watched — the
/// accelerations and the wrench ripple, and the steps fall to h-min), and the same fixed-step
/// run. `--watch` still decides over the annotation.
#[test]
fn an_exported_system_watches_what_the_scene_does() {
    let (_, file) = common::scene("lt50m_C.toml", "adaptive-ssp", |_| {});
    let f = file.to_str().unwrap();
    let ssp = common::fmu_dir().join("adaptive-watch-C.ssp");
    let out = master(&["export-ssp", "--scene", f, "--out", ssp.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json = |args: &[&str]| {
        let out = master(args);
        assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let adaptive = ["--scheme", "ijcsa", "--adaptive", "--t-end", "2", "--json"];
    let scene = json(&[&["run", "--scene", f][..], &adaptive].concat());
    let system = json(&[&["run", "--system", ssp.to_str().unwrap()][..], &adaptive].concat());
    for key in ["steps", "rejected_steps", "h_min_used", "h_max_used"] {
        assert_eq!(scene[key], system[key], "{key}");
    }
    // and a fixed-step run takes its first step in substeps as the scene's does (the kink at the
    // start travels as an annotation too): the same iterations, the same largest residual
    let fixed = ["--scheme", "ijcsa", "--dt", "0.01", "--t-end", "1", "--json"];
    let scene_fixed = json(&[&["run", "--scene", f][..], &fixed].concat());
    let system_fixed = json(&[&["run", "--system", ssp.to_str().unwrap()][..], &fixed].concat());
    for key in ["mean_iterations", "max_interface_residual"] {
        assert_eq!(scene_fixed[key], system_fixed[key], "{key}");
    }
    let watch = ["--watch", "stewart.cabin.r,stewart.cabin.q,stewart.cabin.v"];
    let told = json(&[&["run", "--system", ssp.to_str().unwrap()][..], &adaptive, &watch].concat());
    eprintln!(
        "steps: scene {}, system {}, told to watch the velocities too {}",
        scene["steps"], system["steps"], told["steps"]
    );
    assert!(told["steps"].as_u64() > system["steps"].as_u64());
    std::fs::remove_file(&ssp).unwrap();
}
