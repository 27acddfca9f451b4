//! The net in space: `statics --plot` against the form finding, `run --vtk` and `modes --vtk`
//! files against the run and the modal solver, and bad `--vtk` targets refused before the run.

use std::path::{Path, PathBuf};

use roxmltree::Document;
use studies::net::{Layout, equilibrium_frame};
use studies::report::{Modal, Statics};

use crate::{common, master};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("master-net-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn ok(out: &std::process::Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// Every file below `dir`, relative to it.
fn files_below(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                found.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    found.sort();
    found
}

/// A file of the VTK series read back: its arrays by name.
fn read_vtu(path: &Path) -> std::collections::HashMap<String, Vec<f64>> {
    let bytes = std::fs::read(path).unwrap();
    let start = bytes.windows(2).position(|w| w == b"\n_").unwrap() + 2;
    let xml = format!("{}</AppendedData></VTKFile>", std::str::from_utf8(&bytes[..start - 1]).unwrap());
    let doc = Document::parse(&xml).unwrap();
    let data = &bytes[start..];
    doc.descendants()
        .filter(|n| n.has_tag_name("DataArray") && n.attribute("type") == Some("Float64"))
        .map(|a| {
            let o: usize = a.attribute("offset").unwrap().parse().unwrap();
            let n = u64::from_le_bytes(data[o..o + 8].try_into().unwrap()) as usize;
            let values = data[o + 8..o + 8 + n].chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap()));
            (a.attribute("Name").unwrap().to_string(), values.collect())
        })
        .collect()
}

#[test]
fn the_plotted_net_is_the_equilibrium_of_statics() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let scene_file = common::scene_path(name);
        let scene = feedcore::scene::Scene::load(&scene_file).unwrap();
        let statics = Statics::of(&scene).unwrap();
        let layout = Layout::of(&scene);
        let (_, frame) = equilibrium_frame(&scene, &layout, &statics.equilibrium);
        // what the figure draws: every node where the form finding put it, the end elements'
        // forces those `master statics` prints (the bar law on nodes the shooting placed to
        // ~1e-13 of the span: ~1e-8 of a tension)
        let n = layout.points_per_cable();
        for (i, c) in statics.equilibrium.cables.iter().enumerate() {
            for (j, node) in c.shape.nodes.iter().enumerate() {
                assert!((frame.points[i * n + j] - node).norm() <= 1e-12 * node.norm(), "{name} cable {i} node {j}");
            }
            let (first, last) = (frame.tensions[i * (n - 1)], frame.tensions[i * (n - 1) + n - 2]);
            assert!((first - c.tension_anchor).abs() <= 2e-8 * c.tension_anchor, "{name} cable {i}: {first}");
            assert!((last - c.tension_cabin).abs() <= 2e-8 * c.tension_cabin, "{name} cable {i}: {last}");
        }
        // the command writes the library's figure, which draws every element in its tension's colour
        let dir = scratch(&format!("statics-{name}"));
        let svg = dir.join("net.svg");
        let printed =
            ok(&master(&["statics", "--scene", scene_file.to_str().unwrap(), "--plot", svg.to_str().unwrap()]));
        assert!(printed.ends_with(&format!("plot: {}\n", svg.display())), "{printed}");
        let figure = studies::view3d::statics_figure(&statics).unwrap();
        assert_eq!(std::fs::read_to_string(&svg).unwrap(), figure);
        let doc = Document::parse(&figure).unwrap();
        let scale = studies::view3d::TensionScale::of(&frame.tensions);
        let hex = |c: plotters::style::RGBColor| format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        let strokes: Vec<String> =
            doc.descendants().filter_map(|n| n.attribute("stroke").map(|s| s.to_ascii_uppercase())).collect();
        for (e, &t) in frame.tensions.iter().enumerate() {
            // the four views of the whole net, and the close-up where the element reaches into it
            let drawn = strokes.iter().filter(|s| **s == hex(scale.colour(t))).count();
            assert!(drawn >= 4, "{name} element {e} ({t} N): drawn {drawn} times in its colour");
        }
        let texts: String = doc.descendants().filter(|n| n.is_text()).map(|n| n.text().unwrap()).collect();
        let marked = statics.equilibrium.cables.iter().filter(|c| c.state != cable::statics::CableState::Taut).count();
        assert_eq!(texts.matches("nearly slack").count() + texts.matches("SLACK").count() > 0, marked > 0, "{name}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn a_run_writes_its_net_as_a_paraview_series_and_nothing_else() {
    let base = scratch("run");
    let vtk = base.join("vtk");
    let csv = base.join("run.csv");
    let scene = common::scene_path("lt50m_C.toml");
    let printed = ok(&master(&[
        "run",
        "--scene",
        scene.to_str().unwrap(),
        "--scheme",
        "monolithic",
        "--t-end",
        "1",
        "--out",
        csv.to_str().unwrap(),
        "--vtk",
        vtk.to_str().unwrap(),
        "--vtk-every",
        "10",
    ]));
    // 100 steps sampled every step: the start and every 10th sample
    assert!(
        printed.contains(&format!("net for ParaView: {} (11 files)", vtk.join("lt50m_C.pvd").display())),
        "{printed}"
    );
    let mut expected: Vec<String> = (0..11).map(|k| format!("vtk/lt50m_C/lt50m_C_{k:06}.vtu")).collect();
    expected.push("run.csv".into());
    expected.push("vtk/lt50m_C.pvd".into());
    expected.sort();
    assert_eq!(files_below(&base), expected, "nothing but the series and the CSV");
    let index = std::fs::read_to_string(vtk.join("lt50m_C.pvd")).unwrap();
    let doc = Document::parse(&index).unwrap();
    let sets: Vec<(f64, String)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| (n.attribute("timestep").unwrap().parse().unwrap(), n.attribute("file").unwrap().to_string()))
        .collect();
    assert_eq!(sets.len(), 11);
    // the cabin centre's displacement is the CSV's, the time the sample's
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let centre = 6 * 21 + 6;
    for (k, (t, file)) in sets.iter().enumerate() {
        let row = &rows[10 * k];
        assert_eq!(*t, row[0]);
        let a = read_vtu(&vtk.join(file));
        assert_eq!(a["TimeValue"], [row[0]]);
        let d = &a["displacement"][3 * centre..3 * centre + 3];
        for c in 0..3 {
            assert!((d[c] * 1e3 - row[1 + c]).abs() <= 1e-12 * row[1 + c].abs().max(1e-3), "t = {t}: {d:?} {row:?}");
        }
    }
    std::fs::remove_dir_all(&base).unwrap();
}

#[test]
fn bad_vtk_targets_are_refused_before_the_run() {
    let base = scratch("refused");
    let file = base.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let scene = common::scene_path("lt50m_C.toml");
    let run = |vtk: &Path, scheme: &str| {
        master(&[
            "run",
            "--scene",
            scene.to_str().unwrap(),
            "--scheme",
            scheme,
            "--t-end",
            "1",
            "--vtk",
            vtk.to_str().unwrap(),
        ])
    };
    let cases: [(PathBuf, &str, &str); 4] = [
        (file.clone(), "monolithic", "is a file, not a folder"),
        (file.join("inside"), "monolithic", "which is a file, not a folder"),
        (PathBuf::from("/proc/feedsim-vtk"), "monolithic", "cannot create the folder"),
        (base.join("vtk"), "ijcsa", "--scheme monolithic"),
    ];
    for (target, scheme, says) in cases {
        let out = run(&target, scheme);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{}: accepted", target.display());
        assert!(err.contains("--vtk") && err.contains(says), "{}: {err}", target.display());
        assert!(out.stdout.is_empty(), "{}: the run started", target.display());
    }
    assert_eq!(files_below(&base), ["a-file"], "nothing written");
    let ssp = master(&["run", "--system", "x.ssp", "--scheme", "ijcsa", "--vtk", base.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&ssp.stderr).contains("--vtk writes the cable net of a scene's run"));
    let every = master(&["run", "--scene", scene.to_str().unwrap(), "--scheme", "monolithic", "--vtk-every", "2"]);
    assert!(!every.status.success(), "--vtk-every without --vtk");
    std::fs::remove_dir_all(&base).unwrap();
}

#[test]
fn a_written_mode_is_the_modal_solvers_vector() {
    let base = scratch("modes");
    let scene_file = common::scene_path("lt50m_C.toml");
    let svg = base.join("modes.svg");
    let vtk = base.join("vtk");
    let printed = ok(&master(&[
        "modes",
        "--scene",
        scene_file.to_str().unwrap(),
        "--count",
        "4",
        "--plot",
        svg.to_str().unwrap(),
        "--vtk",
        vtk.to_str().unwrap(),
    ]));
    assert!(printed.contains("mode shapes for ParaView:"), "{printed}");
    let scene = feedcore::scene::Scene::load(&scene_file).unwrap();
    let modal = Modal::of(&scene, 4).unwrap();
    assert_eq!(std::fs::read_to_string(&svg).unwrap(), studies::view3d::modes_figure_of(&modal).unwrap());
    let found = modal.model.modes.as_ref().unwrap();
    let (m, n) = (scene.cables.elements - 1, scene.cables.elements + 1);
    for k in 0..4 {
        let a = read_vtu(&vtk.join(format!("lt50m_C_modes/lt50m_C_mode_{:06}.vtu", k + 1)));
        assert_eq!(a["TimeValue"], [(k + 1) as f64]);
        assert_eq!(a["frequency_hz"], [modal.modes[k].frequency_hz]);
        let shape = &found.shapes[k];
        let v = &a["mode_shape"];
        for i in 0..6 {
            // the free nodes carry the solver's entries exactly; the anchors stay
            assert_eq!(&v[3 * i * n..3 * i * n + 3], &[0.0; 3]);
            assert_eq!(&v[3 * (i * n + 1)..3 * (i * n + 1 + m)], &shape[3 * i * m..3 * (i + 1) * m]);
        }
        let centre = 6 * n + 6;
        assert_eq!(&v[3 * centre..3 * centre + 3], &shape[shape.len() - 6..shape.len() - 3]);
    }
    std::fs::remove_dir_all(&base).unwrap();
}
