//! `master design`: the shipped LQG scene is what it designs, and careless input is refused by name.

use feedcore::scene::Scene;

use crate::common;
use crate::master;

/// The shipped `lt50m_C_lqg.toml` holds, bit for bit, the design model and weights that
/// `master design` makes of `lt50m_C_compensated.toml` (the scene it was designed from).
#[test]
fn the_shipped_lqg_scene_is_what_the_command_designs() {
    let file = common::scene_file("lt50m_C_compensated.toml", "design", |_| {});
    let out = common::fmu_dir().join("design-out");
    let o = master(&["design", "--scene", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let designed = Scene::load(out.join("lt50m_C_compensated_lqg.toml")).unwrap();
    let shipped = Scene::load(common::scene_path("lt50m_C_lqg.toml")).unwrap();
    let (a, b) = (designed.control.as_ref().unwrap(), shipped.control.as_ref().unwrap());
    assert_eq!(a.lqg, b.lqg);
    assert_eq!(
        (a.law, a.notch_hz, a.bandwidth_hz, a.filter_stages),
        (b.law, b.notch_hz, b.bandwidth_hz, b.filter_stages)
    );
    // what it prints is the design's own prediction: a bound far below the uncompensated model
    let bound = report["bound"]["feed_rms_mm"].as_f64().unwrap();
    let open = report["uncompensated"]["feed_rms_mm"].as_f64().unwrap();
    assert!(bound > 0.0 && bound < 0.01 * open, "{bound} {open}");
    for r in report["riccati_residuals"].as_array().unwrap() {
        assert!(r.as_f64().unwrap() < 1e-12, "{r}");
    }
}

/// A scene the design cannot serve is refused before anything runs, naming the key: no inertial
/// unit, a reading without noise, a delay no evaluation run would outlive.
#[test]
fn careless_input_is_refused_by_name() {
    let out = common::fmu_dir().join("design-refused");
    let refused = |file: &std::path::Path, extra: &[&str], needle: &str| {
        let mut args = vec!["design", "--scene", file.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = master(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{needle}: {err}");
        assert!(!out.join("design.md").exists(), "a refused design wrote its report");
    };
    let bare = common::scene_file("lt50m_C_sampled.toml", "design-bare", |_| {});
    refused(&bare, &[], "[control.imu]");
    let silent = common::scene_file("lt50m_C_compensated.toml", "design-silent", |s| {
        s.control.as_mut().unwrap().imu.as_mut().unwrap().gyro_noise_density = 0.0;
    });
    refused(&silent, &[], "control.imu.gyro_noise_density");
    let file = common::scene_file("lt50m_C_compensated.toml", "design-late", |_| {});
    refused(&file, &["--evaluate", "2", "--t-end", "0.01"], "control.delay_s");
}
