//! `master statics` and `master modes` print what the library computes, in the documented keys.

use std::process::Command;

use cable_fmu::model::CableCabin;
use feedcore::scene::Scene;

fn scene_path(name: &str) -> String {
    format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn run_json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(crate::MASTER).args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn statics_json_matches_the_library() {
    let path = scene_path("lt50m_B.toml");
    let v = run_json(&["statics", "--scene", &path, "--json"]);
    let model = CableCabin::from_scene(&Scene::load(&path).unwrap()).unwrap();
    let eq = &model.equilibrium;
    let pos: Vec<f64> = serde_json::from_value(v["cabin_position"].clone()).unwrap();
    assert_eq!(pos, eq.position.as_slice());
    let q: Vec<f64> = serde_json::from_value(v["cabin_orientation"].clone()).unwrap();
    assert_eq!(q, vec![eq.orientation.w, eq.orientation.i, eq.orientation.j, eq.orientation.k]);
    let cables = v["cables"].as_array().unwrap();
    assert_eq!(cables.len(), 6);
    for (c, lib) in cables.iter().zip(&eq.cables) {
        assert_eq!(c["unstretched_length_m"].as_f64().unwrap(), lib.unstretched_length);
        assert_eq!(c["tension_anchor_n"].as_f64().unwrap(), lib.tension_anchor);
        assert_eq!(c["tension_cabin_n"].as_f64().unwrap(), lib.tension_cabin);
        assert!(!c["slack"].as_bool().unwrap());
    }
    // lt50m.md: at B cable 4 is nearly slack, about 0.2 kN at the cabin
    assert!(cables[4]["nearly_slack"].as_bool().unwrap());
    assert!((cables[4]["tension_cabin_n"].as_f64().unwrap() - 200.0).abs() < 50.0);
}

#[test]
fn modes_json_lists_ascending_frequencies() {
    let path = scene_path("lt50m_C.toml");
    let v = run_json(&["modes", "--scene", &path, "--count", "8", "--json"]);
    let f: Vec<f64> = serde_json::from_value(v["frequencies_hz"].clone()).unwrap();
    assert_eq!(f.len(), 8);
    assert!(f.windows(2).all(|w| w[0] <= w[1]));
    let model = CableCabin::build(&Scene::load(&path).unwrap(), 8).unwrap();
    assert_eq!(f, model.modes.unwrap().frequencies_hz);
}

#[test]
fn a_bad_scene_fails_with_the_key_and_value() {
    let dir = std::env::temp_dir().join(format!("cli-cable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    let text =
        std::fs::read_to_string(scene_path("lt50m_C.toml")).unwrap().replace("mass_kg = 720.0", "mass_kg = -720.0");
    std::fs::write(&bad, text).unwrap();
    let out = Command::new(crate::MASTER).args(["statics", "--scene", bad.to_str().unwrap()]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml") && err.contains("cabin.mass_kg") && err.contains("-720"), "{err}");
}
