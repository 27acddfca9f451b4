//! The paper side by side (docs/reproduction.md): the momentum-consistent start in the
//! co-simulation against the monolithic model, and `master reproduce`.

use crate::common;

use feedcore::scene::Start;
use studies::cosim::{Extrapolation, JacobianUpdate, Options, Relaxation, Scheme};
use studies::simulate::{Method, simulate};

fn ijcsa() -> Method {
    Method::Cosim(Options {
        scheme: Scheme::Ijcsa,
        extrapolation: Extrapolation::Constant,
        relaxation: Relaxation::Fixed(0.5),
        jacobian: JacobianUpdate::EveryStep,
        tol: 1e-8,
        max_iter: 100,
        ..Options::default()
    })
}

/// With `start = "consistent"` the cable FMU starts the cabin with the recoil velocity the
/// monolithic model gives it: IJCSA follows the monolithic model, far below the change the
/// start makes, and the gap shrinks at second order with the step — the first macro step is
/// taken in substeps, since each FMU's first acceleration lacks the other's inertia (in one
/// step: first order, 0.046 mm at h = 0.01).
#[test]
fn the_consistent_start_agrees_between_ijcsa_and_the_monolithic_model() {
    let (abrupt, abrupt_file) = common::scene("lt50m_C.toml", "start-abrupt", |_| {});
    let (scene, file) = common::scene("lt50m_C.toml", "start-consistent", |s| s.motion.start = Start::Consistent);
    let t_end = 2.0;
    let run = |m: Method, h: f64| simulate(&scene, &file, m, h, t_end).unwrap();
    let reference = simulate(&abrupt, &abrupt_file, Method::Monolithic, 0.01, t_end).unwrap();
    let (mono, mono_fine) = (run(Method::Monolithic, 0.01), run(Method::Monolithic, 0.0025));
    let (nj, nj_fine) = (run(ijcsa(), 0.01), run(ijcsa(), 0.0025));
    let effect = mono.error_against(&reference).0;
    let (gap, gap_fine) = (nj.error_against(&mono).0, nj_fine.error_against(&mono_fine).0);
    eprintln!(
        "consistent − abrupt start {effect:.3e} mm; ijcsa − monolithic {gap:.3e} mm at h, {gap_fine:.3e} mm at h/4"
    );
    assert!(effect > 0.05, "the start changes the response by {effect} mm");
    // the first step in substeps: second order (before, first order and 0.046 mm at h)
    assert!(gap <= 2e-3 * effect, "{gap:e} mm against the start's effect {effect:e} mm");
    assert!(gap_fine <= gap / 8.0, "second order in h: {gap:e} → {gap_fine:e}");
}

fn modes_json(args: &[&str]) -> Vec<f64> {
    let out = crate::master(args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["frequencies_hz"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn library_modes(scene: &feedcore::scene::ValidScene, count: usize) -> Vec<f64> {
    let m = cable::model::CableCabin::build(scene, count).unwrap();
    m.modes.unwrap().frequencies_hz[..count].to_vec()
}

/// `--platform added-mass` equals the modes of a cabin made heavier by the platform's mass
/// with no platform; `--platform absent` those without it; `--youngs-modulus` those of a scene
/// with that E; each differs from the scene's own modes.
#[test]
fn modal_options_equal_the_edited_scenes() {
    let path = common::scene_path("lt50m_C.toml");
    let p = path.to_str().unwrap();
    let scene = feedcore::scene::Scene::load(&path).unwrap();
    let base = library_modes(&scene, 4);
    let absent = feedcore::scene::StewartMode::Absent;
    let heavy = scene
        .edited(|s| {
            s.cabin.mass_kg += 184.8;
            s.analyses.stewart = absent;
        })
        .unwrap();
    let bare = scene.edited(|s| s.analyses.stewart = absent).unwrap();
    let soft = scene.edited(|s| s.cables.youngs_modulus_pa = 1e9).unwrap();
    for (flags, edited) in [
        (vec!["--platform", "added-mass"], heavy),
        (vec!["--platform", "absent"], bare),
        (vec!["--youngs-modulus", "1e9"], soft),
    ] {
        let mut args = vec!["modes", "--scene", p, "--count", "4", "--json"];
        args.extend(&flags);
        let cli = modes_json(&args);
        let lib = library_modes(&edited, 4);
        eprintln!("{flags:?}: {cli:?} (scene's {base:?})");
        for k in 0..4 {
            assert!((cli[k] - lib[k]).abs() <= 1e-9 * lib[k], "{flags:?} mode {}: {} vs {}", k + 1, cli[k], lib[k]);
        }
        assert!((cli[0] - base[0]).abs() > 1e-3, "{flags:?} changes nothing");
    }
}

/// `master reproduce --quick` writes every table and figure of docs/reproduction.md; the
/// numbers it prints are the library's (our frequencies, the paper's, the static inertial
/// response of the issue: ≈ 0.015 mm at C from force and moment together, ≈ 0.05 mm from the
/// moment alone).
#[test]
fn reproduce_writes_every_table_and_figure() {
    let dir = std::env::temp_dir().join(format!("feedsim-reproduce-{}", std::process::id()));
    let (b, c) = (common::scene_path("lt50m_B.toml"), common::scene_path("lt50m_C.toml"));
    let out = crate::master(&[
        "reproduce",
        "--out",
        dir.to_str().unwrap(),
        "--scene-b",
        b.to_str().unwrap(),
        "--scene-c",
        c.to_str().unwrap(),
        "--quick",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let md = std::fs::read_to_string(dir.join("numbers.md")).unwrap();
    for needle in ["0.0733, 0.1624, 0.1659, 0.1757", "0.4658, 0.4730, 0.7574, 0.8002", "±0.21", "±0.32", "±0.75"] {
        assert!(md.contains(needle), "numbers.md lacks {needle}");
    }
    let table2 = std::fs::read_to_string(dir.join("table2.csv")).unwrap();
    assert_eq!(table2.lines().count(), 1 + 2 * 2 * 3 * 2, "{table2}");
    let statics = std::fs::read_to_string(dir.join("static_inertial.csv")).unwrap();
    let c_row: Vec<f64> =
        statics.lines().find(|l| l.starts_with("C,")).unwrap().split(',').skip(1).map(|x| x.parse().unwrap()).collect();
    eprintln!("static inertial response at C: {c_row:?}");
    assert!((0.014..0.017).contains(&c_row[0]) && (0.045..0.06).contains(&c_row[2]), "{c_row:?}");
    for fig in ["fig4_B.svg", "fig5_C.svg", "spectrum.svg"] {
        let svg = std::fs::read_to_string(dir.join(fig)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("paper"), "{fig}");
    }
    let responses = std::fs::read_to_string(dir.join("responses.csv")).unwrap();
    assert_eq!(responses.lines().count(), 1 + 12);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The weight-shift hypothesis lives in the monolithic model only; the co-simulation says so.
#[test]
fn inertial_only_is_refused_to_the_co_simulation() {
    let (_, file) = common::scene("lt50m_C.toml", "inertial-only", |s| {
        s.analyses.wrench = feedcore::scene::WrenchModel::InertialOnly
    });
    let out = crate::master(&["run", "--scene", file.to_str().unwrap(), "--scheme", "ijcsa", "--t-end", "0.1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("inertial_only") && err.contains("monolithic"), "{err}");
}
