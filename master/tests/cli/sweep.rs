//! `master sweep`: the table of a whole sweep equals the merge of its shards (and the serial
//! run the parallel one), every number equals what the library computes for that point, and
//! an incomplete set of parts is refused.

use std::path::{Path, PathBuf};

use cable::model::CableCabin;
use cable::net::CableNet;
use cable::statics::form_find;
use feedcore::scene::Scene;
use studies::simulate::{Method, simulate};
use studies::sweep::table::Table;
use studies::sweep::{Axis, Placement, point_scene, scale_platform_mass};

use crate::master;

fn scene_path(name: &str) -> String {
    crate::common::scene_path(name).display().to_string()
}

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cli-sweep-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A command line split at spaces (the paths used here have none).
fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

fn ok(args: &[&str]) {
    let out = master(args);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// The table without its run-time columns (the only ones that differ between runs).
fn timeless(t: &Table) -> Vec<Vec<String>> {
    let keep: Vec<usize> = (0..t.columns.len()).filter(|&c| !t.columns[c].ends_with("wall_s")).collect();
    t.rows.values().map(|r| keep.iter().map(|&c| r[c].clone()).collect()).collect()
}

fn cell(t: &Table, index: usize, column: &str) -> String {
    t.rows[&index][t.column(column).unwrap_or_else(|| panic!("no column {column}"))].clone()
}

#[test]
fn shards_merge_to_the_whole_sweep_and_every_number_is_the_librarys() {
    let scene = scene_path("lt50m_C.toml");
    let grid = ["--grid", "x=-4,-1,0,1", "--grid", "y=-1:1:3"];
    let whole = dir("whole");
    let mut args = vec!["sweep", "--scene", &scene, "--modes", "2", "--jobs", "2", "--quiet", "--out"];
    args.push(whole.to_str().unwrap());
    args.extend(grid);
    ok(&args);
    let parts = dir("parts");
    for shard in ["0/3", "1/3", "2/3"] {
        let mut a = vec!["sweep", "--scene", &scene, "--modes", "2", "--jobs", "1", "--quiet", "--shard", shard];
        a.extend(["--out", parts.to_str().unwrap()]);
        a.extend(grid);
        ok(&a);
    }
    let merged = dir("merged");
    ok(&["sweep", "--merge", parts.to_str().unwrap(), "--out", merged.to_str().unwrap()]);
    let w = Table::read(&whole.join("sweep.csv")).unwrap();
    let m = Table::read(&merged.join("sweep.csv")).unwrap();
    assert_eq!(w.header, m.header);
    assert_eq!(w.columns, m.columns);
    assert_eq!(timeless(&w), timeless(&m), "parallel whole sweep vs serial shards merged");
    assert!(whole.join("sweep.svg").exists() && merged.join("sweep.svg").exists());

    // every point against the library
    let base = Scene::load(&scene).unwrap();
    let placement = Placement { surface: None, tilt_share: None };
    assert_eq!(w.rows.len(), 12);
    for &i in w.rows.keys() {
        let x: f64 = cell(&w, i, "x_m").parse().unwrap();
        let y: f64 = cell(&w, i, "y_m").parse().unwrap();
        let (s, _) = point_scene(&base, &placement, &[(Axis::X, x), (Axis::Y, y)]).unwrap();
        let net = CableNet::from_scene(&s);
        match form_find(&net, s.target_position(), s.target_orientation()) {
            Ok(eq) => {
                assert_eq!(cell(&w, i, "feasible"), "true", "point {i}: {}", cell(&w, i, "note"));
                let t: Vec<f64> = eq.cables.iter().flat_map(|c| [c.tension_anchor, c.tension_cabin]).collect();
                let min = t.iter().copied().fold(f64::INFINITY, f64::min);
                let max = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                assert_eq!(cell(&w, i, "min_tension_n"), format!("{min:?}"));
                assert_eq!(cell(&w, i, "max_tension_n"), format!("{max:?}"));
                let f = CableCabin::build(&s, 2).unwrap().modes.unwrap().frequencies_hz;
                assert_eq!(cell(&w, i, "f1_hz"), format!("{:?}", f[0]));
                assert_eq!(cell(&w, i, "f2_hz"), format!("{:?}", f[1]));
            }
            Err(e) => {
                assert_eq!(cell(&w, i, "feasible"), "false");
                assert_eq!(cell(&w, i, "note"), e.to_string());
                assert_eq!(x, -4.0, "only the points 4 m off centre are infeasible");
            }
        }
    }
    // the centre is the scene itself: lt50m.md, first frequency ≈ 0.47 Hz
    let centre = w.rows.keys().find(|&&i| cell(&w, i, "x_m") == "0.0" && cell(&w, i, "y_m") == "0.0").unwrap();
    let f1: f64 = cell(&w, *centre, "f1_hz").parse().unwrap();
    assert!((f1 - 0.466).abs() < 0.005, "{f1}");
}

#[test]
fn an_incomplete_set_of_parts_is_refused() {
    let scene = scene_path("lt50m_C.toml");
    let parts = dir("incomplete");
    ok(&words(&format!(
        "sweep --scene {scene} --modes 0 --quiet --shard 0/2 --grid x=-1:1:3 --out {}",
        parts.display()
    )));
    let out = master(&["sweep", "--merge", parts.to_str().unwrap(), "--out", dir("incomplete-out").to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("shard(s) 1/2 missing"), "{err}");
    let bad = master(&["sweep", "--scene", &scene, "--grid", "q=1", "--out", parts.to_str().unwrap()]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--grid q=1: unknown axis `q`"));
}

/// A coupled run per point: the peak displacement is the library's for that point's scene
/// (mass factor applied), and the step comes from the dt axis.
#[test]
fn coupled_runs_per_point_are_the_librarys() {
    let scene = scene_path("lt50m_C.toml");
    let out = dir("runs");
    ok(&words(&format!(
        "sweep --scene {scene} --modes 0 --quiet --run monolithic --t-end 0.3 --grid mass=0.5,2 --grid dt=0.01,0.02 --out {}",
        out.display()
    )));
    let t = Table::read(&out.join("sweep.csv")).unwrap();
    assert_eq!(t.rows.len(), 4);
    let base = Scene::load(&scene).unwrap();
    for &i in t.rows.keys() {
        let f: f64 = cell(&t, i, "mass_factor").parse().unwrap();
        let dt: f64 = cell(&t, i, "dt_s").parse().unwrap();
        let s = base.edited(|s| scale_platform_mass(s, f)).unwrap();
        let trace = simulate(&s, Path::new(&scene), Method::Monolithic, dt, 0.3).unwrap();
        assert_eq!(cell(&t, i, "run_peak_mm"), format!("{:?}", trace.peak_mm()), "point {i}");
        assert_eq!(cell(&t, i, "run_iterations"), format!("{:?}", trace.mean_iterations()));
        assert_eq!(trace.steps, (0.3 / dt).round() as u64);
    }
}

/// `master stability` runs its cases on several threads: the table it writes is the one a
/// single thread writes, cell for cell (verdicts, iterations, the reasons of the stops).
#[test]
fn stability_in_parallel_writes_what_a_serial_run_writes() {
    let (_, scene) = crate::common::scene("lt50m_C.toml", "stability-jobs", |_| {});
    let run = |jobs: &str| {
        let out = dir(&format!("stability-jobs-{jobs}"));
        ok(&words(&format!(
            "stability --scene {} --schemes jacobi,ijcsa --ratios 0.5,2 --dts 0.02,0.01 --t-end 4 --quiet \
             --jobs {jobs} --out {}",
            scene.display(),
            out.display()
        )));
        std::fs::read_to_string(out.join("stability.csv")).unwrap()
    };
    let (serial, parallel) = (run("1"), run("2"));
    assert_eq!(serial.lines().count(), 1 + 2 * 2 * 2, "{serial}");
    assert!(serial.contains("ijcsa,0.5,0.02,stable") && serial.contains("jacobi,2,0.01,"), "{serial}");
    assert_eq!(parallel, serial);
}

/// `master scaling` on a tiny mesh: one row per method and size, each set-up shorter than its
/// full run and its memory positive; the files written whole. Without GNU time (which gives the
/// peak memory) it refuses before running, naming the package.
#[test]
fn scaling_measures_every_method_and_size() {
    let (_, scene) = crate::common::scene("lt50m_C.toml", "scaling", |_| {});
    let out = dir("scaling");
    let cable = scene_path("lt50m_C_cable_only.toml");
    let args = format!(
        "scaling --scene {} --cable-scene {cable} --elements 4,8 --schemes cable,monolithic --t-end 0.5 --repeats 1 \
         --out {}",
        scene.display(),
        out.display()
    );
    let result = master(&words(&args));
    if !Path::new("/usr/bin/time").is_file() {
        assert!(!result.status.success());
        assert!(String::from_utf8_lossy(&result.stderr).contains("package `time`"));
        assert!(!out.join("scaling.csv").exists());
        return;
    }
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    let csv = std::fs::read_to_string(out.join("scaling.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let keys: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(keys, [("cable", "4"), ("cable", "8"), ("monolithic", "4"), ("monolithic", "8")]);
    for r in &rows {
        let x: Vec<f64> = r[2..].iter().map(|c| c.parse().unwrap()).collect();
        // set-up s, set-up MB, stepping s, peak MB, set-up CPU s, stepping CPU s
        assert!(x[0] > 0.0 && x[1] > 1.0 && x[2] >= 0.0 && x[3] >= x[1] * 0.9, "{r:?}");
    }
    let svg = std::fs::read_to_string(out.join("scaling.svg")).unwrap();
    assert!(svg.contains("elements per cable") && svg.contains("monolithic"));
    let table = String::from_utf8_lossy(&result.stdout);
    assert!(table.contains("| monolithic | 8 |"), "{table}");
}

/// A sweep and a stability map hand their scene variants to the FMUs in memory (a `data:` URI
/// in the `scene` parameter): nothing is written outside `--out`.
#[test]
fn scene_variants_are_handed_over_without_files() {
    let tmp = std::env::temp_dir().join(format!("master-variants-test-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let (_, scene) = crate::common::scene("lt50m_C.toml", "variants", |_| {});
    let out = tmp.join("out");
    let status = std::process::Command::new(crate::MASTER)
        .env("TMPDIR", &tmp)
        .args(["sweep", "--scene", scene.to_str().unwrap(), "--grid", "x=0,1", "--modes", "0", "--quiet"])
        .args(["--run", "ijcsa", "--t-end", "0.02", "--out", out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    let stability = std::process::Command::new(crate::MASTER)
        .env("TMPDIR", &tmp)
        .args(["stability", "--scene", scene.to_str().unwrap(), "--schemes", "ijcsa", "--ratios", "1"])
        .args(["--dts", "0.02", "--t-end", "0.04", "--quiet", "--out", out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(stability.success());
    let left: Vec<_> = std::fs::read_dir(&tmp).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, ["out"], "only the outputs are written");
    std::fs::remove_dir_all(&tmp).unwrap();
}

/// The FMUs run the variant in memory, not the file it was made from: with the platform's mass
/// doubled (a different added mass, a different response), IJCSA agrees with the monolithic
/// model of the same variant as closely as on the scene itself, and both differ from the file's.
#[test]
fn the_fmus_run_the_variant_held_in_memory() {
    use studies::simulate::{Method, simulate};
    let (base, file) = crate::common::scene("lt50m_C.toml", "in-memory", |_| {});
    let heavy = base.edited(|s| studies::sweep::scale_platform_mass(s, 2.0)).unwrap();
    let ijcsa = Method::Cosim(studies::cosim::Options { tol: 1e-10, ..Default::default() });
    let run = |s: &feedcore::scene::ValidScene, m: Method| simulate(s, &file, m, 0.01, 2.0).unwrap();
    let (mono, cosim) = (run(&heavy, Method::Monolithic), run(&heavy, ijcsa.clone()));
    let base_mono = run(&base, Method::Monolithic);
    let (agree, moved) = (cosim.error_against(&mono).0, base_mono.error_against(&mono).0);
    assert!(agree < 1e-3 * mono.peak_mm(), "ijcsa against monolithic on the variant: {agree} mm");
    assert!(moved > 100.0 * agree, "the variant's response is its own: {moved} mm from the file's");
}

/// The rows of a sweep's CSV without its wall-time columns.
fn rows_but_wall(csv: &std::path::Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len()).filter(|&i| !header[i].ends_with("wall_s")).collect();
    let mut rows = vec![keep.iter().map(|&i| header[i].to_string()).collect::<Vec<_>>()];
    for line in lines {
        let cells = studies::sweep::table::split(line).unwrap();
        rows.push(keep.iter().map(|&i| cells[i].clone()).collect());
    }
    rows
}

/// Waits until the journal holds `n` finished points (or the sweep ended).
fn wait_for_points(journal: &std::path::Path, child: &mut std::process::Child, n: usize) {
    let start = std::time::Instant::now();
    while std::fs::read_to_string(journal).map_or(0, |t| t.lines().count().saturating_sub(1)) < n {
        assert!(child.try_wait().unwrap().is_none(), "the sweep ended before {n} points");
        assert!(start.elapsed().as_secs() < 120, "no progress");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// A sweep killed halfway (SIGKILL: no chance to clean up) or interrupted (Ctrl-C: exit 130, no
/// table, the finished points kept) and continued with --resume gives the uninterrupted table,
/// but for its wall times; without --resume the journal is not overwritten.
#[test]
fn a_killed_or_interrupted_sweep_resumes_to_the_uninterrupted_table() {
    let (_, scene) = crate::common::scene("lt50m_C.toml", "resume", |_| {});
    let base = std::env::temp_dir().join(format!("master-resume-{}", std::process::id()));
    let args = |out: &std::path::Path| {
        let mut a: Vec<String> = ["sweep", "--scene", scene.to_str().unwrap(), "--grid", "x=-1:1:24", "--modes", "2"]
            .map(String::from)
            .to_vec();
        a.extend(["--run", "ijcsa", "--t-end", "20", "--jobs", "1", "--quiet", "--out"].map(String::from));
        a.push(out.display().to_string());
        a
    };
    let whole = base.join("whole");
    assert!(master(&args(&whole).iter().map(String::as_str).collect::<Vec<_>>()).status.success());
    let expected = rows_but_wall(&whole.join("sweep.csv"));
    assert_eq!(expected.len(), 25);

    for how in ["kill", "interrupt"] {
        let out = base.join(how);
        let journal = out.join("sweep.csv.partial");
        let mut child = std::process::Command::new(crate::MASTER)
            .args(args(&out))
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        wait_for_points(&journal, &mut child, 5);
        if how == "kill" {
            child.kill().unwrap();
            child.wait().unwrap();
        } else {
            let sent = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
            assert!(sent.success());
            let done = child.wait_with_output().unwrap();
            assert_eq!(done.status.code(), Some(130));
            let err = String::from_utf8_lossy(&done.stderr);
            assert!(err.contains("interrupted (Ctrl-C)") && err.contains("--resume"), "{err}");
        }
        assert!(!out.join("sweep.csv").exists(), "{how}: no table that looks complete");
        assert!(journal.exists(), "{how}: the finished points are kept");
        let said = (how == "kill").then(|| crate::resume::vandalize(&journal));
        let again = master(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
        assert!(!again.status.success() && String::from_utf8_lossy(&again.stderr).contains("--resume"));
        let mut resumed = args(&out);
        resumed.push("--resume".into());
        let done = master(&resumed.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert!(stderr.contains("done before"));
        assert!(said.is_none_or(|said| stderr.contains(said)), "{stderr}");
        assert_eq!(rows_but_wall(&out.join("sweep.csv")), expected, "{how}");
        assert!(!journal.exists(), "{how}: the journal goes when the sweep completes");
    }
    // a journal of other work is refused
    let out = base.join("foreign");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("sweep.csv.partial"), "# master journal: something else\n").unwrap();
    let mut resumed = args(&out);
    resumed.push("--resume".into());
    let refused = master(&resumed.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("a journal of other work"));
    std::fs::remove_dir_all(&base).unwrap();
}
