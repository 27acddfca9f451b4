//! The whole layer end to end: package the oscillator, import the archive with the fmi
//! importer, and run it through the C ABI.

use fmi::export::Model;
use fmi::ffi::{Status, fmi2Error};
use fmi::import::{Capability, Error, Fmu, Instance};
use fmi_testmodel::{Oscillator, vr};

mod common;

use common::{fmu, ready};

const OUTPUTS: [u32; 3] = [vr::X, vr::V, vr::A];

fn outputs(i: &mut Instance) -> [f64; 3] {
    let mut y = [0.0; 3];
    i.get_real(&OUTPUTS, &mut y).unwrap();
    y
}

fn force(t: f64) -> f64 {
    3.0 * (2.0 * t).sin() + 0.5
}

/// `n` steps of size `h` from `t0` with the force input; outputs after each step.
fn run(i: &mut Instance, t0: f64, h: f64, n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|k| {
            let t = t0 + k as f64 * h;
            i.set_real(&[vr::F], &[force(t)]).unwrap();
            i.do_step(t, h).unwrap();
            outputs(i)
        })
        .collect()
}

fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
    v.iter().map(|y| y.map(f64::to_bits)).collect()
}

#[test]
fn archive_layout_and_description() {
    let f = fmu();
    let root = f.root();
    assert!(root.join("modelDescription.xml").is_file());
    assert!(root.join("binaries/linux64/oscillator.so").is_file());
    assert!(root.join("resources/oscillator.txt").is_file());
    let d = f.description();
    assert_eq!(d.model_identifier, "oscillator");
    assert_eq!(d.guid, Oscillator::description().unwrap().guid);
    assert_eq!(d.variables.len(), 13);
    for cap in [
        Capability::VariableStepSize,
        Capability::InterpolateInputs,
        Capability::GetSetState,
        Capability::SerializeState,
        Capability::DirectionalDerivative,
        Capability::StepMapDerivative,
    ] {
        f.require(cap).unwrap();
    }
    let e = f.require(Capability::OutputDerivatives).unwrap_err();
    assert_eq!(e.to_string(), "FMU `oscillator` does not declare maxOutputDerivativeOrder ≥ 1 in modelDescription.xml");
    // Outputs with their direct dependencies: only `a` depends on `F` (index 1).
    assert_eq!(d.variable("a").unwrap().depends_on, Some(vec!["F".to_owned()]));
    assert_eq!(f.value_reference("v").unwrap(), vr::V);
    assert!(f.value_reference("w").unwrap_err().to_string().contains("no variable named `w`"));
}

#[test]
fn the_fmu_reproduces_the_library_bit_for_bit() {
    let f = fmu();
    let mut i = ready(&f, "osc");
    let through_fmu = run(&mut i, 0.0, 0.01, 300);
    let dir = f.root().join("resources");
    let mut m = Oscillator::instantiate(Some(&dir)).unwrap();
    m.exit_initialization(0.0).unwrap();
    let in_process: Vec<[f64; 3]> = (0..300)
        .map(|k| {
            let t = k as f64 * 0.01;
            m.set_real(vr::F, force(t)).unwrap();
            m.do_step(t, 0.01).unwrap();
            OUTPUTS.map(|r| m.get_real(r).unwrap())
        })
        .collect();
    assert_eq!(bits(&through_fmu), bits(&in_process));
    let mut steps = [0];
    i.get_integer(&[vr::STEPS], &mut steps).unwrap();
    assert_eq!(steps[0], 300);
    assert_eq!(i.get_string(&[vr::CONFIG]).unwrap(), ["oscillator.txt"]);
    i.terminate().unwrap();
}

#[test]
fn parameters_of_every_type() {
    let f = fmu();
    let mut i = f.instantiate("p", false).unwrap();
    i.set_integer(&[vr::SUBSTEPS], &[4]).unwrap();
    i.set_boolean(&[vr::GRAVITY], &[true]).unwrap();
    i.set_real(&[vr::X0, vr::K], &[0.0, 50.0]).unwrap();
    let abs = f.root().join("resources/oscillator.txt");
    i.set_string(&[vr::CONFIG], &[abs.to_str().unwrap()]).unwrap();
    i.enter_initialization_mode().unwrap();
    // Calculated output in initialization mode, from the current parameters: a = −g.
    assert_eq!(outputs(&mut i)[2], -fmi_testmodel::G);
    i.exit_initialization_mode().unwrap();
    let mut b = [false];
    i.get_boolean(&[vr::GRAVITY], &mut b).unwrap();
    assert!(b[0]);
    i.do_step(0.0, 0.1).unwrap();
    assert!(outputs(&mut i)[0] < 0.0, "falls under gravity");
}

#[test]
fn rollback_reproduces_every_output_bit_for_bit() {
    let f = fmu();
    let mut i = ready(&f, "rb");
    run(&mut i, 0.0, 0.01, 17);
    let s = i.get_state().unwrap();
    let first = run(&mut i, 0.17, 0.01, 50);
    i.set_state(&s).unwrap();
    let again = run(&mut i, 0.17, 0.01, 50);
    assert_eq!(bits(&first), bits(&again));
    // Reusing the saved state in place, many times over.
    for _ in 0..3 {
        i.update_state(&s).unwrap();
        let a = run(&mut i, 0.67, 0.01, 5);
        i.set_state(&s).unwrap();
        assert_eq!(bits(&a), bits(&run(&mut i, 0.67, 0.01, 5)));
        i.set_state(&s).unwrap();
    }
    i.free_state(s).unwrap();
}

#[test]
fn serialized_state_round_trips_into_another_instance() {
    let f = fmu();
    let mut a = ready(&f, "a");
    run(&mut a, 0.0, 0.01, 40);
    let s = a.get_state().unwrap();
    let bytes = a.serialize_state(&s).unwrap();
    let mut b = f.instantiate("b", false).unwrap();
    let sb = b.deserialize_state(&bytes).unwrap();
    b.set_state(&sb).unwrap();
    assert_eq!(b.serialize_state(&sb).unwrap(), bytes);
    assert_eq!(bits(&run(&mut a, 0.4, 0.01, 30)), bits(&run(&mut b, 0.4, 0.01, 30)));
    // A state from another instance cannot be used through this API.
    assert!(matches!(a.set_state(&sb), Err(Error::Usage(_))));
    // Damaged bytes: a clear error, no crash.
    let e = b.deserialize_state(&bytes[..bytes.len() / 2]).unwrap_err();
    assert_eq!(e.status(), Some(Status::Error));
    assert!(e.to_string().contains("not a state of this FMU"), "{e}");
}

/// The standard derivative at a communication point: fmi2GetReal after fmi2SetReal, no step.
/// Only the acceleration responds to the force (as `<Outputs>` declares), through 1/m.
#[test]
fn directional_derivatives_are_those_of_the_current_instant() {
    let f = fmu();
    let mut i = ready(&f, "instant");
    run(&mut i, 0.0, 0.01, 25);
    let u = force(0.25);
    let at = |i: &mut Instance, du: f64| {
        i.set_real(&[vr::F], &[u + du]).unwrap();
        outputs(i)
    };
    let d = 1e-3;
    let (p, m) = (at(&mut i, d), at(&mut i, -d));
    at(&mut i, 0.0);
    let mut jac = [0.0; 3];
    i.directional_derivative(&OUTPUTS, &[vr::F], &[1.0], &mut jac).unwrap();
    for k in 0..3 {
        let fd = (p[k] - m[k]) / (2.0 * d);
        assert!((fd - jac[k]).abs() <= 1e-9 * jac[k].abs().max(1.0), "output {k}: fd {fd}, exact {}", jac[k]);
    }
    assert_eq!((jac[0], jac[1]), (0.0, 0.0));
    assert!((jac[2] - 0.5).abs() < 1e-15, "1/m with m = 2 kg: {}", jac[2]);
    // The declared structure says the same.
    let deps = ["x", "v", "a"].map(|n| f.description().variable(n).unwrap().depends_on.clone().unwrap());
    assert_eq!(deps, [vec![], vec![], vec!["F".to_owned()]]);
}

/// A model that ends: fmi2Discard, fmi2Terminated true, fmi2LastSuccessfulTime at the end.
#[test]
fn a_model_that_ends_is_reported_through_the_importer() {
    let f = fmu();
    let mut i = f.instantiate("end", false).unwrap();
    i.setup_experiment(None, 0.0, None).unwrap();
    i.enter_initialization_mode().unwrap();
    i.set_integer(&[vr::MAX_STEPS], &[3]).unwrap();
    i.exit_initialization_mode().unwrap();
    run(&mut i, 0.0, 0.01, 3);
    let e = i.do_step(0.03, 0.01).unwrap_err();
    assert_eq!(e.status(), Some(Status::Discard), "{e}");
    assert!(e.to_string().contains("max_steps = 3 reached"), "{e}");
    assert!(i.terminated().unwrap());
    assert!((i.last_successful_time().unwrap() - 0.03).abs() < 1e-15);
    let mut steps = [0];
    i.get_integer(&[vr::STEPS], &mut steps).unwrap();
    assert_eq!(steps, [3]);
    i.terminate().unwrap();
}

#[test]
fn step_map_derivatives_match_central_differences_with_rollback() {
    let f = fmu();
    let mut i = ready(&f, "dd");
    i.set_integer(&[], &[]).unwrap();
    run(&mut i, 0.0, 0.01, 25);
    let t = 0.25;
    let s = i.get_state().unwrap();
    let u = force(t);
    let at = |i: &mut Instance, du: f64| {
        i.set_state(&s).unwrap();
        i.set_real(&[vr::F], &[u + du]).unwrap();
        i.do_step(t, 0.01).unwrap();
        outputs(i)
    };
    let d = 1e-4;
    let (p, m) = (at(&mut i, d), at(&mut i, -d));
    at(&mut i, 0.0);
    let mut jac = [0.0; 3];
    assert!(f.description().flags.provides_step_map_derivative);
    i.step_map_derivative(&OUTPUTS, &[vr::F], &[1.0], &mut jac).unwrap();
    for k in 0..3 {
        let fd = (p[k] - m[k]) / (2.0 * d);
        // The step map is linear in F: central differences are exact up to rounding.
        assert!((fd - jac[k]).abs() <= 1e-8 * jac[k].abs().max(1e-6), "output {k}: fd {fd}, exact {}", jac[k]);
    }
    assert!(jac[0] > 0.0 && jac[2] > 0.0);
    // Parameters among the knowns: zero seeds are fine, a non-zero seed is refused clearly.
    i.step_map_derivative(&[vr::X], &[vr::F, vr::K], &[1.0, 0.0], &mut jac[..1]).unwrap();
    let e = i.step_map_derivative(&[vr::X], &[vr::K], &[1.0], &mut jac[..1]).unwrap_err();
    assert!(e.to_string().contains("derivatives with respect to value reference 4 are not provided"), "{e}");
}

/// Independent reference: the trapezoidal rule in matrix form, `y⁺ = (I − h/2 A)⁻¹ [(I + h/2 A) y
/// + h/2 b (f⁻ + f⁺)]` with `A = [[0, 1], [−k/m, −c/m]]`, `b = [0, 1/m]`; returns x after each step.
fn trapezoid(m: f64, k: f64, c: f64, y0: [f64; 2], h: f64, forces: &[(f64, f64)]) -> Vec<f64> {
    let a = [[0.0, 1.0], [-k / m, -c / m]];
    let l = [[1.0 - 0.5 * h * a[0][0], -0.5 * h * a[0][1]], [-0.5 * h * a[1][0], 1.0 - 0.5 * h * a[1][1]]];
    let det = l[0][0] * l[1][1] - l[0][1] * l[1][0];
    let inv = [[l[1][1] / det, -l[0][1] / det], [-l[1][0] / det, l[0][0] / det]];
    let mut y = y0;
    forces
        .iter()
        .map(|&(fa, fb)| {
            let r = [
                y[0] + 0.5 * h * (a[0][0] * y[0] + a[0][1] * y[1]),
                y[1] + 0.5 * h * (a[1][0] * y[0] + a[1][1] * y[1]) + 0.5 * h * (fa + fb) / m,
            ];
            y = [inv[0][0] * r[0] + inv[0][1] * r[1], inv[1][0] * r[0] + inv[1][1] * r[1]];
            y[0]
        })
        .collect()
}

#[test]
fn input_held_or_interpolated_matches_the_trapezoidal_recurrence() {
    let f = fmu();
    let (h, r, n) = (0.01, 2.0, 300);
    let ramp = |k: usize| r * k as f64 * h;
    for interpolate in [false, true] {
        let mut i = ready(&f, "ramp");
        let mut xs = Vec::new();
        for k in 0..n {
            i.set_real(&[vr::F], &[ramp(k)]).unwrap();
            if interpolate {
                i.set_real_input_derivatives(&[vr::F], &[1], &[r]).unwrap();
            }
            i.do_step(k as f64 * h, h).unwrap();
            xs.push(outputs(&mut i)[0]);
        }
        let forces: Vec<(f64, f64)> =
            (0..n).map(|k| (ramp(k), if interpolate { ramp(k + 1) } else { ramp(k) })).collect();
        let reference = trapezoid(2.0, 40.0, 0.8, [0.1, 0.0], h, &forces);
        for (k, (x, x_ref)) in xs.iter().zip(&reference).enumerate() {
            assert!((x - x_ref).abs() <= 1e-12 * x_ref.abs().max(0.1), "step {k}: {x} vs {x_ref} ({interpolate})");
        }
    }
    let mut i = ready(&f, "order");
    let e = i.set_real_input_derivatives(&[vr::F], &[2], &[0.0]).unwrap_err();
    assert!(e.to_string().contains("order 2 for `F` (input, continuous): only first-order"), "{e}");
}

#[test]
fn misuse_gives_errors_that_name_the_problem() {
    let f = fmu();
    let mut i = f.instantiate("misuse", false).unwrap();
    let e = i.do_step(0.0, 0.01).unwrap_err();
    assert_eq!(e.status(), Some(Status::Error));
    let text = e.to_string();
    assert!(text.starts_with("FMU `oscillator` (instance `misuse`): fmi2DoStep returned fmi2Error"), "{text}");
    assert!(text.contains("fmi2DoStep: not allowed in state `instantiated`"), "{text}");

    let mut i = ready(&f, "unknown");
    let e = i.set_real(&[42], &[1.0]).unwrap_err();
    assert!(e.to_string().contains("unknown value reference 42 (no Real variable has it)"), "{e}");
    let mut i = ready(&f, "nan");
    let e = i.set_real(&[vr::F], &[f64::NAN]).unwrap_err();
    assert!(e.to_string().contains("`F` (input, continuous) = NaN: not a finite number"), "{e}");
    let mut i = ready(&f, "fixed");
    let e = i.set_real(&[vr::X0], &[1.0]).unwrap_err();
    assert!(e.to_string().contains("`x0` (parameter, fixed) cannot be set in state `step mode`"), "{e}");
    let mut i = f.instantiate("config", false).unwrap();
    let e = i.set_string(&[vr::CONFIG], &["100% missing.txt"]).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("No such file") && text.contains("resources/100% missing.txt"), "{text}");
    // After an error the instance stays unusable until reset.
    assert!(i.enter_initialization_mode().is_err());
    i.reset().unwrap();
    i.enter_initialization_mode().unwrap();
    let mut i = ready(&f, "time");
    let e = i.do_step(1.0, 0.01).unwrap_err();
    assert!(e.to_string().contains("currentCommunicationPoint = 1 but the instance is at t = 0"), "{e}");
    let mut i = ready(&f, "len");
    assert!(matches!(i.set_real(&[vr::F], &[]), Err(Error::Usage(_))));
    let mut out = [0.0];
    let e = i.get_real_output_derivatives(&[vr::X], &[1], &mut out).unwrap_err();
    assert!(matches!(e, Error::Capability { .. }));
}

#[test]
fn communication_points_from_fmpy_style_clocks() {
    let f = fmu();
    let mut i = ready(&f, "clock");
    let h = 0.01;
    let mut t = 0.0;
    for n in 0..500 {
        let next = (n + 1) as f64 * h; // fmpy: next point = start + (n+1) h, step = next − time
        i.do_step(t, next - t).unwrap();
        t = next;
    }
    assert_eq!(i.last_successful_time().unwrap(), t);
}

#[test]
fn instances_step_independently_on_threads() {
    let f = fmu();
    let serial = run(&mut ready(&f, "serial"), 0.0, 0.01, 200);
    let handles: Vec<_> = (0..4)
        .map(|k| {
            let mut i = ready(&f, &format!("thread{k}"));
            std::thread::spawn(move || run(&mut i, 0.0, 0.01, 200))
        })
        .collect();
    for h in handles {
        assert_eq!(bits(&h.join().unwrap()), bits(&serial));
    }
}

#[test]
fn malformed_archives_are_clear_errors() {
    let dir = std::env::temp_dir().join(format!("fmi2-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let not_zip = dir.join("not_zip.fmu");
    std::fs::write(&not_zip, b"hello").unwrap();
    let e = Fmu::load(&not_zip).unwrap_err();
    assert!(e.to_string().starts_with(&format!("{}: not a valid zip archive", not_zip.display())), "{e}");
    let e = Fmu::load(&dir.join("absent.fmu")).unwrap_err();
    assert!(e.to_string().contains("absent.fmu: cannot open"), "{e}");
    // A zip without a binary, and one with a broken description.
    let d = Oscillator::description().unwrap();
    let no_lib = dir.join("no_lib.fmu");
    let missing = dir.join("missing.so");
    let e = fmi::package::write_fmu(&no_lib, &d, &missing, &[]).unwrap_err();
    assert!(e.to_string().contains("missing.so"), "{e}");
    let unpacked = dir.join("unpacked");
    std::fs::create_dir_all(unpacked.join("binaries/linux64")).unwrap();
    std::fs::write(unpacked.join("modelDescription.xml"), "<fmiModelDescription fmiVersion=\"2.0\"").unwrap();
    let e = Fmu::load_unpacked(&unpacked).unwrap_err();
    assert!(e.to_string().contains("modelDescription.xml: modelDescription.xml: not well-formed XML"), "{e}");
    std::fs::write(unpacked.join("modelDescription.xml"), fmi::xml::model_description_xml(&d).unwrap()).unwrap();
    let e = Fmu::load_unpacked(&unpacked).unwrap_err();
    assert!(e.to_string().contains("oscillator.so: missing: no linux64 binary"), "{e}");
    std::fs::write(unpacked.join("binaries/linux64/oscillator.so"), b"not an ELF").unwrap();
    let e = Fmu::load_unpacked(&unpacked).unwrap_err();
    assert!(e.to_string().contains("cannot load the binary"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_wrong_guid_is_refused_at_instantiation() {
    let f = fmu();
    let dir = std::env::temp_dir().join(format!("fmi2-guid-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("binaries/linux64")).unwrap();
    std::fs::copy(f.root().join("binaries/linux64/oscillator.so"), dir.join("binaries/linux64/oscillator.so")).unwrap();
    let mut d = Oscillator::description().unwrap();
    d.guid = "{another-build}".into();
    std::fs::write(dir.join("modelDescription.xml"), fmi::xml::model_description_xml(&d).unwrap()).unwrap();
    let g = Fmu::load_unpacked(&dir).unwrap();
    let e = g.instantiate("g", false).unwrap_err();
    assert!(matches!(e, Error::Call { status, .. } if status == fmi2Error));
    assert!(e.to_string().contains("fmuGUID `{another-build}` does not match"), "{e}");
    drop(g);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A copy of the packaged FMU with `extra` entries added.
fn with_entries(tag: &str, extra: &[(&str, &[u8])]) -> std::path::PathBuf {
    let mut src = zip::ZipArchive::new(std::fs::File::open(common::archive()).unwrap()).unwrap();
    let path = std::env::temp_dir().join(format!("fmi2-entries-{tag}-{}.fmu", std::process::id()));
    let mut out = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    for i in 0..src.len() {
        out.raw_copy_file(src.by_index(i).unwrap()).unwrap();
    }
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (name, bytes) in extra {
        out.start_file(*name, deflated).unwrap();
        std::io::Write::write_all(&mut out, bytes).unwrap();
    }
    out.finish().unwrap();
    path
}

/// Loading an FMU unpacks what an importer uses — the description, this platform's binary,
/// resources/ — and leaves documentation, sources and other platforms' binaries packed (an
/// archive of a few megabytes may hold gigabytes of zeros); an archive listing a name twice is
/// refused.
#[test]
fn loading_unpacks_only_what_the_importer_uses() {
    let zeros = vec![0u8; 64 << 20];
    let extra: [(&str, &[u8]); 3] =
        [("documentation/zeros.bin", &zeros), ("binaries/win64/oscillator.dll", b"MZ"), ("sources/model.c", b"int x;")];
    let path = with_entries("extra", &extra);
    assert!(std::fs::metadata(&path).unwrap().len() < (8 << 20), "the zeros deflate to little");
    let fmu = Fmu::load(&path).unwrap();
    let root = fmu.root();
    assert!(root.join("modelDescription.xml").is_file());
    assert!(root.join("binaries/linux64/oscillator.so").is_file());
    assert!(root.join("resources").is_dir());
    for left in ["documentation", "sources", "binaries/win64"] {
        assert!(!root.join(left).exists(), "{left} stays packed");
    }
    let mut i = ready(&fmu, "unpacked");
    i.do_step(0.0, 0.01).unwrap();

    // two entries of one name: write another, then give both one name in the bytes
    let twice = with_entries("twice", &[("modelDescription.xmX", b"<x/>")]);
    let mut bytes = std::fs::read(&twice).unwrap();
    let (from, to) = (b"modelDescription.xmX", b"modelDescription.xml");
    let mut k = 0;
    while let Some(at) = bytes[k..].windows(from.len()).position(|w| w == from) {
        bytes[k + at..k + at + to.len()].copy_from_slice(to);
        k += at + to.len();
    }
    std::fs::write(&twice, bytes).unwrap();
    let e = Fmu::load(&twice).unwrap_err().to_string();
    assert!(e.contains("lists an entry name twice"), "{e}");
    std::fs::remove_file(&path).unwrap();
    std::fs::remove_file(&twice).unwrap();
}
