//! Model Exchange components: careless and hostile FMUs (`hostile_me`, each fault switched on by
//! a parameter) end the run with an error naming the component, the time and the cause —
//! never a hang, a panic or a NaN reported as success; and a unit the master integrates is
//! rolled back bit for bit by the iterating schemes (a step undone and taken again, an adaptive
//! run's rejected tries), events included.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use studies::cosim::{Coupled, FmuSystem, JacobianUpdate, Options, Scheme, SystemSpec};

use crate::{MASTER, common};

/// Longest a run may take before it counts as a hang.
const TIME_LIMIT: Duration = Duration::from_secs(60);

/// A folder with `hostile_me` and `feedthrough` of FMI `version`, and an `.ssd` connecting
/// `bad.x` to `f`, with `bad`'s parameters set: (misbehaviour, x0).
fn hostile_system(tag: &str, version: u8, misbehaviour: i32, x0: f64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("master-me-{tag}-v{version}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let zoo = if version == 3 { common::zoo_dir().join("fmi3") } else { common::zoo_dir().to_owned() };
    for name in ["hostile_me", "feedthrough"] {
        std::fs::copy(zoo.join(format!("{name}.fmu")), dir.join(format!("{name}.fmu"))).unwrap();
    }
    let bindings = common::parameter_bindings(
        "bad",
        &[("misbehaviour", "Integer", misbehaviour.to_string()), ("x0", "Real", x0.to_string())],
    );
    let elements = format!(
        r#"      <ssd:Component name="bad" source="hostile_me.fmu">
{bindings}
      </ssd:Component>
      <ssd:Component name="f" source="feedthrough.fmu"/>"#
    );
    let connections = r#"      <ssd:Connection startElement="bad" startConnector="x" endElement="f" endConnector="real_continuous_in"/>"#;
    let ssd = common::ssd_text("hostile", &elements, connections, "2");
    let path = dir.join("hostile.ssd");
    std::fs::write(&path, ssd).unwrap();
    path
}

/// `master run --system ssd` with `args`, killed as a hang after [`TIME_LIMIT`]: (exit code,
/// stderr, stdout). A signal fails the test.
fn run_limited(ssd: &Path, args: &[&str]) -> (i32, String, String) {
    let mut child = Command::new(MASTER)
        .args(["run", "--system", ssd.to_str().unwrap()])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > TIME_LIMIT {
            child.kill().unwrap();
            panic!("{} {args:?}: hangs", ssd.display());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = child.wait_with_output().unwrap();
    let code = out.status.code().unwrap_or_else(|| panic!("{args:?}: killed by a signal"));
    (code, String::from_utf8_lossy(&out.stderr).into_owned(), String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The well-behaved `hostile_me` (ẋ = −x, a time event at 0.5 s that changes nothing) runs to
/// e^{−t} in a system with a Co-Simulation FMU, both versions: the baseline the faults depart from.
#[test]
fn the_hostile_fmu_behaving_well_meets_its_exact_solution() {
    for version in [2, 3] {
        let ssd = hostile_system("well", version, 0, 1.0);
        let csv = ssd.with_file_name("well.csv");
        let (code, err, out) = run_limited(
            &ssd,
            &[
                "--scheme",
                "jacobi",
                "--dt",
                "0.1",
                "--me-rtol",
                "1e-10",
                "--me-atol",
                "1e-12",
                "--json",
                "--out",
                csv.to_str().unwrap(),
            ],
        );
        assert_eq!(code, 0, "{err}");
        let json: serde_json::Value = serde_json::from_str(&out).unwrap();
        let me = &json["model_exchange"][0];
        assert_eq!((me["component"].as_str(), me["time_events"].as_u64()), (Some("bad"), Some(1)), "{json}");
        let text = std::fs::read_to_string(&csv).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let (ct, cx) = (0, header.iter().position(|h| *h == "bad.x").unwrap());
        let mut rows = 0;
        for line in text.lines().skip(1) {
            let cells: Vec<&str> = line.split(',').collect();
            let (t, x): (f64, f64) = (cells[ct].parse().unwrap(), cells[cx].parse().unwrap());
            assert!((x - (-t).exp()).abs() < 1e-9, "FMI {version}: x({t}) = {x}");
            rows += 1;
        }
        assert_eq!(rows, 21, "FMI {version}: every row, 0 to 2 s");
    }
}

/// The number `err` gives after `prefix`.
fn number_after(err: &str, prefix: &str) -> f64 {
    let rest = &err[err.find(prefix).unwrap_or_else(|| panic!("`{prefix}` missing from: {err}")) + prefix.len()..];
    let end = rest.find(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == '-')).unwrap_or(rest.len());
    rest[..end].trim_end_matches('.').parse().unwrap_or_else(|_| panic!("no number after `{prefix}`: {err}"))
}

/// Each fault, under Jacobi and IJCSA (which rolls the unit back while it iterates): exit 1,
/// one clean error naming the component, the time and the cause, within the time limit, and
/// no CSV; FMI 2.0 and 3.0 (the state count only in FMI 3.0, which reports it).
#[test]
fn hostile_model_exchange_fmus_are_stopped_with_a_clear_error() {
    // (misbehaviour, x0, versions, what the error must say, (the time it names, exact value))
    type Case<'a> = (i32, f64, &'a [u8], &'a [&'a str], (&'a str, f64));
    let cases: [Case; 5] = [
        (1, 1.0, &[2, 3], &["der_x", "NaN"], ("at t = ", 0.5)),
        // the relay (delta = 1e-6) starts at 1 + delta and switches every 2 delta: the 10001st event
        (
            2,
            1.0,
            &[2, 3],
            &["events in one macro step", "does not settle"],
            ("the last at t = ", 1.0 + 1e-6 + 10_000.0 * 2e-6),
        ),
        (3, 1.0, &[2, 3], &["did not end", "another update"], ("event iteration at t = ", 0.5)),
        (4, 1.0, &[3], &["reports 2 continuous states", "declares 1"], ("at t = ", 0.5)),
        // ẋ = x² from 0.8 blows up at 1.25 s
        (
            5,
            0.8,
            &[2, 3],
            &["cannot meet the tolerance", "largest state `x`"],
            ("the tolerance (rtol 1e-6, atol 1e-8) at t = ", 1.25),
        ),
    ];
    for (misbehaviour, x0, versions, needles, (prefix, t)) in cases {
        for &version in versions {
            for scheme in ["jacobi", "ijcsa"] {
                let ssd = hostile_system(&format!("m{misbehaviour}"), version, misbehaviour, x0);
                let csv = ssd.with_file_name(format!("{scheme}.csv"));
                let (code, err, _) =
                    run_limited(&ssd, &["--scheme", scheme, "--dt", "0.1", "--out", csv.to_str().unwrap()]);
                let label = format!("misbehaviour {misbehaviour}, FMI {version}, {scheme}");
                assert_eq!(code, 1, "{label}: {err}");
                assert!(err.starts_with("error: ") && !err.contains("panicked"), "{label}: {err}");
                assert!(err.contains("FMU `bad`"), "{label}: the component is not named: {err}");
                for n in needles {
                    assert!(err.contains(n), "{label}: `{n}` missing from: {err}");
                }
                let named = number_after(&err, prefix);
                assert!((named - t).abs() < 1e-6, "{label}: the time named is {named}, not {t}: {err}");
                assert!(!csv.exists(), "{label}: a failed run leaves no CSV");
            }
        }
    }
}

fn coupled(spec: &SystemSpec, o: Options, adaptive: bool) -> Coupled<FmuSystem> {
    Coupled::new(FmuSystem::load(spec, &studies::system::needs(&o, adaptive)).unwrap(), o).unwrap()
}

const ITERATING: [(Scheme, JacobianUpdate); 4] = [
    (Scheme::Ijcsa, JacobianUpdate::EveryStep),
    (Scheme::Ijcsa, JacobianUpdate::Reuse),
    (Scheme::IqnIls, JacobianUpdate::EveryStep),
    (Scheme::Iterative, JacobianUpdate::EveryStep),
];

/// A step undone and taken again with a Model Exchange unit: the FMUs' serialized states are
/// the bytes they were, the outputs too, and the step again gives the same bits as the first
/// time (the integrator's state — step size, states, indicators, next time event — restored
/// with the FMU's). Over the ball's first impacts (state events inside the steps), the loop
/// (IJCSA's differences through the unit) and the chain; FMI 2.0 and 3.0.
#[test]
fn a_step_undone_and_taken_again_gives_the_same_bits_with_model_exchange_units() {
    for version in [2, 3] {
        for (which, h) in [("ball", 0.05), ("loop", 0.1), ("chain", 0.1)] {
            let spec = common::me_system(which, version);
            for (scheme, jacobian) in ITERATING {
                let label = format!("{which}, FMI {version}, {} ({jacobian:?})", scheme.name());
                let o = Options { scheme, jacobian, tol: 1e-12, max_iter: 200, ..Options::default() };
                let mut c = coupled(&spec, o, false);
                for _ in 0..6 {
                    c.step(h).unwrap();
                }
                let events_before = c.units().model_exchange_stats()[0].2.state_events;
                for _ in 0..20 {
                    let (before, y) = (c.units_mut().serialized_states().unwrap(), c.outputs().to_vec());
                    c.step(h).unwrap();
                    let (first, after) = (c.outputs().to_vec(), c.units_mut().serialized_states().unwrap());
                    assert_ne!(after, before, "{label}: the step changed nothing");
                    c.undo_step().unwrap();
                    assert_eq!(c.units_mut().serialized_states().unwrap(), before, "{label}");
                    assert_eq!(c.outputs(), &y[..], "{label}");
                    c.step(h).unwrap();
                    assert_eq!(c.outputs(), &first[..], "{label}: the step again");
                    assert_eq!(c.units_mut().serialized_states().unwrap(), after, "{label}: the step again");
                }
                if which == "ball" {
                    // the impacts at 0.452 s and 1.084 s, inside steps undone and taken again:
                    // counted once each (a rollback takes its events back)
                    let events = c.units().model_exchange_stats()[0].2.state_events - events_before;
                    assert_eq!(events, 2, "{label}: state events from 0.3 s to 1.3 s");
                }
            }
        }
    }
}

/// An adaptive run with a Model Exchange unit whose steps were rejected is the same, bit for
/// bit, as a run that took the accepted steps directly: the rejected tries leave no trace in
/// the integrator either (the ball's impacts make the macro step shrink and grow).
#[test]
fn adaptive_rejections_leave_no_trace_in_a_model_exchange_unit() {
    for version in [2, 3] {
        let spec = common::me_system("ball", version);
        for scheme in [Scheme::IqnIls, Scheme::Ijcsa] {
            let o = Options { scheme, tol: 1e-12, max_iter: 200, ..Options::default() };
            let mut c = coupled(&spec, o, true);
            let limits = cosim::step_control::Limits { h_min: 1e-6, h_max: 0.1, h_init: 1e-3 };
            let mut ctl = cosim::step_control::Controller::new(limits).unwrap();
            let tol = cosim::step_control::Tolerances { rtol: 1e-4, atol: 1e-6 };
            let mut steps = Vec::new();
            while c.time() < 1.5 {
                steps.push(c.step_adaptive(&mut ctl, tol, 1.5).unwrap().h);
            }
            let label = format!("FMI {version}, {}", scheme.name());
            assert!(ctl.rejected > 0, "{label}: no step was rejected: the test shows nothing");
            let mut direct = coupled(&spec, o, true);
            for h in &steps {
                direct.step(*h).unwrap();
            }
            assert_eq!(direct.outputs(), c.outputs(), "{label}");
            assert_eq!(direct.units_mut().serialized_states().unwrap(), c.units_mut().serialized_states().unwrap());
        }
    }
}
