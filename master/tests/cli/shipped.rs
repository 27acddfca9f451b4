//! Every shipped scene as a new user first runs it: with every method, the scene's own step and
//! settings, no flag but a short `--t-end`.

use feedcore::scene::{Scene, SensorKind, StewartMode};

use crate::common;
use crate::master;

/// Every method of `master run --scheme`.
const METHODS: [&str; 9] = [
    "monolithic",
    "ijcsa",
    "iqn-ils",
    "iterative",
    "jacobi",
    "gauss-seidel",
    "gauss-seidel-reversed",
    "decoupled",
    "cable",
];

/// Why `method` cannot run `scene` (the refusals the README documents), or `None` if it must.
fn refusal(scene: &Scene, method: &str) -> Option<&'static str> {
    let locked = scene.analyses.stewart != StewartMode::Coupled;
    let compensated = scene.control.as_ref().is_some_and(|c| c.sensor != SensorKind::Off);
    match method {
        "cable" if scene.disturbance.is_none() => Some("[disturbance]"),
        "cable" => None,
        _ if locked => Some("no moving platform"),
        "decoupled" if compensated => Some("compensates the cabin"),
        _ => None,
    }
}

/// Each shipped scene (every file of `scenes/`, so a new one is covered when it is added) with
/// each method over 0.05 s at the scene's own step: the methods a scene supports run to the end
/// with finite results, and the others are refused before anything is built, with the reason
/// the README gives. A scene whose own step its sensors cannot take, or whose FMUs fail at the
/// first step, fails here.
#[test]
fn every_shipped_scene_runs_with_its_own_defaults() {
    let mut names: Vec<String> = std::fs::read_dir(common::scene_path(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 9, "the shipped scenes: {names:?}");
    for name in &names {
        let file = common::scene_file(name, "shipped", |_| {});
        let scene = Scene::load(&file).unwrap_or_else(|e| panic!("{name} as shipped: {e}")).to_scene();
        let mut ran = 0;
        for method in METHODS {
            let f = file.to_str().unwrap();
            let out = master(&["run", "--scene", f, "--scheme", method, "--t-end", "0.05", "--json", "--quiet"]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            match refusal(&scene, method) {
                None => {
                    assert!(out.status.success(), "{name}, {method}: {stderr}");
                    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
                    let (steps, peak) = (v["steps"].as_u64().unwrap(), v["peak_disp_mm"].as_f64().unwrap());
                    let expected = (0.05 / scene.solver.dt_s).round() as u64;
                    assert_eq!(steps, expected, "{name}, {method}: the scene's own step");
                    assert!(peak.is_finite(), "{name}, {method}: peak {peak}");
                    ran += 1;
                }
                Some(why) => {
                    assert_eq!(out.status.code(), Some(1), "{name}, {method}: {stderr}");
                    assert!(stderr.contains("cannot start") && stderr.contains(why), "{name}, {method}: {stderr}");
                }
            }
        }
        assert!(ran >= 1, "{name}: no method runs it");
    }
}

/// The help lists the commands the README's table documents, no more and no fewer: a command
/// added, renamed or dropped on one side fails here.
#[test]
fn the_help_and_the_readme_list_the_same_commands() {
    let help = String::from_utf8(master(&["--help"]).stdout).unwrap();
    let listed: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(listed.len() >= 16, "{help}");
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let mut documented: Vec<&str> = readme
        .lines()
        .filter_map(|l| l.strip_prefix("| `master "))
        .filter_map(|l| l.split([' ', '`']).next())
        .collect();
    documented.dedup();
    let (mut a, mut b) = (listed.clone(), documented.clone());
    a.sort();
    a.dedup();
    b.sort();
    b.dedup();
    assert_eq!(a, b, "`master --help` against the README's command table");
}
