//! The constraint equations: Jacobians against finite differences, residuals on the placed
//! motion at position, velocity and acceleration level, and a square, regular system.

mod common;

use common::CabinPath;
use feedcore::Vec3;
use feedcore::rigid::exp_so3;
use feedcore::scene::Start;
use nalgebra::DMatrix;
use stewart::{CABIN, CONSTRAINTS, ConstraintRow, RigidMotion, SYSTEM_BODIES, Stewart};

fn rows_at(st: &Stewart, bodies: &[RigidMotion; SYSTEM_BODIES], t: f64) -> [ConstraintRow; CONSTRAINTS] {
    let mut rows = [ConstraintRow::EMPTY; CONSTRAINTS];
    st.constraints(bodies, t, &mut rows).unwrap();
    rows
}

/// Φ_q with all 14 bodies' columns as a dense matrix.
fn dense_jacobian(rows: &[ConstraintRow; CONSTRAINTS]) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(CONSTRAINTS, 6 * SYSTEM_BODIES);
    for (r, row) in rows.iter().enumerate() {
        for n in 0..2 {
            for c in 0..6 {
                j[(r, 6 * row.bodies[n] + c)] += row.jacobian[n][c];
            }
        }
    }
    j
}

#[test]
fn jacobian_and_time_derivative_match_central_differences() {
    let scene = common::scene("lt50m_B");
    let st = Stewart::from_scene(&scene).unwrap();
    let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
    for t in [0.7, 4.4, 17.0] {
        let mut bodies = st.system_motion(&path.at(t), t).unwrap();
        // Off the constraint manifold, so that no term hides behind a zero value.
        for (i, b) in bodies.iter_mut().enumerate() {
            let x = i as f64;
            b.position += Vec3::new(0.01 * x.sin(), 0.02 * x.cos(), -0.01);
            b.orientation = exp_so3(&Vec3::new(0.03, -0.02 * x.cos(), 0.05 * x.sin())) * b.orientation;
        }
        let j = dense_jacobian(&rows_at(&st, &bodies, t));
        let h = 1e-6;
        for i in 0..SYSTEM_BODIES {
            for c in 0..6 {
                let shifted = |s: f64| {
                    let mut b = bodies;
                    if c < 3 {
                        b[i].position[c] += s;
                    } else {
                        b[i].orientation = exp_so3(&(Vec3::ith(c - 3, s))) * b[i].orientation;
                    }
                    rows_at(&st, &b, t).map(|r| r.value)
                };
                let (p, m) = (shifted(h), shifted(-h));
                for r in 0..CONSTRAINTS {
                    let fd = (p[r] - m[r]) / (2.0 * h);
                    let an = j[(r, 6 * i + c)];
                    assert!((fd - an).abs() < 1e-8, "row {r}, body {i}, column {c}: {an} vs {fd}");
                }
            }
        }
        let (p, m) = (rows_at(&st, &bodies, t + 1e-4), rows_at(&st, &bodies, t - 1e-4));
        for (r, row) in rows_at(&st, &bodies, t).iter().enumerate() {
            let fd = (p[r].value - m[r].value) / 2e-4;
            assert!((fd - row.time_derivative).abs() < 1e-10, "Φ_t row {r}: {} vs {fd}", row.time_derivative);
        }
    }
}

#[test]
fn placed_motion_satisfies_every_constraint_for_100_seconds() {
    for (name, start) in [("lt50m_B", Start::Abrupt), ("lt50m_C", Start::Ramp)] {
        let scene = common::scene(name)
            .edited(|scene| {
                scene.motion.start = start;
            })
            .unwrap();
        let st = Stewart::from_scene(&scene).unwrap();
        let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
        let mut worst = [0.0_f64; 3];
        for i in 0..=2000 {
            let t = i as f64 * 0.05;
            let bodies = st.system_motion(&path.at(t), t).unwrap();
            for row in rows_at(&st, &bodies, t) {
                worst[0] = worst[0].max(row.value.abs());
                worst[1] = worst[1].max(row.velocity_residual(&bodies).abs());
                worst[2] = worst[2].max(row.acceleration_residual(&bodies).abs());
            }
        }
        println!(
            "{name} {start:?}: worst residuals Φ {:e}, Φ_q v + Φ_t {:e}, Φ_q v̇ − γ {:e}",
            worst[0], worst[1], worst[2]
        );
        assert!(worst.iter().all(|w| *w <= 1e-10), "{name}: {worst:?}");
    }
}

#[test]
fn the_moving_bodies_are_fully_constrained() {
    let scene = common::scene("lt50m_C");
    let st = Stewart::from_scene(&scene).unwrap();
    let bodies = st.system_motion(&common::cabin_at_target(&scene), 2.0).unwrap();
    let j = dense_jacobian(&rows_at(&st, &bodies, 2.0));
    let moving = j.columns(0, 6 * CABIN).into_owned();
    assert_eq!(moving.shape(), (78, 78));
    let s = moving.singular_values();
    let condition = s.max() / s.min();
    println!("condition number of Φ_q (moving bodies): {condition:e}");
    assert!(condition < 1e4);
    // With the cabin free too, the system keeps exactly its six rigid-body freedoms.
    let s = j.clone().svd(false, false).singular_values;
    assert_eq!(s.iter().filter(|x| **x > 1e-9 * s.max()).count(), 78);
}
