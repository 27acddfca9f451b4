//! The FMU adapter (called in-process through the `fmi2::Model` trait) against the library.

mod common;

use cable_fmu::fmu::{CableFmu, vr};
use cable_fmu::model::{CableCabin, Payload};
use fmi2::ModelInfo;
use fmi2::export::Model;
use nalgebra::Vector6;

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

#[test]
fn the_description_is_valid() {
    ModelInfo::new(CableFmu::description()).unwrap();
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
    let s = common::scene("lt50m_B.toml");
    let model = CableCabin::from_scene(&s).unwrap();
    let w0 = model.static_payload_wrench();
    let mut lib = model.dynamics(Payload::External, 0.0).unwrap();
    let mut m = ready(Some("lt50m_B.toml"));
    for k in 0..6 {
        assert_eq!(m.get_real(vr::WRENCH + k as u32).unwrap(), w0[k], "the input start values are the static wrench");
    }
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
fn directional_derivatives_match_finite_differences_with_rollback() {
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
    m.save_state(&mut saved);
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
        m.directional_derivative(&unknowns, &knowns, &seed, &mut analytic).unwrap();
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
    assert!(e.contains("/no/such/scene.toml"), "{e}");
    let e = m.set_integer(vr::ELEMENTS, -3).unwrap_err();
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
