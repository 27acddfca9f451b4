//! Long commands killed halfway and continued with `--resume`: the stability map, the bench and
//! the compensation study give the uninterrupted results (but for wall times), also from a
//! journal damaged after the kill. The sweep's test, with the interrupt as well, is in `sweep`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{MASTER, common, master};

/// A journal line signed as the journal signs it (the FNV-1a digest of the cells before it):
/// what a careless edit that also mended the digest would leave.
fn signed(cells: &[String]) -> String {
    let mut body: String = cells.iter().map(|c| format!("{},", studies::sweep::table::quoted(c))).collect();
    let digest = fmi::digest::digest(body.as_bytes());
    body.push_str(&format!("{digest:016x},\u{1e}\n"));
    body
}

/// Damages the journal of a killed command three ways and returns the message its resumption
/// must give: its last point's line gets an infinite number in its last cell but one (the
/// digest mended, so that only the command's own check of the cells refuses it), and two lines
/// are added, one of binary bytes and one edited without its digest mended.
pub(crate) fn vandalize(journal: &Path) -> &'static str {
    let text = std::fs::read_to_string(journal).unwrap();
    let whole: Vec<&str> = text.split_inclusive('\n').filter(|l| l.ends_with("\u{1e}\n")).collect();
    let last = *whole.last().expect("a finished point");
    let mut cells = studies::sweep::table::split(last.trim_end_matches('\n')).unwrap();
    let n = cells.len();
    assert!(n >= 6, "index, key, two cells at least, digest, end: {last:?}");
    cells[n - 4] = "inf".into();
    let mut damaged = text.replacen(last, &signed(&cells[..n - 2]), 1);
    damaged.push_str(&whole[0].replacen(',', ",9", 2));
    let mut bytes = damaged.into_bytes();
    bytes.extend_from_slice(b"\x00\xff\xfe binary \x1e\n");
    std::fs::write(journal, bytes).unwrap();
    "3 lines dropped"
}

/// Runs `args` into `out` and kills it (SIGKILL) once its journal holds `points`, damages the
/// journal ([`vandalize`]), then continues it with --resume; returns the directory.
fn killed_and_resumed(args: &[String], out: &Path, journal: &str, points: usize) {
    let journal = out.join(journal);
    let mut child = Command::new(MASTER).args(args).arg("--out").arg(out).stderr(Stdio::null()).spawn().unwrap();
    let start = Instant::now();
    while std::fs::read_to_string(&journal).map_or(0, |t| t.lines().count().saturating_sub(1)) < points {
        assert!(child.try_wait().unwrap().is_none(), "ended before {points} points: make the work longer");
        assert!(start.elapsed() < Duration::from_secs(120), "no progress");
        std::thread::sleep(Duration::from_millis(10));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(journal.exists());
    let said = vandalize(&journal);
    let mut resumed: Vec<&str> = args.iter().map(String::as_str).collect();
    resumed.extend(["--out", out.to_str().unwrap(), "--resume"]);
    let done = master(&resumed);
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{stderr}");
    assert_eq!(stderr.matches("dropped").count(), 1, "said once: {stderr}");
    assert!(stderr.contains(said), "{stderr}");
    assert!(!journal.exists(), "the journal goes when the work completes");
}

/// The lines of a CSV without the column `drop` (wall times).
fn without(csv: &Path, drop: &str) -> Vec<String> {
    let text = std::fs::read_to_string(csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let skip = header.iter().position(|h| *h == drop);
    text.lines()
        .map(|l| {
            let cells = studies::sweep::table::split(l).unwrap();
            cells
                .iter()
                .enumerate()
                .filter(|(i, _)| Some(*i) != skip)
                .map(|(_, c)| c.as_str())
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

fn dirs(tag: &str) -> (PathBuf, PathBuf) {
    let base = std::env::temp_dir().join(format!("master-resume-{tag}-{}", std::process::id()));
    (base.join("whole"), base.join("resumed"))
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| s.to_string()).collect()
}

#[test]
fn a_killed_stability_map_resumes_to_the_same_map() {
    let (_, scene) = common::scene("lt50m_C.toml", "resume-stability", |_| {});
    let args = strings(&[
        "stability",
        "--scene",
        scene.to_str().unwrap(),
        "--schemes",
        "ijcsa,iqn-ils",
        "--ratios",
        "0.5,1,2",
        "--dts",
        "0.02,0.01",
        "--t-end",
        "40",
        "--jobs",
        "1",
        "--quiet",
    ]);
    let (whole, resumed) = dirs("stability");
    let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
    all.extend(["--out", whole.to_str().unwrap()]);
    assert!(master(&all).status.success());
    killed_and_resumed(&args, &resumed, "stability.csv.partial", 4);
    for f in ["stability.csv", "stability.svg"] {
        assert_eq!(std::fs::read(whole.join(f)).unwrap(), std::fs::read(resumed.join(f)).unwrap(), "{f}");
    }
}

#[test]
fn a_killed_bench_resumes_to_the_same_table() {
    let (_, scene) = common::scene("lt50m_C.toml", "resume-bench", |_| {});
    let args = strings(&[
        "bench",
        "--scene",
        scene.to_str().unwrap(),
        "--schemes",
        "monolithic,ijcsa,iqn-ils",
        "--dts",
        "0.02,0.01,0.005",
        "--t-end",
        "60",
        "--repeats",
        "1",
        "--quiet",
    ]);
    let (whole, resumed) = dirs("bench");
    let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
    all.extend(["--out", whole.to_str().unwrap()]);
    assert!(master(&all).status.success());
    killed_and_resumed(&args, &resumed, "bench.csv.partial", 3);
    assert_eq!(without(&whole.join("bench.csv"), "wall_time_s"), without(&resumed.join("bench.csv"), "wall_time_s"));
}

#[test]
fn a_killed_compensation_study_resumes_to_the_same_tables() {
    let (_, scene) = common::scene("lt50m_C_sampled.toml", "resume-compensation", |_| {});
    let args = strings(&[
        "compensation",
        "--scene",
        scene.to_str().unwrap(),
        "--t-end",
        "2",
        "--sweep-t-end",
        "4",
        "--rates",
        "10,25,50",
        "--delays",
        "0,0.02,0.05,0.1",
        "--jobs",
        "1",
    ]);
    let (whole, resumed) = dirs("compensation");
    let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
    all.extend(["--out", whole.to_str().unwrap()]);
    assert!(master(&all).status.success());
    killed_and_resumed(&args, &resumed, "sweep.csv.partial", 3);
    for f in ["sweep.csv", "compensation.csv"] {
        assert_eq!(std::fs::read(whole.join(f)).unwrap(), std::fs::read(resumed.join(f)).unwrap(), "{f}");
    }
}
