//! Careless and hostile use of the command line: each gets a clear error naming what is wrong
//! and a non-zero exit, or the right behaviour; no file is clobbered and none is left stale.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use crate::{common, master};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("master-misuse-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A clean refusal: exit 1, `error:` first, every `needles` in the message, no panic.
#[track_caller]
fn refused(out: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{err}");
    // notes (e.g. on removed files) may come first; then the error and its causes
    assert!(err.lines().any(|l| l.starts_with("error: ")), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` missing from: {err}");
    }
    err
}

/// Output paths are checked before the run: none may name an input or another output, the
/// plot must be SVG, and an unwritable place is named.
#[test]
fn output_paths_are_checked_before_the_run() {
    let dir = scratch("paths");
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-paths", |_| {});
    let scene_text = std::fs::read(&scene).unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--scene", s(&scene), "--scheme", "monolithic", "--t-end", "0.05", "--quiet"];
        args.extend_from_slice(extra);
        master(&args)
    };
    // the scene itself, by another name
    let alias = dir.join("alias.toml");
    std::os::unix::fs::symlink(&scene, &alias).unwrap();
    for target in [s(&scene), s(&alias)] {
        refused(&run(&["--out", target]), &["--out", "input of the run"]);
    }
    assert_eq!(std::fs::read(&scene).unwrap(), scene_text, "the scene is untouched");
    // an FMU archive of the run
    let fmu = common::fmu_dir().join("cable_fmu.fmu");
    let fmu_bytes = std::fs::read(&fmu).unwrap();
    refused(&run(&["--out", s(&fmu)]), &["input of the run"]);
    assert_eq!(std::fs::read(&fmu).unwrap(), fmu_bytes);
    // two outputs on one file
    let svg = dir.join("a.svg");
    refused(
        &run(&["--out", s(&svg), "--plot", &format!("{}/./a.svg", s(&dir))]),
        &["--plot", "the same file as --out"],
    );
    // the plot's extension, before anything runs or is written
    let csv = dir.join("x.csv");
    refused(&run(&["--out", s(&csv), "--plot", s(&dir.join("x.png"))]), &["--plot", "x.png", "SVG"]);
    assert!(!csv.exists(), "nothing written");
    // a refused command line touches no earlier result
    std::fs::write(&csv, "earlier").unwrap();
    refused(&run(&["--out", s(&csv), "--plot", s(&dir.join("x.png"))]), &["SVG"]);
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), "earlier");
    std::fs::remove_file(&csv).unwrap();
    // a place that cannot be written is named
    refused(&run(&["--out", "/proc/x.csv"]), &["--out /proc/x.csv"]);
    refused(&run(&["--out", s(&dir)]), &["is a directory"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A failed run leaves no file behind that looks like its result: neither a partial one nor
/// one from an earlier run under the same name.
#[test]
fn a_failed_run_leaves_no_stale_output() {
    let dir = scratch("stale");
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-stale", |_| {});
    let (csv, svg) = (dir.join("r.csv"), dir.join("r.svg"));
    let ok = master(&[
        "run",
        "--scene",
        s(&scene),
        "--scheme",
        "monolithic",
        "--t-end",
        "0.05",
        "--quiet",
        "--out",
        s(&csv),
        "--plot",
        s(&svg),
    ]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(csv.is_file() && svg.is_file());
    // jacobi diverges after 0.6 s: the run fails, and the earlier results go
    let failed = master(&[
        "run",
        "--scene",
        s(&scene),
        "--scheme",
        "jacobi",
        "--t-end",
        "5",
        "--quiet",
        "--out",
        s(&csv),
        "--plot",
        s(&svg),
    ]);
    let err = refused(&failed, &["stopped at t = ", "jacobi"]);
    assert!(err.contains("removed"), "{err}");
    assert!(!csv.exists() && !svg.exists(), "no stale result");
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(leftovers.is_empty(), "no temporary file left: {leftovers:?}");
    // bench: a step longer than the run is refused before anything runs or is written
    let bench_dir = dir.join("bench");
    let out =
        master(&["bench", "--scene", s(&scene), "--dts", "0.05", "--t-end", "0.01", "--out", s(&bench_dir), "--quiet"]);
    refused(&out, &["not a whole number of steps", "0.05"]);
    assert!(!bench_dir.join("bench.csv").exists() && !bench_dir.join("work_precision.svg").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run that is killed leaves nothing the next run trips over: SIGKILL leaves its hidden
/// temporary files (no process can prevent that), and the next run into the same place removes
/// them; SIGTERM stops the run like Ctrl-C (exit 130), its temporary files and the earlier
/// run's results under the same names removed.
#[test]
fn a_killed_run_leaves_nothing_behind_for_long() {
    let dir = scratch("killed");
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-killed", |_| {});
    let csv = dir.join("r.csv");
    let run = |t_end: &str| {
        Command::new(crate::MASTER)
            .args([
                "run",
                "--scene",
                s(&scene),
                "--scheme",
                "monolithic",
                "--quiet",
                "--t-end",
                t_end,
                "--out",
                s(&csv),
            ])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let hidden = || -> Vec<String> {
        std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.'))
            .collect()
    };
    let started = |child: &mut std::process::Child| {
        let t0 = std::time::Instant::now();
        while hidden().is_empty() {
            assert!(child.try_wait().unwrap().is_none(), "the run ended before it was killed");
            assert!(t0.elapsed().as_secs() < 60, "no temporary file");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    };
    let mut child = run("5000");
    started(&mut child);
    child.kill().unwrap();
    child.wait().unwrap();
    let left = hidden();
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(left[0].starts_with(".r.csv.") && left[0].ends_with(".tmp"), "{left:?}");
    assert!(run("0.05").wait_with_output().unwrap().status.success());
    assert!(hidden().is_empty() && csv.is_file(), "the next run removes what the killed one left");

    let mut child = run("5000");
    started(&mut child);
    assert!(Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap().success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted") && err.contains("removed"), "{err}");
    assert!(hidden().is_empty() && !csv.exists(), "nothing left behind: {:?}", hidden());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The step against the end time: reached exactly, or refused up front with the nearest end
/// times that work; steps and end times are parsed as numbers even when negative.
#[test]
fn steps_must_reach_the_end_time() {
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-steps", |_| {});
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--scene", s(&scene), "--scheme", "monolithic", "--quiet", "--json"];
        args.extend_from_slice(extra);
        master(&args)
    };
    refused(&run(&["--dt", "5", "--t-end", "1"]), &["not a whole number of steps", "end time of 5 s"]);
    refused(&run(&["--dt", "0.3", "--t-end", "1"]), &["0.9 s or 1.2 s"]);
    refused(&run(&["--dt", "-0.01"]), &["h = -0.01 s", "positive"]);
    refused(&run(&["--t-end", "-1"]), &["end time -1 s", "positive"]);
    refused(&run(&["--dt", "nan"]), &["h = NaN"]);
    let ok = run(&["--dt", "0.1", "--t-end", "0.3"]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let v: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert_eq!((v["steps"].as_u64(), v["t_end"].as_f64()), (Some(3), Some(0.3)));
}

/// Unbounded work is capped, each cap with its flag; the memory a scene needs is estimated
/// before anything is built.
#[test]
fn work_and_memory_are_capped_up_front() {
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-caps", |_| {});
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--scene", s(&scene), "--scheme", "monolithic", "--quiet"];
        args.extend_from_slice(extra);
        master(&args)
    };
    refused(&run(&["--dt", "1e-9"]), &["exceed the cap of 1000000 steps", "--max-steps"]);
    refused(&run(&["--t-end", "1e300"]), &["--max-steps"]);
    refused(&run(&["--t-end", "1", "--max-steps", "50"]), &["100 steps", "cap of 50"]);
    // ten million elements per cable: about 400 GB
    let (_, big) = common::scene("lt50m_C.toml", "misuse-big", |s| s.cables.elements = 10_000_000);
    let started = std::time::Instant::now();
    let out = master(&["run", "--scene", s(&big), "--scheme", "monolithic", "--quiet"]);
    refused(&out, &["would need about", "MB", "10000000 elements", "--max-memory-mb"]);
    assert!(started.elapsed().as_secs() < 10, "refused before building anything");
    // the modes of 20,000 elements per cable need about 350 MB (chain model and Lanczos basis,
    // both linear): over a 200 MB cap
    let (_, mid) = common::scene("lt50m_C.toml", "misuse-mid", |s| s.cables.elements = 20_000);
    let out = master(&["modes", "--scene", s(&mid), "--max-memory-mb", "200"]);
    refused(&out, &["200 MB", "--max-memory-mb", "6 modes of 359988 unknowns"]);
    // the scene file: only regular files, never more than the cap
    refused(&master(&["statics", "--scene", "/dev/zero"]), &["/dev/zero", "not a regular file"]);
    let dir = scratch("fifo");
    let fifo = dir.join("scene.toml");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    refused(&master(&["statics", "--scene", s(&fifo)]), &["not a regular file"]);
    refused(
        &master(&["statics", "--scene", s(&scene), "--max-scene-bytes", "100"]),
        &["limit of 100 bytes", "--max-scene-bytes"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Caps given in megabytes are counted in bytes: one that does not fit in 64 bits is refused by
/// name before anything runs (2^44 MB of unpacking wrapped around to a tiny cap, and the archive's
/// description read as empty); the largest that fits works as no cap at all.
#[test]
fn megabyte_caps_that_overflow_are_refused_by_name() {
    let dir = scratch("megabytes");
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-mb", |_| {});
    let ssp = dir.join("c.ssp");
    assert!(master(&["export-ssp", "--scene", s(&scene), "--out", s(&ssp)]).status.success());
    let run = |flag: &str, mb: &str| {
        master(&[
            "run",
            "--system",
            s(&ssp),
            "--scheme",
            "ijcsa",
            "--dt",
            "0.01",
            "--t-end",
            "0.02",
            "--quiet",
            flag,
            mb,
        ])
    };
    for (flag, most) in [("--max-unpacked-mb", (u64::MAX >> 20)), ("--max-memory-mb", u64::MAX / 1_000_000)] {
        for over in [most + 1, u64::MAX] {
            let out = run(flag, &over.to_string());
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{err}");
            assert!(
                err.contains(flag) && err.contains(&format!("at most {most} MB")) && !err.contains("panicked"),
                "{err}"
            );
        }
        let out = run(flag, &most.to_string());
        assert!(out.status.success(), "{flag} {most}: {}", String::from_utf8_lossy(&out.stderr));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The memory estimate is an upper bound of what a build takes, within a factor of two: the
/// peak resident memory (the kernel's VmHWM) of `master modes` (model, tangent matrices, Lanczos
/// basis) at 20 and 320 elements per cable, with the scene's modes and with 200. (Measured by
/// the process itself: a child's rusage would count the test process's own memory, which the
/// child has until it execs.)
#[test]
fn the_memory_estimate_bounds_the_measured_peak() {
    for elements in [20, 320] {
        let tag = format!("misuse-rss-{elements}");
        let (scene, file) = common::scene("lt50m_C.toml", &tag, |s| s.cables.elements = elements);
        for count in [scene.analyses.modes, 200] {
            let out = master(&["modes", "--json", "--scene", s(&file), "--count", &count.to_string()]);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let measured = v["peak_memory_bytes"].as_u64().expect("Linux reports VmHWM");
            let (estimate, _) = studies::limits::memory_needed(&scene, studies::limits::Footprint::CableModel, count);
            assert_eq!(v["memory_estimate_bytes"].as_u64(), Some(estimate));
            eprintln!(
                "{elements} elements, {count} modes: estimate {:.1} MB, measured {:.1} MB",
                estimate as f64 / 1e6,
                measured as f64 / 1e6
            );
            assert!(estimate >= measured && estimate <= 2 * measured, "{estimate} against {measured}");
        }
    }
}

/// Small ones: `modes --count 0`, `--scheme cable` without a disturbance, a scene under a
/// non-UTF-8 path (it runs), and a reader that goes away.
#[test]
fn small_misuses_are_refused_clearly() {
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-small", |_| {});
    let out = master(&["modes", "--scene", s(&scene), "--count", "0"]);
    assert_eq!(out.status.code(), Some(2), "a usage error");
    assert!(String::from_utf8_lossy(&out.stderr).contains("'0'"));
    refused(&master(&["run", "--scene", s(&scene), "--scheme", "cable", "--quiet"]), &["[disturbance]", "has none"]);
    // a scene under a non-UTF-8 path runs with the FMUs too: they receive the scene itself (a
    // data: URI), not its path, which an FMI string could not carry
    let dir = scratch("utf8");
    let odd = dir.join(<std::ffi::OsStr as std::os::unix::ffi::OsStrExt>::from_bytes(b"sc\xffene.toml"));
    std::fs::copy(&scene, &odd).unwrap();
    let out = Command::new(crate::MASTER)
        .args(["run", "--scheme", "ijcsa", "--t-end", "0.02", "--quiet", "--scene"])
        .arg(&odd)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = Command::new(crate::MASTER).args(["statics", "--json", "--scene"]).arg(&odd).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::remove_dir_all(&dir).unwrap();
    // `master statics | head -1`: no panic, a quiet exit
    let mut child = Command::new(crate::MASTER)
        .args(["statics", "--scene", s(&scene)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away before anything is written
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `master stability` on a scene whose FMU is missing is an error, not a map of "unstable".
#[test]
fn stability_reports_a_missing_fmu_as_an_error() {
    let mut scene = feedcore::scene::Scene::load(common::scene_path("lt50m_B.toml")).unwrap().to_scene();
    scene.system.as_mut().unwrap().fmus[0].path = "/nonexistent/cable_fmu.fmu".into();
    let file = common::fmu_dir().join("misuse-stability.toml");
    std::fs::write(&file, scene.to_toml()).unwrap();
    let scene = file;
    let dir = scratch("stability");
    let out = master(&[
        "stability",
        "--scene",
        s(&scene),
        "--schemes",
        "ijcsa",
        "--ratios",
        "1",
        "--dts",
        "0.02",
        "--t-end",
        "0.04",
        "--out",
        s(&dir),
        "--quiet",
    ]);
    refused(&out, &["/nonexistent/cable_fmu.fmu", "ijcsa"]);
    assert!(!dir.join("stability.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The adaptive step's options: --dt refused with it (the step is chosen), a scheme that does
/// not iterate refused, the step range and the tolerances checked, the step cap checked up front
/// at the largest step and enforced while the run goes.
#[test]
fn the_adaptive_step_is_checked_too() {
    let (_, scene) = common::scene("lt50m_C.toml", "misuse-adaptive", |_| {});
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "--scene", s(&scene), "--quiet", "--adaptive"];
        args.extend_from_slice(extra);
        master(&args)
    };
    refused(&run(&["--scheme", "ijcsa", "--dt", "0.01"]), &["--dt", "adaptive step chooses"]);
    for scheme in ["jacobi", "gauss-seidel", "decoupled", "cable"] {
        refused(&run(&["--scheme", scheme]), &["--adaptive", &format!("`{scheme}`")]);
    }
    refused(&run(&["--scheme", "ijcsa", "--h-min", "0.2", "--h-max", "0.1"]), &["--h-min 0.2", "--h-max 0.1"]);
    for (flag, value) in [("--rtol", "0"), ("--rtol", "1"), ("--atol", "-1"), ("--h-min", "nan"), ("--h-max", "inf")] {
        let out = run(&["--scheme", "ijcsa", flag, value]);
        assert_eq!(out.status.code(), Some(2), "{flag} {value}: a usage error");
        assert!(String::from_utf8_lossy(&out.stderr).contains(flag), "{flag} {value}");
    }
    refused(
        &run(&["--scheme", "ijcsa", "--h-max", "1e-6", "--h-min", "1e-7"]),
        &["even at the largest step --h-max", "cap of 1000000 steps"],
    );
    refused(
        &run(&["--scheme", "iqn-ils", "--t-end", "1", "--max-steps", "20"]),
        &["stopped at t = ", "cap of 20 steps", "--max-steps"],
    );
}

#[test]
fn a_failed_replay_leaves_no_output() {
    let dir = scratch("replay");
    let (inputs, out) = (dir.join("in.csv"), dir.join("out.csv"));
    let names: Vec<String> = cable_fmu::input_names();
    let scene = common::scene_path("lt50m_C.toml");
    let model = cable::model::CableCabin::from_scene(&feedcore::scene::Scene::load(&scene).unwrap()).unwrap();
    let w0 = model.static_payload_wrench();
    let row = |t: f64, w: &[f64]| format!("{t},{}", w.iter().map(f64::to_string).collect::<Vec<_>>().join(","));
    let mut table = format!("time,{}\n{}\n{}\n", names.join(","), row(0.0, w0.as_slice()), row(0.01, w0.as_slice()));
    std::fs::write(&inputs, &table).unwrap();
    let args = ["replay", "--model", "cable_fmu", "--scene", s(&scene), "--inputs", s(&inputs)];
    let ok = master(&[&args[..], &["--out", s(&out)]].concat());
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 3, "header and two rows");
    // a wrench of 1e300 N held over the second step stops the model: no output, not even the
    // earlier one
    table.push_str(&row(0.02, &[1e300; 6]));
    std::fs::write(&inputs, &table).unwrap();
    let failed = master(&[&args[..], &["--out", s(&out)]].concat());
    refused(&failed, &["stopped at t = 0.02", "NaN"]);
    assert!(!out.exists(), "no partial output");
    // the inputs themselves are never overwritten
    let clobber = master(&[&args[..], &["--out", s(&inputs)]].concat());
    refused(&clobber, &["--out", "input of the run"]);
    assert!(std::fs::read_to_string(&inputs).unwrap() == table);
}
