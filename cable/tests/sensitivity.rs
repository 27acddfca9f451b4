//! Rollback and step sensitivities, as the FMU exposes them: a saved state reproduces every
//! bit, and the exact sensitivity of a step to the wrench matches central differences of
//! re-stepping from the same state.

mod common;

use cable::dynamics::{CabinDelta, Dynamics};
use cable::model::{CableCabin, Payload};
use common::scene;
use nalgebra::Vector6;

fn wrench(t: f64) -> Vector6<f64> {
    Vector6::new(-40.0 * (0.9 * t).sin(), 25.0, -1800.0 + 30.0 * t, 12.0 * (2.1 * t).cos(), -8.0, 3.0 * t)
}

/// Everything the FMU outputs, as one vector.
fn outputs(dy: &Dynamics) -> Vec<f64> {
    let c = dy.cabin();
    let q = c.orientation.quaternion();
    let mut v: Vec<f64> = [c.position, c.velocity, c.angular_velocity, c.acceleration, c.angular_acceleration]
        .iter()
        .flat_map(|x| x.iter().copied().collect::<Vec<_>>())
        .collect();
    v.extend_from_slice(&[q.w, q.i, q.j, q.k]);
    let mut t = vec![(0.0, 0.0); 6];
    dy.end_tensions(&mut t);
    v.extend(t.iter().flat_map(|(a, b)| [*a, *b]));
    v
}

fn started(name: &str) -> Dynamics {
    // The Newton tolerance of the co-simulation scenes' cable FMU: differences of re-stepped
    // solutions need an iteration error far below the perturbation's effect (with the scene's
    // 1e-10 m the tension differences carry 1e-6 of round-off noise from the iteration).
    let s = scene(name)
        .edited(|s| {
            s.solver.newton_tol = 1e-12;
        })
        .unwrap();
    let model = CableCabin::from_scene(&s).unwrap();
    let mut dy = model.dynamics(Payload::External, 0.0).unwrap();
    for k in 1..=50 {
        dy.step(0.01, &(model.static_payload_wrench() + wrench(0.01 * k as f64))).unwrap();
    }
    dy
}

#[test]
fn a_restored_state_reproduces_every_bit() {
    let mut dy = started("lt50m_B.toml");
    let mut saved = Vec::new();
    dy.encode_state(&mut saved);
    let run = |dy: &mut Dynamics| {
        let mut all = Vec::new();
        for k in 0..30 {
            dy.step(0.01, &wrench(0.6 + 0.01 * k as f64)).unwrap();
            all.extend(outputs(dy));
        }
        all
    };
    let first = run(&mut dy);
    dy.decode_state(&saved).unwrap();
    let again = run(&mut dy);
    assert!(first.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()), "rollback must be bit for bit");
    // a state that is not ours is refused
    assert!(dy.decode_state(&saved[..saved.len() - 3]).is_err());
}

#[test]
fn step_sensitivity_matches_central_differences() {
    let mut dy = started("lt50m_C.toml");
    let mut saved = Vec::new();
    dy.encode_state(&mut saved);
    let w = wrench(0.51) + Vector6::new(0.0, 0.0, -1812.9, 0.0, 0.0, 0.0);
    let step_with = |dy: &mut Dynamics, w: &Vector6<f64>| {
        dy.decode_state(&saved).unwrap();
        dy.step(0.01, w).unwrap();
        outputs(dy)
    };
    step_with(&mut dy, &w);
    let mut worst = 0.0f64;
    for k in 0..6 {
        let mut seed = Vector6::zeros();
        seed[k] = 1.0;
        let d = dy.wrench_sensitivity(&seed, true).unwrap();
        // without tensions: the same motion, no tensions
        let motion_only = dy.wrench_sensitivity(&seed, false).unwrap();
        assert!(motion_only.tensions.is_empty());
        assert_eq!(CabinDelta { tensions: d.tensions.clone(), ..motion_only }, d);
        // Central differences: truncation error grows as eps², round-off as 1/eps (an end tension
        // carries ≈ 1e-8 N of round-off from node coordinates of 30 m); these balance them.
        let eps = if k < 3 { 40.0 } else { 20.0 };
        let plus = step_with(&mut dy, &(w + seed * eps));
        let minus = step_with(&mut dy, &(w - seed * eps));
        step_with(&mut dy, &w); // back to the nominal step for the next sensitivity
        let fd: Vec<f64> = plus.iter().zip(&minus).map(|(p, m)| (p - m) / (2.0 * eps)).collect();
        let mut analytic: Vec<f64> = [
            d.motion.position,
            d.motion.velocity,
            d.motion.angular_velocity,
            d.motion.acceleration,
            d.motion.angular_acceleration,
        ]
        .iter()
        .flat_map(|x| x.iter().copied().collect::<Vec<_>>())
        .collect();
        // quaternion: δq = ½ (0, δφ) ⊗ q
        let q = dy.cabin().orientation.into_inner();
        let dq = nalgebra::Quaternion::from_imag(d.motion.rotation * 0.5) * q;
        analytic.extend_from_slice(&[dq.w, dq.i, dq.j, dq.k]);
        analytic.extend(d.tensions.iter().flat_map(|(a, b)| [*a, *b]));
        for (i, (a, f)) in analytic.iter().zip(&fd).enumerate() {
            let scale = f.abs().max(a.abs()).max(1e-12);
            // The differences cannot resolve less than the outputs' round-off: tensions come
            // from ~30 m world coordinates through EA/l0 ≈ 6e6 N/m, ~1e-11 of their value.
            let floor = 1e-11 * plus[i].abs().max(minus[i].abs()) / eps;
            let allowed = 1e-6 * scale + 1e-13 + floor;
            worst = worst.max((a - f).abs() / allowed);
            assert!((a - f).abs() <= allowed, "seed {k}, output {i}: analytic {a:e}, FD {f:e}");
        }
    }
    eprintln!("largest difference from central differences: {worst:.2} of the allowed");
}
