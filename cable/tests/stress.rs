//! Stress tests of the cable–cabin model: ten times stiffer cables, 50 elements per cable, the
//! nearly slack cable at B driven slack, and 1000 s simulated. Each must finish without NaN, with
//! its energy or drift bounded (the figures are printed).

mod common;

use cable::dynamics::{Dynamics, DynamicsOptions};
use cable::element::Bar;
use cable::model::{CableCabin, Payload};
use cable::system::System;
use feedcore::scene::ValidScene;
use nalgebra::Vector6;

/// Largest energy drift over 1000 undamped steps (ρ∞ = 1) after a cabin kick, relative to the
/// vibration energy, and the largest rest drift over 1000 steps.
fn energy_and_rest(scene: &ValidScene) -> (f64, f64) {
    let model = CableCabin::from_scene(scene).unwrap();
    let mut sys = model.system(Payload::Locked);
    sys.damping = None;
    let eq = model.equilibrium_config();
    let n = sys.dim();
    let options = DynamicsOptions { rho_inf: 1.0, newton_tol: 1e-13, newton_max_iter: 40 };
    let mut rest = Dynamics::new(sys.clone(), eq.clone(), vec![0.0; n], 0.0, &Vector6::zeros(), options).unwrap();
    let mut drift = 0.0f64;
    for _ in 0..1000 {
        rest.step(0.01, &Vector6::zeros()).unwrap();
        drift = drift.max((rest.cabin().position - eq.position).norm());
    }
    let e_eq = sys.energy(&eq, &vec![0.0; n], &eq).total();
    let mut v = vec![0.0; n];
    v[sys.cabin_offset()] = 1e-3;
    let mut dy = Dynamics::new(sys, eq.clone(), v, 0.0, &Vector6::zeros(), options).unwrap();
    let e0 = dy.energy(&eq).total();
    let mut worst = 0.0f64;
    for _ in 0..1000 {
        dy.step(0.01, &Vector6::zeros()).unwrap();
        worst = worst.max((dy.energy(&eq).total() - e0).abs() / (e0 - e_eq));
    }
    (worst, drift)
}

#[test]
fn ten_times_stiffer_cables() {
    let s = common::scene("lt50m_C.toml")
        .edited(|s| {
            s.cables.youngs_modulus_pa *= 10.0;
        })
        .unwrap();
    let (energy, rest) = energy_and_rest(&s);
    eprintln!("E × 10: energy drift {energy:.2e} of the vibration energy, rest drift {rest:.2e} m");
    assert!(energy < 1e-4 && rest < 1e-9);
}

#[test]
fn fifty_elements_per_cable() {
    let s = common::scene("lt50m_C.toml")
        .edited(|s| {
            s.cables.elements = 50;
        })
        .unwrap();
    let (energy, rest) = energy_and_rest(&s);
    eprintln!("50 elements: energy drift {energy:.2e} of the vibration energy, rest drift {rest:.2e} m");
    assert!(energy < 1e-4 && rest < 1e-9);
}

/// Smallest element force in the net now, and whether some element is slack.
fn smallest_tension(sys: &System, dy: &Dynamics) -> f64 {
    let cfg = dy.config();
    let m = sys.free_nodes();
    (0..sys.cables())
        .flat_map(|i| {
            let mut pts = vec![sys.net.anchors[i]];
            pts.extend_from_slice(&cfg.nodes[i * m..i * m + m]);
            pts.push(sys.attachment(cfg, i).0);
            let l0 = sys.element_length[i];
            pts.windows(2).map(|w| Bar::new(&(w[1] - w[0]), sys.net.spec.ea, l0).force).collect::<Vec<_>>()
        })
        .fold(f64::INFINITY, f64::min)
}

/// At B the nearly slack cable 4 carries 0.2 kN; a 2 kN push of the cabin towards its tower
/// sags it further. The soft, strongly nonlinear cable is integrated without trouble.
#[test]
fn the_nearly_slack_cable_under_a_push() {
    let s = common::scene("lt50m_B.toml");
    let model = CableCabin::from_scene(&s).unwrap();
    let sys = model.system(Payload::Locked);
    let mut dy = model.dynamics(Payload::Locked, 0.0).unwrap();
    let a = 260f64.to_radians(); // anchor 4
    let mut tensions = vec![(0.0, 0.0); 6];
    let (mut lowest, mut iterations, mut moved) = (f64::INFINITY, 0, 0.0f64);
    let p0 = dy.cabin().position;
    for k in 1..=3000 {
        let t = 0.01 * k as f64;
        let push = if t < 15.0 { 2000.0 * (std::f64::consts::PI * t / 15.0).sin() } else { 0.0 };
        let w = Vector6::new(push * a.cos(), push * a.sin(), 0.0, 0.0, 0.0, 0.0);
        iterations += dy.step(0.01, &w).unwrap().iterations;
        dy.end_tensions(&mut tensions);
        lowest = lowest.min(tensions[4].1);
        moved = moved.max((dy.cabin().position - p0).norm());
        assert!(smallest_tension(&sys, &dy).is_finite());
    }
    eprintln!(
        "cable 4 at the cabin: static {:.1} N, lowest {lowest:.1} N; cabin pushed {:.1} mm; {:.2} Newton iterations per step",
        model.equilibrium.cables[4].tension_cabin,
        moved * 1e3,
        iterations as f64 / 3000.0
    );
    // the push moved the cabin a lot; the sagging cable's pull hardly changes (its own weight
    // sets its tension), and never reaches zero
    assert!(moved > 0.01 && lowest > 0.0);
}

/// A body held by six pretensioned cables (no gravity) pushed along +x harder than the
/// pretension: the +x cable goes slack (zero force and stiffness), and tightens again when the
/// push is gone. Newton goes through the tension-only kink and back.
#[test]
fn a_cable_goes_slack_and_tightens_again() {
    use cable::net::CableNet;
    use cable::shooting::CableSpec;
    use cable::system::{Config, Support};
    use feedcore::rigid::MassProperties;
    use feedcore::{Mat3, Quat, Vec3};
    let (a, len, ea, pre) = (0.5, 4.0, 2.0e6, 500.0);
    let axes = [Vec3::x(), -Vec3::x(), Vec3::y(), -Vec3::y(), Vec3::z(), -Vec3::z()];
    let net = CableNet {
        anchors: axes.iter().map(|e| e * (a + len)).collect(),
        attachments: axes.iter().map(|e| e * a).collect(),
        spec: CableSpec { elements: 4, ea, mass_per_length: 0.5, gravity: Vec3::zeros() },
        cabin: MassProperties { mass: 300.0, com: Vec3::zeros(), inertia_com: Mat3::identity() * 50.0 },
        payload: MassProperties::ZERO,
    };
    let l0 = len / (1.0 + pre / ea);
    let sys = System::new(net, vec![l0; 6], true, Support::Free);
    // free nodes from the anchor towards the body
    let nodes = axes.iter().flat_map(|e| (1..4).rev().map(move |j| e * (a + len * j as f64 / 4.0))).collect();
    let cfg = Config { nodes, position: Vec3::zeros(), orientation: Quat::identity() };
    let n = sys.dim();
    let options = DynamicsOptions { rho_inf: 0.9, newton_tol: 1e-10, newton_max_iter: 25 };
    let mut dy = Dynamics::new(sys.clone(), cfg, vec![0.0; n], 0.0, &Vector6::zeros(), options).unwrap();
    let mut tensions = vec![(0.0, 0.0); 6];
    let (mut slack_steps, mut iterations) = (0, 0);
    for k in 1..=2000 {
        let t = 0.01 * k as f64;
        let push = if t < 5.0 { 3.0 * pre * (std::f64::consts::PI * t / 5.0).sin() } else { 0.0 };
        iterations += dy.step(0.01, &Vector6::new(push, 0.0, 0.0, 0.0, 0.0, 0.0)).unwrap().iterations;
        dy.end_tensions(&mut tensions);
        slack_steps += usize::from(tensions[0].1 == 0.0);
    }
    dy.end_tensions(&mut tensions);
    eprintln!(
        "+x cable slack in {slack_steps} of 2000 steps, {:.2} Newton iterations per step, force now {:.1} N",
        iterations as f64 / 2000.0,
        tensions[0].1
    );
    assert!(slack_steps > 50, "the +x cable must go slack");
    assert!(tensions[0].1 > 0.0, "and carry load again");
}

/// 1000 s of the cable-only scene under its disturbance: the response stays periodic (the last
/// period's peak equals an early one's).
#[test]
fn a_thousand_seconds() {
    let s = common::scene("lt50m_C_cable_only.toml");
    let model = CableCabin::build(&s, 0).unwrap();
    let d = s.disturbance.clone().unwrap();
    let mut dy = model.dynamics_with(Payload::Locked, 0.0, &Vector6::from(d.wrench(0.0))).unwrap();
    let p0 = dy.cabin().position;
    let period = 1.0 / d.frequency_hz;
    let (mut early, mut late) = (0.0f64, 0.0f64);
    for k in 1..=100_000 {
        let t = 0.01 * k as f64;
        dy.step(0.01, &Vector6::from(d.wrench(t))).unwrap();
        let x = (dy.cabin().position - p0).norm();
        if t > 5.0 * period && t <= 6.0 * period {
            early = early.max(x);
        }
        if t > 1000.0 - period {
            late = late.max(x);
        }
    }
    eprintln!("peak in period 6: {:.4} mm, in the last period: {:.4} mm", early * 1e3, late * 1e3);
    assert!((late - early).abs() < 0.01 * early);
}
