//! The FMU adapter (called in-process through the `fmi::Model` trait) against the library.

use cable::model::{CableCabin, Payload};
use cable_fmu::{CableFmu, vr};
use fmi::ModelInfo;
use fmi::export::Model;
use nalgebra::Vector6;

fn load_scene(name: &str) -> feedcore::scene::ValidScene {
    feedcore::scene::Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn ready(scene: Option<&str>) -> CableFmu {
    let mut m = CableFmu::instantiate(None).unwrap();
    if let Some(s) = scene {
        m.set_string(vr::SCENE, s).unwrap();
    }
    m.exit_initialization(0.0).unwrap();
    m
}

fn outputs(m: &mut CableFmu) -> Vec<f64> {
    (vr::POSITION..vr::DAMPING_RATIO).map(|v| m.get_real(v).unwrap()).collect()
}

fn wrench_at(t: f64, base: &Vector6<f64>) -> Vector6<f64> {
    base + Vector6::new(30.0 * (0.8 * t).sin(), -20.0 * (0.5 * t).cos(), 10.0 * t, 5.0, -8.0 * (1.1 * t).sin(), 2.0)
}

/// The description passes packaging's checks — the exporter's validation, and the
/// modelDescription.xml it writes reads back through the importer's parser as the description
/// — and every input declares a range that holds its start value.
#[test]
fn the_description_is_valid_and_reads_back_as_written() {
    let xml = fmi::package::checked_xml(&CableFmu::description().unwrap()).unwrap();
    let back = fmi::xml::parse_model_description(&xml).unwrap();
    for v in back.variables.iter().filter(|v| v.causality == fmi::Causality::Input) {
        let Some(fmi::Value::Real(start)) = v.start else { panic!("{}: start {:?}", v.name, v.start) };
        assert!(v.min.is_some() && v.max.is_some() && v.outside_range(start).is_none(), "{}", v.name);
    }
}

#[test]
fn alone_with_inputs_at_their_start_values_it_stays_at_rest() {
    for scene in ["lt50m_C.toml", "lt50m_B.toml"] {
        let mut m = ready(Some(scene));
        let p0 = outputs(&mut m);
        let mut drift = 0.0f64;
        for k in 0..2000 {
            m.do_step(0.01 * k as f64, 0.01).unwrap();
            let p = outputs(&mut m);
            drift = drift.max((0..3).map(|i| (p[i] - p0[i]).abs()).fold(0.0, f64::max));
        }
        eprintln!("{scene}: drift over 20 s {drift:.2e} m");
        assert!(drift <= 1e-9, "{scene}: {drift:e}");
    }
}

#[test]
fn the_fmu_reproduces_the_library_bit_for_bit() {
    let s = load_scene("lt50m_B.toml");
    let model = CableCabin::from_scene(&s).unwrap();
    let w0 = model.static_payload_wrench();
    let mut lib = model.dynamics(Payload::External, 0.0).unwrap();
    let mut m = CableFmu::instantiate(None).unwrap();
    m.set_string(vr::SCENE, "lt50m_B.toml").unwrap();
    // The importer gives the platform's static wrench at B (the declared start values are C's).
    for k in 0..6 {
        m.set_real(vr::WRENCH + k as u32, w0[k]).unwrap();
    }
    m.exit_initialization(0.0).unwrap();
    for k in 0..300 {
        let t = 0.01 * k as f64;
        let w = wrench_at(t, &w0);
        for i in 0..6 {
            m.set_real(vr::WRENCH + i as u32, w[i]).unwrap();
        }
        m.do_step(t, 0.01).unwrap();
        lib.step(0.01, &w).unwrap();
        let c = lib.cabin();
        assert_eq!(m.get_real(vr::POSITION).unwrap().to_bits(), c.position.x.to_bits());
        assert_eq!(m.get_real(vr::ANGULAR_ACCELERATION + 2).unwrap().to_bits(), c.angular_acceleration.z.to_bits());
    }
}

#[test]
fn step_map_derivatives_match_finite_differences_with_rollback() {
    // a tight Newton tolerance, so that the differences measure the model, not the solver
    let mut m = CableFmu::instantiate(None).unwrap();
    m.set_real(vr::NEWTON_TOL, 1e-13).unwrap();
    m.exit_initialization(0.0).unwrap();
    let w0: Vec<f64> = (0..6).map(|k| m.get_real(vr::WRENCH + k).unwrap()).collect();
    for k in 0..40 {
        let w = wrench_at(0.01 * k as f64, &Vector6::from_column_slice(&w0));
        for i in 0..6 {
            m.set_real(vr::WRENCH + i as u32, w[i]).unwrap();
        }
        m.do_step(0.01 * k as f64, 0.01).unwrap();
    }
    let mut saved = Vec::new();
    m.save_state(&mut saved).unwrap();
    let t = 0.4;
    let unknowns: Vec<u32> = (vr::POSITION..vr::DAMPING_RATIO).collect();
    let knowns: Vec<u32> = (0..6).collect();
    let base: Vec<f64> = (0..6).map(|k| m.get_real(vr::WRENCH + k).unwrap()).collect();
    let step_with = |m: &mut CableFmu, w: &[f64]| {
        m.restore_state(&saved).unwrap();
        for (i, x) in w.iter().enumerate() {
            m.set_real(vr::WRENCH + i as u32, *x).unwrap();
        }
        m.do_step(t, 0.01).unwrap();
        outputs(m)
    };
    for k in 0..6 {
        step_with(&mut m, &base);
        let mut seed = vec![0.0; 6];
        seed[k] = 1.0;
        let mut analytic = vec![0.0; unknowns.len()];
        m.step_map_derivative(&unknowns, &knowns, &seed, &mut analytic).unwrap();
        let eps = if k < 3 { 20.0 } else { 10.0 };
        let mut wp = base.clone();
        wp[k] += eps;
        let mut wm = base.clone();
        wm[k] -= eps;
        let (p, q) = (step_with(&mut m, &wp), step_with(&mut m, &wm));
        for (i, a) in analytic.iter().enumerate() {
            let fd = (p[i] - q[i]) / (2.0 * eps);
            // The differences cannot resolve less than the outputs' round-off: tensions come
            // from ~30 m world coordinates through EA/l0 ≈ 6e6 N/m, ~1e-11 of their value.
            let floor = 1e-11 * p[i].abs().max(q[i].abs()) / eps;
            assert!(
                (a - fd).abs() <= 1e-6 * a.abs().max(fd.abs()).max(1e-12) + 1e-13 + floor,
                "input {k}, output {i}: {a:e} vs {fd:e}"
            );
        }
    }
}

#[test]
fn a_missing_scene_is_refused_by_name() {
    let mut m = CableFmu::instantiate(None).unwrap();
    let e = m.set_string(vr::SCENE, "/no/such/scene.toml").unwrap_err();
    assert!(e.to_string().contains("/no/such/scene.toml"), "{e}");
    let e = m.set_integer(vr::ELEMENTS, -3).unwrap_err().to_string();
    assert!(e.contains("elements_per_cable") && e.contains("-3"), "{e}");
}

#[test]
fn elements_per_cable_overrides_the_scene() {
    let mut m = CableFmu::instantiate(None).unwrap();
    m.set_integer(vr::ELEMENTS, 30).unwrap();
    m.exit_initialization(0.0).unwrap();
    // the static equilibrium with 30 elements: still at rest, tensions from the finer net
    let t30 = m.get_real(vr::TENSION_CABIN).unwrap();
    let t20 = ready(None).get_real(vr::TENSION_CABIN).unwrap();
    assert!(t30 != t20 && (t30 - t20).abs() < 0.01 * t20, "{t30} vs {t20}");
}

/// FMI 2.0 semantics, checked pair by pair: at a communication point, the directional derivative
/// of every output with respect to every input equals central differences of fmi2GetReal after
/// fmi2SetReal (no step); an undeclared pair does not move at all; a declared one does — in
/// initialization mode (`<InitialUnknowns>`) and in step mode (`<Outputs>`), at B and C.
#[test]
fn derivatives_and_dependencies_follow_the_standard_at_b_and_c() {
    let info = ModelInfo::new(CableFmu::description().unwrap()).unwrap();
    let inputs: Vec<u32> = (vr::WRENCH..vr::POSITION).collect();
    let outputs: Vec<u32> = (vr::POSITION..vr::DAMPING_RATIO).collect();
    let index_of = |vr: u32| info.lookup(fmi::VarType::Real, vr).unwrap().index;
    let declared = |o: u32, i: u32, initial: bool| {
        let v = info.lookup(fmi::VarType::Real, o).unwrap();
        let deps = if initial { &v.initial_dependencies } else { &v.dependencies };
        deps.as_ref().unwrap().contains(&index_of(i))
    };
    let mut seen_nonzero = std::collections::HashSet::new();
    for scene in ["lt50m_C.toml", "lt50m_B.toml"] {
        let static_w = CableCabin::from_scene(&load_scene(scene)).unwrap().static_payload_wrench();
        for initial in [true, false] {
            let mut m = CableFmu::instantiate(None).unwrap();
            m.set_string(vr::SCENE, scene).unwrap();
            for k in 0..6 {
                m.set_real(vr::WRENCH + k as u32, static_w[k]).unwrap();
            }
            if !initial {
                m.exit_initialization(0.0).unwrap();
                for k in 0..20 {
                    let w = wrench_at(0.01 * k as f64, &static_w);
                    for i in 0..6 {
                        m.set_real(vr::WRENCH + i as u32, w[i]).unwrap();
                    }
                    m.do_step(0.01 * k as f64, 0.01).unwrap();
                }
            }
            for (j, &input) in inputs.iter().enumerate() {
                let u0 = m.get_real(input).unwrap();
                // small steps: the form finding at B (a nearly slack cable) is strongly nonlinear
                let delta = if j < 3 { 2.0 } else { 1.0 };
                let mut at = |u: f64| {
                    m.set_real(input, u).unwrap();
                    outputs.iter().map(|&o| m.get_real(o).unwrap()).collect::<Vec<_>>()
                };
                let (p, q) = (at(u0 + delta), at(u0 - delta));
                at(u0);
                let mut d = vec![f64::NAN; outputs.len()];
                m.directional_derivative(&outputs, &[input], &[1.0], &mut d).unwrap();
                // The form finding stops at residuals of 1e-11 (1e-9 when its line search stalls,
                // as at B with its nearly slack cable) of the weight: differences of its tensions
                // carry that noise, about 1e-5 of the column's largest entry.
                let scale = d.iter().fold(1e-3f64, |m, x| m.max(x.abs()));
                for (r, &o) in outputs.iter().enumerate() {
                    let fd = (p[r] - q[r]) / (2.0 * delta);
                    let what = format!("{scene}, {}: d(vr {o})/d(vr {input})", if initial { "init" } else { "step" });
                    if declared(o, input, initial) {
                        assert!((fd - d[r]).abs() <= 1e-4 * scale, "{what}: fd {fd:e}, exact {:e}", d[r]);
                        if d[r] != 0.0 {
                            seen_nonzero.insert((initial, o, input));
                        }
                    } else {
                        assert_eq!((fd, d[r]), (0.0, 0.0), "{what}: undeclared but it moves");
                    }
                }
            }
        }
    }
    for initial in [true, false] {
        for &o in &outputs {
            for &i in &inputs {
                if declared(o, i, initial) {
                    assert!(seen_nonzero.contains(&(initial, o, i)), "declared but never moves: vr {o} on vr {i}");
                }
            }
        }
    }
}

/// Under scene B with the inputs at their declared start values (scene C's static wrench) the
/// FMU does not replace them; it form-finds for them and stays at rest; given B's own static
/// wrench it starts from the nominal equilibrium.
#[test]
fn initialization_keeps_the_inputs_it_was_given() {
    let mut m = CableFmu::instantiate(None).unwrap();
    let declared: Vec<f64> = (0..6).map(|k| m.get_real(vr::WRENCH + k).unwrap()).collect();
    m.set_string(vr::SCENE, "lt50m_B.toml").unwrap();
    let t0 = m.get_real(vr::TENSION_CABIN).unwrap();
    assert_eq!((0..6).map(|k| m.get_real(vr::WRENCH + k).unwrap()).collect::<Vec<_>>(), declared);
    let b = CableCabin::from_scene(&load_scene("lt50m_B.toml")).unwrap();
    for k in 0..6 {
        m.set_real(vr::WRENCH + k as u32, b.static_payload_wrench()[k]).unwrap();
    }
    let t1 = m.get_real(vr::TENSION_CABIN).unwrap();
    assert_eq!(t1, b.equilibrium.cables[0].tension_cabin.max(t1).min(t1), "finite");
    assert!((t1 - b.equilibrium.cables[0].tension_cabin).abs() < 1e-6 * t1, "{t1} vs the nominal equilibrium");
    assert!((t0 - t1).abs() > 1.0, "another wrench, other tensions: {t0} vs {t1}");
}

/// Misuse that must fail cleanly: a model too large for the machine, a relative scene path
/// leaving resources/, a wrench of 1e300.
#[test]
fn misuse_is_refused_with_the_reason() {
    let mut m = CableFmu::instantiate(None).unwrap();
    for n in [10_000_000, i32::MAX] {
        let e = m.set_integer(vr::ELEMENTS, n).unwrap_err().to_string();
        assert!(e.contains(&format!("{n} elements per cable would need about")) && e.contains("GB"), "{e}");
    }
    assert_eq!(m.get_integer(vr::ELEMENTS).unwrap(), 0, "a refused value is not kept");
    let dir = std::env::temp_dir().join(format!("cable-fmu-res-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("resources")).unwrap();
    std::fs::write(dir.join("secret.toml"), "password = \"hunter2\"\n").unwrap();
    let mut r = CableFmu::instantiate(Some(&dir.join("resources"))).unwrap();
    let e = r.set_string(vr::SCENE, "../secret.toml").unwrap_err().to_string();
    assert!(e.contains("leaves the FMU's resources/ directory") && !e.contains("hunter2"), "{e}");
    std::fs::write(dir.join("resources/bad.toml"), format!("{}\n", "x".repeat(5000))).unwrap();
    let e = r.set_string(vr::SCENE, "bad.toml").unwrap_err().to_string();
    assert!(e.len() < 1000, "a parse error quotes a short excerpt only: {} bytes", e.len());
    std::fs::remove_dir_all(&dir).unwrap();
    let mut m = ready(None);
    m.set_real(vr::WRENCH + 2, 1e300).unwrap();
    let e = m.do_step(0.0, 0.01).unwrap_err().to_string();
    assert!(e.contains("t = 0.01"), "{e}");
}
