//! `master statics` and `master modes` print what the library computes, in the documented keys.

use std::process::Command;

use cable::model::CableCabin;
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

/// With a breaking load, statics, run and sweep report each cable's utilisation — its larger end
/// tension over the breaking load, from the tensions statics prints — and flag overload: the
/// statics text and run warn, the sweep marks the point infeasible.
#[test]
fn a_breaking_load_gives_the_utilisation_and_flags_overload() {
    // at B the end tensions run from 0.2 to 6.1 kN: 5 kN overloads two cables
    let (_, file) = crate::common::scene("lt50m_B.toml", "breaking", |s| s.cables.breaking_load_n = Some(5000.0));
    let path = file.to_str().unwrap();
    let v = run_json(&["statics", "--scene", path, "--json"]);
    let mut overloaded = Vec::new();
    let mut utilisation = Vec::new();
    for (i, c) in v["cables"].as_array().unwrap().iter().enumerate() {
        let largest = c["tension_anchor_n"].as_f64().unwrap().max(c["tension_cabin_n"].as_f64().unwrap());
        let u = c["utilisation"].as_f64().unwrap();
        assert_eq!(u, largest / 5000.0);
        assert_eq!(c["overloaded"].as_bool().unwrap(), u > 1.0);
        if u > 1.0 {
            overloaded.push(i);
        }
        utilisation.push(u);
    }
    assert_eq!(overloaded, [0, 3]);
    let text = Command::new(crate::MASTER).args(["statics", "--scene", path]).output().unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("OVERLOAD") && text.contains("warning: cables [0, 3] carry more than their breaking load"),
        "{text}"
    );

    let run = Command::new(crate::MASTER)
        .args(["run", "--scene", path, "--scheme", "monolithic", "--t-end", "0.05", "--json"])
        .output()
        .unwrap();
    assert!(run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("cables [0, 3] carry more than their breaking load"));
    let j: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let from_run: Vec<f64> = serde_json::from_value(j["cable_utilisation_static"].clone()).unwrap();
    assert_eq!(from_run, utilisation);
    // without a breaking load, nothing is added
    let plain = run_json(&[
        "run",
        "--scene",
        &scene_path("lt50m_B.toml"),
        "--scheme",
        "monolithic",
        "--t-end",
        "0.05",
        "--json",
    ]);
    assert!(plain.get("cable_utilisation_static").is_none());

    let out = std::env::temp_dir().join(format!("master-breaking-sweep-{}", std::process::id()));
    let sweep = Command::new(crate::MASTER)
        .args(["sweep", "--scene", path, "--grid", "mass=1:2:2", "--modes", "0", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(sweep.status.success(), "{}", String::from_utf8_lossy(&sweep.stderr));
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let u: f64 = cells[col("max_utilisation")].parse().unwrap();
        let max_t: f64 = cells[col("max_tension_n")].parse().unwrap();
        assert_eq!(u, max_t / 5000.0);
        assert_eq!(cells[col("feasible")], "false", "{line}");
        assert!(line.contains("overloaded"), "{line}");
    }
    std::fs::remove_dir_all(&out).unwrap();
}

/// Without a breaking load, statics still says when its tensions cannot be physical: a cabin a
/// billion times heavier stretches the cables far beyond a steel rope's elastic range (the
/// models' cables are linear elastic); the reference scenes stay far within it.
#[test]
fn tensions_beyond_the_elastic_range_are_flagged() {
    let (_, heavy) = crate::common::scene("lt50m_C.toml", "heavy", |s| s.cabin.mass_kg *= 1e9);
    let out = Command::new(crate::MASTER).args(["statics", "--scene", heavy.to_str().unwrap()]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("warning: cables [0, 1, 2, 3, 4, 5] are stretched beyond 1 %"), "{text}");
    let v = run_json(&["statics", "--scene", heavy.to_str().unwrap(), "--json"]);
    assert!(v["cables"].as_array().unwrap().iter().all(|c| c["strain"].as_f64().unwrap() > 1e3));
    for name in ["lt50m_B.toml", "lt50m_C.toml", "fast500_centre.toml", "fast500_rim.toml"] {
        let out = Command::new(crate::MASTER).args(["statics", "--scene", &scene_path(name)]).output().unwrap();
        assert!(!String::from_utf8_lossy(&out.stdout).contains("warning"), "{name}");
        let v = run_json(&["statics", "--scene", &scene_path(name), "--json"]);
        for c in v["cables"].as_array().unwrap() {
            let strain = c["strain"].as_f64().unwrap();
            let largest = c["tension_anchor_n"].as_f64().unwrap().max(c["tension_cabin_n"].as_f64().unwrap());
            let scene = Scene::load(scene_path(name)).unwrap();
            assert_eq!(strain, largest / (scene.cables.area_m2 * scene.cables.youngs_modulus_pa));
            assert!(strain < 0.005, "{name}: {strain}"); // FAST at the rim: 0.23 %
        }
    }
}
