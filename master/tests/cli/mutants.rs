//! Every key of the reference scenes set to hostile values — 0, −0, negative, NaN, ±∞, huge,
//! tiny, the wrong type, the wrong length, missing, duplicated — and a cheap command run on each
//! mutant (a 5-step monolithic run, a 2-step co-simulation for the [system] keys, `modes` for
//! the analyses, the cable model alone for the disturbance). Each outcome must be one of:
//!
//! * success with finite results (every number in the JSON finite);
//! * a clean refusal (exit 1, `error:` first) that names the key;
//! * a clean stop while running or setting up that says when or why (exit 1, `error:` first);
//!
//! never a signal, a panic, a hang (each command has a time limit) or a non-finite result.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use toml::{Table, Value};

use crate::common;

/// Longest a mutant's command may take before it counts as a hang.
const TIME_LIMIT: Duration = Duration::from_secs(60);

/// One mutated scene and the command that tries it.
struct Mutant {
    /// `key: what was done`, for the report.
    label: String,
    /// The key's last name, which a refusal must mention.
    key_name: String,
    text: String,
    command: &'static [&'static str],
}

/// A key of the scene: its path of table keys and array indices.
#[derive(Clone)]
enum Step {
    Key(String),
    Index(usize),
}

fn path_text(path: &[Step]) -> String {
    let mut s = String::new();
    for p in path {
        match p {
            Step::Key(k) if s.is_empty() => s.push_str(k),
            Step::Key(k) => {
                s.push('.');
                s.push_str(k);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

fn get_mut<'a>(root: &'a mut Value, path: &[Step]) -> &'a mut Value {
    path.iter().fold(root, |v, p| match p {
        Step::Key(k) => v.as_table_mut().unwrap().get_mut(k).unwrap(),
        Step::Index(i) => &mut v.as_array_mut().unwrap()[*i],
    })
}

/// Every leaf (and every array, as a whole) of the scene, depth first.
fn leaves(v: &Value, path: &mut Vec<Step>, out: &mut Vec<(Vec<Step>, Value)>) {
    match v {
        Value::Table(t) => {
            for (k, x) in t {
                path.push(Step::Key(k.clone()));
                leaves(x, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            out.push((path.clone(), v.clone()));
            // the first element stands for all (a table element: every key of the first)
            if let Some(first) = a.first() {
                path.push(Step::Index(0));
                if first.is_table() || first.is_array() {
                    leaves(first, path, out);
                } else {
                    out.push((path.clone(), first.clone()));
                }
                path.pop();
            }
        }
        _ => out.push((path.clone(), v.clone())),
    }
}

/// The hostile replacements of a value.
fn replacements(v: &Value) -> Vec<(&'static str, Option<Value>)> {
    let mut r = Vec::new();
    match v {
        Value::Float(x) => {
            r.extend([
                ("0", Some(Value::Float(0.0))),
                ("-0", Some(Value::Float(-0.0))),
                ("negative", Some(Value::Float(if *x != 0.0 { -x } else { -1.0 }))),
                ("NaN", Some(Value::Float(f64::NAN))),
                ("+inf", Some(Value::Float(f64::INFINITY))),
                ("-inf", Some(Value::Float(f64::NEG_INFINITY))),
                ("huge", Some(Value::Float(1e300))),
                ("tiny", Some(Value::Float(1e-300))),
                ("wrong type", Some(Value::String("x".into()))),
            ]);
        }
        Value::Integer(_) => {
            r.extend([
                ("0", Some(Value::Integer(0))),
                ("negative", Some(Value::Integer(-1))),
                ("huge", Some(Value::Integer(i64::MAX))),
                ("tiny", Some(Value::Integer(1))),
                ("NaN", Some(Value::Float(f64::NAN))),
                ("inf", Some(Value::Float(f64::INFINITY))),
                ("fraction", Some(Value::Float(2.5))),
                ("wrong type", Some(Value::String("x".into()))),
            ]);
        }
        Value::String(_) => {
            r.extend([
                ("empty", Some(Value::String(String::new()))),
                // strings that FMU parameters read as numbers
                ("\"1e300\"", Some(Value::String("1e300".into()))),
                ("\"nan\"", Some(Value::String("nan".into()))),
                ("\"-1\"", Some(Value::String("-1".into()))),
                ("long", Some(Value::String("é\u{1b}".repeat(50_000)))),
                ("wrong type", Some(Value::Integer(1))),
            ]);
        }
        Value::Boolean(_) => r.push(("wrong type", Some(Value::Integer(1)))),
        Value::Array(a) => {
            let mut longer = a.clone();
            longer.extend(a.first().cloned());
            let mut shorter = a.clone();
            shorter.pop();
            let thousand: Vec<Value> = a.first().map(|f| vec![f.clone(); 1000]).unwrap_or_default();
            r.extend([
                ("one longer", Some(Value::Array(longer))),
                ("one shorter", Some(Value::Array(shorter))),
                ("1000 long", Some(Value::Array(thousand))),
                ("empty", Some(Value::Array(Vec::new()))),
                ("wrong type", Some(Value::Float(1.0))),
            ]);
        }
        _ => {}
    }
    r.push(("missing", None));
    r
}

/// The command that exercises a key cheaply.
fn command_for(path: &str) -> &'static [&'static str] {
    const RUN: &[&str] = &["run", "--scheme", "monolithic", "--t-end", "0.05", "--dt", "0.01", "--json", "--quiet"];
    // the scene's own step and end time: only the other one is given
    const RUN_OWN_DT: &[&str] = &["run", "--scheme", "monolithic", "--t-end", "0.05", "--json", "--quiet"];
    const RUN_OWN_END: &[&str] = &["run", "--scheme", "monolithic", "--dt", "0.01", "--json", "--quiet"];
    const COSIM: &[&str] = &["run", "--scheme", "ijcsa", "--t-end", "0.02", "--dt", "0.01", "--json", "--quiet"];
    const MODES: &[&str] = &["modes", "--json"];
    const CABLE: &[&str] = &["run", "--scheme", "cable", "--t-end", "0.05", "--dt", "0.01", "--json", "--quiet"];
    // the compensated scene: steps within a quarter of its 50 Hz sensor's period
    const COMPENSATED: &[&str] =
        &["run", "--scheme", "monolithic", "--t-end", "0.01", "--dt", "0.0025", "--json", "--quiet"];
    if path.starts_with("control") || path.starts_with("wind") {
        COMPENSATED
    } else if path.starts_with("system") {
        COSIM
    } else if path.starts_with("analyses.modes") {
        MODES
    } else if path.starts_with("disturbance") {
        CABLE
    } else if path.starts_with("solver.dt_s") {
        RUN_OWN_DT
    } else if path.starts_with("solver.t_end_s") {
        RUN_OWN_END
    } else {
        RUN
    }
}

/// All mutants of a scene file (its [system] pointing at the packaged FMUs).
fn mutants_of(text: &str, only: Option<&str>) -> Vec<Mutant> {
    let root = Value::Table(text.parse::<Table>().unwrap());
    let mut all = Vec::new();
    leaves(&root, &mut Vec::new(), &mut all);
    let mut out = Vec::new();
    for (path, value) in all {
        let key = path_text(&path);
        if only.is_some_and(|p| !key.starts_with(p)) {
            continue;
        }
        let key_name =
            path.iter().rev().find_map(|p| if let Step::Key(k) = p { Some(k.clone()) } else { None }).unwrap();
        let command = command_for(&key);
        for (what, replacement) in replacements(&value) {
            let mut m = root.clone();
            match (replacement, path.split_last().unwrap()) {
                (Some(r), _) => *get_mut(&mut m, &path) = r,
                (None, (Step::Key(k), parent)) => {
                    get_mut(&mut m, parent).as_table_mut().unwrap().remove(k);
                }
                (None, (Step::Index(i), parent)) => {
                    get_mut(&mut m, parent).as_array_mut().unwrap().remove(*i);
                }
            }
            out.push(Mutant {
                label: format!("{key}: {what}"),
                key_name: key_name.clone(),
                text: toml::to_string(&m).unwrap(),
                command,
            });
        }
    }
    // duplicated keys: every `key = …` line of the file written twice
    let lines: Vec<&str> = text.lines().collect();
    let mut table = String::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        if t.starts_with('[') {
            table = t.trim_matches(|c| c == '[' || c == ']').to_string();
            continue;
        }
        let Some((k, _)) = t.split_once('=') else { continue };
        let k = k.trim();
        if k.is_empty() || k.starts_with('#') || k.contains(' ') || k.starts_with('{') {
            continue;
        }
        let key = if table.is_empty() { k.to_string() } else { format!("{table}.{k}") };
        if only.is_some_and(|p| !key.starts_with(p)) {
            continue;
        }
        let mut dup = lines.clone();
        dup.insert(i + 1, line);
        out.push(Mutant {
            label: format!("{key}: duplicate"),
            key_name: k.trim_matches('"').to_string(),
            text: dup.join("\n"),
            command: command_for(&key),
        });
    }
    out
}

/// How one mutant ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Outcome {
    /// Exit 0 with finite results.
    Finite,
    /// Exit 1, refused before running, naming the key.
    RefusedNamingKey,
    /// Exit 1, stopped while running, with the time and the reason.
    StoppedAtTime,
    /// Exit 1, the model or the FMUs could not be set up with these values, with the reason.
    SetupRefused,
    // --- failures ---
    NonFinite,
    Unnamed,
    Panic,
    Signal,
    Hang,
}

impl Outcome {
    fn is_failure(self) -> bool {
        self >= Outcome::NonFinite
    }
}

/// Whether every number in a JSON document is finite (serde_json writes NaN and ∞ as null).
fn all_finite(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Null => false,
        serde_json::Value::Number(n) => n.as_f64().is_some_and(f64::is_finite),
        serde_json::Value::Array(a) => a.iter().all(all_finite),
        serde_json::Value::Object(o) => o.values().all(all_finite),
        _ => true,
    }
}

fn try_mutant(m: &Mutant, dir: &Path) -> (Outcome, String) {
    let scene = dir.join("scene.toml");
    let (stdout, stderr) = (dir.join("stdout"), dir.join("stderr"));
    std::fs::write(&scene, &m.text).unwrap();
    let mut child = Command::new(crate::MASTER)
        .args(m.command)
        .arg("--scene")
        .arg(&scene)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&stdout).unwrap())
        .stderr(std::fs::File::create(&stderr).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if start.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let err = String::from_utf8_lossy(&std::fs::read(&stderr).unwrap()).to_string();
    let first = err.lines().next().unwrap_or("").chars().take(200).collect::<String>();
    let Some(status) = status else { return (Outcome::Hang, String::new()) };
    let outcome = match status.code() {
        None => Outcome::Signal,
        Some(0) => match serde_json::from_slice::<serde_json::Value>(&std::fs::read(&stdout).unwrap()) {
            Ok(v) if all_finite(&v) => Outcome::Finite,
            _ => Outcome::NonFinite,
        },
        Some(1) if err.starts_with("error: ") && !err.contains("panicked") => {
            if err.contains(&m.key_name) {
                Outcome::RefusedNamingKey
            } else if err.contains("stopped at t = ") {
                Outcome::StoppedAtTime
            } else if err.contains("setting up the") || err.contains("cannot start") {
                Outcome::SetupRefused
            } else {
                Outcome::Unnamed
            }
        }
        Some(101) => Outcome::Panic,
        Some(_) if err.contains("panicked") => Outcome::Panic,
        Some(_) => Outcome::Unnamed,
    };
    (outcome, first)
}

/// Runs the mutants on two workers; returns the outcome of each.
fn run_all(mutants: &[Mutant]) -> Vec<(Outcome, String)> {
    let next = AtomicUsize::new(0);
    let results = Mutex::new(vec![(Outcome::Finite, String::new()); mutants.len()]);
    std::thread::scope(|s| {
        for w in 0..2 {
            let (next, results) = (&next, &results);
            s.spawn(move || {
                let dir = std::env::temp_dir().join(format!("master-mutants-{}-{w}", std::process::id()));
                std::fs::create_dir_all(&dir).unwrap();
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(m) = mutants.get(i) else { break };
                    let r = try_mutant(m, &dir);
                    results.lock().unwrap()[i] = r;
                }
                let _ = std::fs::remove_dir_all(&dir);
            });
        }
    });
    results.into_inner().unwrap()
}

fn scene_text(name: &str) -> (String, PathBuf) {
    let (_, file) = common::scene(name, "mutants", |_| {});
    (std::fs::read_to_string(&file).unwrap(), file)
}

#[test]
fn every_scene_key_survives_hostile_values() {
    let started = Instant::now();
    let (coupled, _) = scene_text("lt50m_C.toml");
    let cable_only = std::fs::read_to_string(common::scene_path("lt50m_C_cable_only.toml")).unwrap();
    let mut mutants = mutants_of(&coupled, None);
    mutants.extend(mutants_of(&cable_only, Some("disturbance")));
    let (compensated, _) = scene_text("lt50m_C_sampled.toml");
    mutants.extend(mutants_of(&compensated, Some("control")));
    mutants.extend(mutants_of(&compensated, Some("wind")));
    let results = run_all(&mutants);
    let mut counts: BTreeMap<Outcome, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    // MUTANTS_VERBOSE=1 lists every mutant with its outcome and the first line of its error
    let verbose = std::env::var_os("MUTANTS_VERBOSE").is_some();
    for (m, (outcome, first)) in mutants.iter().zip(&results) {
        *counts.entry(*outcome).or_default() += 1;
        if verbose {
            eprintln!("{outcome:?}\t{}\t{first}", m.label);
        }
        if outcome.is_failure() {
            failures.push(format!("{} [{}]: {outcome:?}: {first}", m.label, m.command.join(" ")));
        }
    }
    eprintln!("{} mutants in {:.1} s:", mutants.len(), started.elapsed().as_secs_f64());
    for (o, n) in &counts {
        eprintln!("  {o:?}: {n}");
    }
    assert!(failures.is_empty(), "{} of {} mutants failed:\n{}", failures.len(), mutants.len(), failures.join("\n"));
    assert!(mutants.len() > 500, "every key is mutated: {}", mutants.len());
}
