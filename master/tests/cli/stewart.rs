//! `master stewart` prints what the Stewart library computes, under the documented keys.

use std::process::Command;

use feedcore::scene::Scene;
use stewart::{CabinMotion, Stewart};

fn scene_path(name: &str) -> String {
    format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn vector(v: &serde_json::Value) -> Vec<f64> {
    serde_json::from_value(v.clone()).unwrap()
}

#[test]
fn stewart_json_matches_the_library() {
    let path = scene_path("lt50m_B.toml");
    let out = Command::new(crate::MASTER).args(["stewart", "--scene", &path, "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["added_mass", "static_wrench", "wrench_min", "wrench_max", "actuator_force_max_n", "actuator_forces_n"]
    {
        assert!(!v[key].is_null(), "missing key {key}");
    }

    let scene = Scene::load(&path).unwrap();
    let st = Stewart::from_scene(&scene).unwrap();
    let (x, q) = (scene.target_position(), scene.target_orientation());
    // static wrench against the library, and the weight it must be
    let w = st.static_wrench(&x, &q).unwrap().to_vector();
    assert_eq!(vector(&v["static_wrench"]), w.as_slice());
    assert!((w[2] + 184.8 * scene.gravity_m_s2).abs() < 1e-9);
    // added mass: 6×6, symmetric, translational block = total mass
    let rows: Vec<Vec<f64>> = serde_json::from_value(v["added_mass"].clone()).unwrap();
    assert_eq!((rows.len(), rows[0].len()), (6, 6));
    let (_, jac) = st.relative_at_rest().unwrap().wrench_with_jacobians(&CabinMotion::at_rest(x, q), &st.gravity());
    for i in 0..6 {
        assert_eq!(rows[i], jac.added_mass().row(i).iter().copied().collect::<Vec<_>>());
    }
    assert!((rows[0][0] - 184.8).abs() < 1e-12);
    // two computations, one body: the locked platform's centre of mass c (from the force–angular
    // acceleration block of the added mass, −m[c]×) carries the weight, so the static moment
    // about the cabin centre point is c × F
    let m = rows[0][0];
    let c = nalgebra::Vector3::new(-rows[2][4] / m, -rows[0][5] / m, -rows[1][3] / m);
    let moment = c.cross(&nalgebra::Vector3::new(w[0], w[1], w[2]));
    for i in 0..3 {
        assert!((moment[i] - w[3 + i]).abs() < 1e-9 * w[2].abs(), "{moment} against {w}");
    }
    // ranges over the first revolution
    let range = st.fixed_cabin_range(&x, &q, scene.solver.dt_s).unwrap();
    assert_eq!(v["actuator_force_max_n"].as_f64().unwrap(), range.actuator_force_max());
    let (lo, hi) = (vector(&v["wrench_min"]), vector(&v["wrench_max"]));
    for i in 0..6 {
        assert!(lo[i] <= w[i] + 1.0 && w[i] - 1.0 <= hi[i] && lo[i] <= hi[i]);
    }
}

#[test]
fn stewart_tables_and_errors_are_readable() {
    let out = Command::new(crate::MASTER).args(["stewart", "--scene", &scene_path("lt50m_C.toml")]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for part in ["Added mass", "Wrench on the cabin", "Actuator forces", "peak actuator force"] {
        assert!(text.contains(part), "{text}");
    }
    // a leg geometry that cannot reach the platform names the leg and the time
    let dir = std::env::temp_dir().join(format!("cli-stewart-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("short.toml");
    let scene = std::fs::read_to_string(scene_path("lt50m_C.toml")).unwrap();
    let text = scene.replacen("length_m = 0.8", "length_m = 1.5", 1);
    assert_ne!(text, scene);
    std::fs::write(&bad, text).unwrap();
    let out = Command::new(crate::MASTER).args(["stewart", "--scene", bad.to_str().unwrap()]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("Stewart leg") && err.contains("t = 0 s"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
