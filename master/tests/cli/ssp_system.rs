//! SSP 1.0 systems of FMUs that know nothing of this project's physics (the fmi test
//! oscillator): hand-written `.ssd`/`.ssv` files read, checked and run by the master.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use studies::cosim::{Coupled, FmuSystem, Needs, Options, Scheme, SetupError};

use crate::common;

/// The oscillator FMU, packaged once per test binary.
fn oscillator() -> &'static Path {
    static FMU: OnceLock<PathBuf> = OnceLock::new();
    FMU.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let deps = exe.parent().unwrap();
        let lib = [deps, deps.parent().unwrap()]
            .iter()
            .map(|d| d.join("libfmi_testmodel.so"))
            .find(|p| p.is_file())
            .expect("libfmi_testmodel.so: run `cargo build --release --workspace` first");
        let dir = std::env::temp_dir().join(format!("master-ssp-tests-{}", std::process::id()));
        fmi::package::package_model::<fmi_testmodel::Oscillator>(&dir, &lib).unwrap()
    })
}

/// Two oscillators pulling on each other: `a.F = KC · b.x`, `b.F = KC · a.x` (linear
/// transformations convert the position into a force); b's parameters from an `.ssv` file,
/// a's inline, of every type.
fn pair_ssd(dir: &Path, extra_connection: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::copy(oscillator(), dir.join("oscillator.fmu")).unwrap();
    std::fs::write(
        dir.join("b.ssv"),
        r#"<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="b">
  <ssv:Parameters>
    <ssv:Parameter name="x0"><ssv:Real value="-0.05"/></ssv:Parameter>
    <ssv:Parameter name="k"><ssv:Real value="60"/></ssv:Parameter>
  </ssv:Parameters>
</ssv:ParameterSet>
"#,
    )
    .unwrap();
    let a = common::parameter_bindings(
        "a",
        &[
            ("x0", "Real", "0.2".into()),
            ("substeps", "Integer", "3".into()),
            ("gravity", "Boolean", "false".into()),
            ("config", "String", "oscillator.txt".into()),
        ],
    );
    let elements = format!(
        r#"      <ssd:Component name="a" source="oscillator.fmu">
        <ssd:Connectors>
          <ssd:Connector name="F" kind="input"><ssc:Real unit="N"/></ssd:Connector>
          <ssd:Connector name="x" kind="output"><ssc:Real unit="m"/></ssd:Connector>
        </ssd:Connectors>
{a}
      </ssd:Component>
      <ssd:Component name="b" source="oscillator.fmu">
        <ssd:ParameterBindings>
          <ssd:ParameterBinding source="b.ssv"/>
        </ssd:ParameterBindings>
      </ssd:Component>"#
    );
    let connections = format!(
        r#"      <ssd:Connection startElement="b" startConnector="x" endElement="a" endConnector="F"><ssc:LinearTransformation factor="15" offset="0"/></ssd:Connection>
      <ssd:Connection startElement="a" startConnector="x" endElement="b" endConnector="F"><ssc:LinearTransformation factor="15"/></ssd:Connection>
      {extra_connection}"#
    );
    let ssd = common::ssd_text("pair", &elements, &connections, "2");
    let path = dir.join("pair.ssd");
    std::fs::write(&path, ssd).unwrap();
    path
}

fn test_dir(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("master-ssp-{tag}-{}", std::process::id()))
}

/// The master's Jacobi run of the SSP system is, bit for bit, a Jacobi loop written out here over
/// the FMI importer (parameters, transformations and connections applied by hand); the implicit
/// schemes reach one solution.
#[test]
fn ssp_pair_runs_like_a_hand_written_loop() {
    let ssd = pair_ssd(&test_dir("pair"), "");
    let loaded = studies::cosim::ssp::read::load(&ssd).unwrap();
    assert_eq!(loaded.stop_time, Some(2.0));
    let (h, steps) = (0.01, 200);
    let jacobi = Options { scheme: Scheme::Jacobi, ..Options::default() };
    let mut c = Coupled::new(FmuSystem::load(&loaded.spec, &Needs::default()).unwrap(), jacobi).unwrap();
    for _ in 0..steps {
        c.step(h).unwrap();
    }
    let master_x = |c: &mut Coupled<FmuSystem>, name: &str| {
        let inst = c.units_mut().instance(name).unwrap();
        let vr = inst.fmu().value_reference("x").unwrap();
        let mut x = [0.0];
        inst.get_real(&[vr], &mut x).unwrap();
        x[0]
    };
    let (xa, xb) = (master_x(&mut c, "a"), master_x(&mut c, "b"));

    // by hand
    let fmu = fmi::import::Fmu::load(oscillator()).unwrap();
    let vr = |n: &str| fmu.value_reference(n).unwrap();
    let mut a = fmu.instantiate("a", false).unwrap();
    let mut b = fmu.instantiate("b", false).unwrap();
    for i in [&mut a, &mut b] {
        i.setup_experiment(None, 0.0, None).unwrap();
    }
    a.set_real(&[vr("x0")], &[0.2]).unwrap();
    a.set_integer(&[vr("substeps")], &[3]).unwrap();
    a.set_boolean(&[vr("gravity")], &[false]).unwrap();
    a.set_string(&[vr("config")], &["oscillator.txt"]).unwrap();
    b.set_real(&[vr("x0"), vr("k")], &[-0.05, 60.0]).unwrap();
    for i in [&mut a, &mut b] {
        i.enter_initialization_mode().unwrap();
    }
    let x = |i: &mut fmi::import::Instance| {
        let mut v = [0.0];
        i.get_real(&[vr("x")], &mut v).unwrap();
        v[0]
    };
    // initialization: inputs from outputs (no feedthrough from F to x: one pass is consistent)
    let (x_a, x_b) = (x(&mut a), x(&mut b));
    a.set_real(&[vr("F")], &[15.0 * x_b]).unwrap();
    b.set_real(&[vr("F")], &[15.0 * x_a]).unwrap();
    for i in [&mut a, &mut b] {
        i.exit_initialization_mode().unwrap();
    }
    let mut t = 0.0;
    for _ in 0..steps {
        let (x_a, x_b) = (x(&mut a), x(&mut b));
        a.set_real(&[vr("F")], &[15.0 * x_b]).unwrap();
        b.set_real(&[vr("F")], &[15.0 * x_a]).unwrap();
        a.do_step(t, h).unwrap();
        b.do_step(t, h).unwrap();
        t += h;
    }
    assert_eq!((xa.to_bits(), xb.to_bits()), (x(&mut a).to_bits(), x(&mut b).to_bits()), "{xa} {xb}");

    // the implicit schemes converge to one solution
    let run = |scheme| {
        let o = Options { scheme, tol: 1e-12, ..Options::default() };
        let mut c = Coupled::new(
            FmuSystem::load(&loaded.spec, &Needs { what: "test".into(), rollback: true, ..Default::default() })
                .unwrap(),
            o,
        )
        .unwrap();
        for _ in 0..steps {
            c.step(h).unwrap();
        }
        (master_x(&mut c, "a"), master_x(&mut c, "b"))
    };
    let reference = run(Scheme::Ijcsa);
    for scheme in [Scheme::IqnIls, Scheme::Iterative] {
        let r = run(scheme);
        assert!((r.0 - reference.0).abs() < 1e-10 && (r.1 - reference.1).abs() < 1e-10, "{}: {r:?}", scheme.name());
    }
    // and the explicit one is a different (first-order) coupling of the same motion
    assert!((xa - reference.0).abs() > 1e-8 && (xa - reference.0).abs() < 1e-2);
}

/// A connection between different units without a transformation is refused, naming both ends
/// and the units; so is a connector whose declared unit is not the FMU's.
#[test]
fn unit_mismatches_are_refused() {
    let ssd = pair_ssd(&test_dir("units"), "");
    let text = std::fs::read_to_string(&ssd).unwrap();
    let broken = text.replace(r#"<ssc:LinearTransformation factor="15"/>"#, "");
    std::fs::write(&ssd, broken).unwrap();
    let loaded = studies::cosim::ssp::read::load(&ssd).unwrap();
    let e = FmuSystem::load(&loaded.spec, &Needs::default()).err().expect("refused").to_string();
    assert!(e.contains("`a.x` → `b.F`") && e.contains("`m` → `N`") && e.contains("LinearTransformation"), "{e}");

    let ssd = pair_ssd(&test_dir("units2"), "");
    let text = std::fs::read_to_string(&ssd).unwrap();
    std::fs::write(
        &ssd,
        text.replace(r#"kind="output"><ssc:Real unit="m"/>"#, r#"kind="output"><ssc:Real unit="mm"/>"#),
    )
    .unwrap();
    let loaded = studies::cosim::ssp::read::load(&ssd).unwrap();
    let e = FmuSystem::load(&loaded.spec, &Needs::default()).err().expect("refused").to_string();
    assert!(e.contains("connector `a.x`") && e.contains("`mm`") && e.contains("`m`"), "{e}");
}

/// A scheme that needs rollback is refused up front for an FMU that cannot get/set its state,
/// naming the component, the FMU and the attribute; Jacobi runs it.
#[test]
fn a_scheme_an_fmu_cannot_support_is_refused_up_front() {
    let dir = test_dir("caps");
    let ssd = pair_ssd(&dir, "");
    // an unpacked copy of the oscillator that declares no state access
    let unpacked = dir.join("stateless");
    let fmu = fmi::import::Fmu::load(oscillator()).unwrap();
    copy_dir(fmu.root(), &unpacked);
    let md = unpacked.join("modelDescription.xml");
    let text = std::fs::read_to_string(&md).unwrap();
    assert!(text.contains(r#"canGetAndSetFMUstate="true""#));
    std::fs::write(&md, text.replace(r#"canGetAndSetFMUstate="true""#, r#"canGetAndSetFMUstate="false""#)).unwrap();
    let text = std::fs::read_to_string(&ssd).unwrap();
    std::fs::write(&ssd, text.replace(r#"name="b" source="oscillator.fmu""#, r#"name="b" source="stateless""#))
        .unwrap();
    let loaded = studies::cosim::ssp::read::load(&ssd).unwrap();
    let needs = Needs { what: "scheme iqn-ils".into(), rollback: true, ..Default::default() };
    match FmuSystem::load(&loaded.spec, &needs) {
        Err(e @ SetupError::Capability { .. }) => {
            let m = e.to_string();
            assert!(m.contains("scheme iqn-ils") && m.contains("`b`") && m.contains("canGetAndSetFMUstate"), "{m}");
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("accepted"),
    }
    assert!(FmuSystem::load(&loaded.spec, &Needs::default()).is_ok());
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// `master run --system`: the CSV has `time` and every output of every component as
/// `<component>.<variable>`; the JSON says the run was not stopped early; the end time comes from
/// the description's DefaultExperiment.
#[test]
fn run_system_writes_every_output() {
    let dir = test_dir("cli");
    let ssd = pair_ssd(&dir, "");
    let csv = dir.join("out.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["run", "--system", ssd.to_str().unwrap(), "--scheme", "iqn-ils", "--dt", "0.01", "--json", "--out"])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["stopped_early"], false);
    assert_eq!(v["steps"], 200);
    assert_eq!(v["t_end"], 2.0);
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(header, "time,a.x,a.v,a.a,a.steps,b.x,b.v,b.a,b.steps");
    assert_eq!(text.lines().count(), 1 + 201);
    let last: Vec<&str> = text.lines().last().unwrap().split(',').collect();
    assert_eq!(last[4], "200", "the Integer output counts the steps");
    assert!(!dir.join("out.csv.part").exists());
    // a scheme that is not a coupling scheme is refused with the reason
    let out = Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["run", "--system", ssd.to_str().unwrap(), "--scheme", "monolithic", "--dt", "0.01"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("runs only the LT50m scene"));
}

/// The pair with `a` ending the run after 50 steps (fmi2Discard): the run ends there, at the last
/// communication point, with exit 0, a note, the JSON saying so, and the CSV up to that point.
#[test]
fn run_system_ends_early_when_a_component_says_so() {
    let dir = test_dir("discard");
    let ssd = pair_ssd(&dir, "");
    let text = std::fs::read_to_string(&ssd).unwrap();
    let ends = r#"<ssv:Parameter name="substeps"><ssv:Integer value="3"/></ssv:Parameter>
                  <ssv:Parameter name="max_steps"><ssv:Integer value="50"/></ssv:Parameter>"#;
    std::fs::write(
        &ssd,
        text.replace(r#"<ssv:Parameter name="substeps"><ssv:Integer value="3"/></ssv:Parameter>"#, ends),
    )
    .unwrap();
    let csv = dir.join("early.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["run", "--system", ssd.to_str().unwrap(), "--scheme", "jacobi", "--dt", "0.01", "--json", "--out"])
        .arg(&csv)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("note: the run ended early at t = 0.5 s") && err.contains("component `a`"), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((v["stopped_early"].as_bool(), v["stopped_at"].as_f64()), (Some(true), Some(0.5)), "{v}");
    assert!(v["note"].as_str().unwrap().contains("fmi2Discard"), "{v}");
    assert_eq!(v["steps"], 50);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().count(), 1 + 51);
    assert!(text.lines().last().unwrap().starts_with("0.5,"), "{}", text.lines().last().unwrap());
}

/// The outputs and the steps of a system run are checked before it starts (an input as output,
/// a plot that is not SVG, an end time that is no whole number of steps, --dt with --adaptive);
/// a run that fails removes an earlier result of the same name.
#[test]
fn run_system_checks_before_running_and_leaves_no_stale_output() {
    let dir = test_dir("misuse");
    let ssd = pair_ssd(&dir, "");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_master"))
            .args(["run", "--system", ssd.to_str().unwrap(), "--quiet"])
            .args(extra)
            .output()
            .unwrap()
    };
    let refused = |out: std::process::Output, needles: &[&str]| {
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert_eq!(out.status.code(), Some(1), "{err}");
        for n in needles {
            assert!(err.contains(n), "`{n}` missing: {err}");
        }
    };
    let ssd_text = std::fs::read(&ssd).unwrap();
    refused(run(&["--scheme", "jacobi", "--dt", "0.01", "--out", ssd.to_str().unwrap()]), &["input of the run"]);
    let fmu = dir.join("oscillator.fmu");
    refused(run(&["--scheme", "jacobi", "--dt", "0.01", "--out", fmu.to_str().unwrap()]), &["input of the run"]);
    assert_eq!(std::fs::read(&ssd).unwrap(), ssd_text);
    let png = dir.join("x.png");
    refused(run(&["--scheme", "jacobi", "--dt", "0.01", "--plot", png.to_str().unwrap()]), &["SVG"]);
    refused(run(&["--scheme", "jacobi", "--dt", "0.3"]), &["not a whole number of steps", "1.8 s or 2.1 s"]);
    refused(run(&["--scheme", "ijcsa", "--adaptive", "--dt", "0.01"]), &["--dt", "adaptive"]);
    refused(run(&["--scheme", "jacobi", "--adaptive"]), &["--adaptive", "jacobi"]);
    refused(run(&["--scheme", "jacobi"]), &["--dt"]);
    // a coupling a thousand times stiffer: Jacobi runs away, and the earlier CSV goes
    let csv = dir.join("r.csv");
    std::fs::write(&csv, "earlier").unwrap();
    let text = std::fs::read_to_string(&ssd).unwrap();
    std::fs::write(&ssd, text.replace(r#"factor="15""#, r#"factor="15000""#)).unwrap();
    let out = run(&["--scheme", "jacobi", "--dt", "0.01", "--out", csv.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    refused(out, &["stopped at t = ", "unstable", "removed"]);
    assert!(!csv.exists(), "{err}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

/// The pair with the adaptive step: it lands on the end time of the DefaultExperiment, its
/// response approaches a fine fixed step as the tolerance tightens, and the plot shows every
/// Real output, a panel per component. By default (the predictor, watching the coupled inputs)
/// not within rtol × range: each FMU holds its force input over the step, so the coupling
/// converges at first order — through the velocities, which no connection carries (docs/
/// coupling.md, "Coupled FMUs of first order"); the ends are 7.4e-3, 2.4e-3, 6.2e-4 of the
/// ranges off at rtol 1e-2, 1e-3, 1e-4. Step doubling watching the velocities too (outputs read
/// besides the connected ones) meets the tolerance.
#[test]
fn run_system_with_the_adaptive_step_and_a_plot() {
    let dir = test_dir("adaptive");
    let ssd = pair_ssd(&dir, "");
    let run = |csv: &Path, extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_master"))
            .args(["run", "--system", ssd.to_str().unwrap(), "--scheme", "ijcsa", "--json", "--out"])
            .arg(csv)
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v = serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap();
        let rows: Vec<Vec<f64>> = std::fs::read_to_string(csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        (v, rows)
    };
    let (_, fine) = run(&dir.join("fixed.csv"), &["--dt", "0.000125"]);
    // columns: time, a.x, a.v, a.a, a.steps, b.x, … (an adaptive run's with h_s after time): the
    // positions at the end against the fine run (itself 9e-5 of b.x's range from the limit of
    // the fixed steps)
    let end = fine.last().unwrap();
    let range = |col: usize| fine.iter().map(|r| (r[col] - fine[0][col]).abs()).fold(0.0, f64::max);
    let run_adaptive = |name: &str, rtol: &str, extra: &[&str]| {
        let svg = dir.join(format!("pair-{name}-{rtol}.svg"));
        let mut args = vec!["--adaptive", "--rtol", rtol, "--plot", svg.to_str().unwrap()];
        args.extend_from_slice(extra);
        let (v, rows) = run(&dir.join(format!("adaptive-{name}-{rtol}.csv")), &args);
        assert_eq!((v["adaptive"].as_bool(), v["t_end"].as_f64()), (Some(true), Some(2.0)));
        assert!(v["dt"].is_null());
        assert_eq!(rows.len() as u64, v["steps"].as_u64().unwrap() + 1);
        assert_eq!(rows.last().unwrap()[0], 2.0, "the last step lands on the end time");
        for w in rows.windows(2) {
            assert!((w[1][0] - w[0][0] - w[1][1]).abs() <= 1e-12, "h_s is the step that ended at t: {w:?}");
        }
        assert_eq!(rows[0][1], 0.0);
        let error =
            [1, 5].iter().map(|&col| (rows.last().unwrap()[col + 1] - end[col]).abs() / range(col)).fold(0.0, f64::max);
        eprintln!("{name}, rtol {rtol}: {} steps, end positions off by {error:.2e} of their ranges", rows.len() - 1);
        let text = std::fs::read_to_string(&svg).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        let labels: Vec<&str> =
            doc.descendants().filter(|n| n.is_text()).filter_map(|n| n.text()).map(str::trim).collect();
        for label in ["a", "b", "a.x", "a.v", "a.a", "b.x", "b.v", "b.a", "time (s)"] {
            assert!(labels.contains(&label), "{label} missing from the plot: {labels:?}");
        }
        error
    };
    let errors: Vec<f64> = ["1e-2", "1e-3", "1e-4"].iter().map(|rtol| run_adaptive("predictor", rtol, &[])).collect();
    // every tenfold tighter tolerance at least halves the error
    assert!(errors[1] < errors[0] / 2.0 && errors[2] < errors[1] / 2.0, "{errors:?}");
    let states = ["--estimate", "doubling", "--watch", "a.F,b.F,a.v,b.v"];
    for (rtol, text) in [(1e-2, "1e-2"), (1e-3, "1e-3")] {
        let error = run_adaptive("doubling", text, &states);
        assert!(error <= rtol, "doubling, watching the velocities: {error:.2e} of the ranges at rtol {rtol}");
    }
}

/// `run --system` reads a system's FMUs from its own folder: an `.ssd` naming one outside it is
/// refused, naming the source and the option that allows it; with the option it runs. The option
/// belongs to --system.
#[test]
fn run_system_loads_fmus_from_outside_only_when_allowed() {
    let dir = test_dir("outside");
    let ssd = pair_ssd(&dir, "");
    let inner = dir.join("inner");
    std::fs::create_dir_all(&inner).unwrap();
    std::fs::copy(dir.join("b.ssv"), inner.join("b.ssv")).unwrap();
    let moved = inner.join("pair.ssd");
    let text =
        std::fs::read_to_string(&ssd).unwrap().replace(r#"source="oscillator.fmu""#, r#"source="../oscillator.fmu""#);
    std::fs::write(&moved, text).unwrap();
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_master"))
            .args(["run", "--system", moved.to_str().unwrap(), "--scheme", "jacobi", "--dt", "0.01", "--quiet"])
            .args(extra)
            .output()
            .unwrap()
    };
    let refused = run(&[]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(err.contains("pair.ssd") && err.contains("`../oscillator.fmu` lies outside the system's folder"), "{err}");
    assert!(err.contains("--allow-external-fmus"), "{err}");
    let allowed = run(&["--allow-external-fmus"]);
    assert!(allowed.status.success(), "{}", String::from_utf8_lossy(&allowed.stderr));

    let scene = Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["run", "--scene", "../scenes/lt50m_C.toml", "--scheme", "ijcsa", "--allow-external-fmus"])
        .output()
        .unwrap();
    assert!(!scene.status.success());
    assert!(String::from_utf8_lossy(&scene.stderr).contains("--system"), "{}", String::from_utf8_lossy(&scene.stderr));
}
