//! Kinematics: relative and absolute body motion against finite differences, the leg frames
//! against the joint definitions, inverse against forward kinematics.

mod common;

use common::{CabinPath, derivative, rotation_between};
use feedcore::scene::{LEGS, Start};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::Vector3;
use stewart::kinematics::{forward_kinematics, leg_lengths};
use stewart::{PathPoint, RelativeState, RigidMotion, Stewart};

fn assert_close(what: &str, a: &Vec3, b: &Vec3, tol: f64) {
    assert!((a - b).norm() <= tol, "{what}: {a:?} vs {b:?} (diff {:e})", (a - b).norm());
}

/// Velocities and accelerations of a family of rigid motions against 8th-order differences.
fn check_derivatives(name: &str, motion: impl Fn(f64) -> RigidMotion, t: f64, h: f64, tol: f64) {
    let m = motion(t);
    let v = derivative(|s| motion(s).position, t, h);
    let a = derivative(|s| motion(s).velocity, t, h);
    let w = derivative(|s| rotation_between(&m.orientation, &motion(s).orientation), t, h);
    let dw = derivative(|s| motion(s).angular_velocity, t, h);
    assert_close(&format!("{name} velocity at t={t}"), &m.velocity, &v, tol);
    assert_close(&format!("{name} acceleration at t={t}"), &m.acceleration, &a, tol);
    assert_close(&format!("{name} angular velocity at t={t}"), &m.angular_velocity, &w, tol);
    assert_close(&format!("{name} angular acceleration at t={t}"), &m.angular_acceleration, &dw, tol);
}

/// Every body's relative motion of a family of relative states against differences, and the
/// strokes' rates and accelerations against differences of their lengths and rates.
fn check_relative_motion(name: &str, rel: impl Fn(f64) -> RelativeState, t: f64) {
    for i in 0..BODIES {
        let body = |s: f64| {
            let b = rel(s).bodies[i];
            RigidMotion {
                position: b.position,
                orientation: Quat::from_matrix(&b.orientation),
                velocity: b.velocity,
                angular_velocity: b.angular_velocity,
                acceleration: b.acceleration,
                angular_acceleration: b.angular_acceleration,
            }
        };
        check_derivatives(&format!("{name} body {i}"), body, t, 1e-3, 1e-11);
    }
    let now = rel(t);
    for k in 0..LEGS {
        let rate = derivative(|s| Vector3::repeat(rel(s).strokes[k].length), t, 1e-3);
        let accel = derivative(|s| Vector3::repeat(rel(s).strokes[k].rate), t, 1e-3);
        assert!((rate.x - now.strokes[k].rate).abs() < 1e-12, "{name} leg {k}");
        assert!((accel.x - now.strokes[k].acceleration).abs() < 1e-12, "{name} leg {k}");
    }
}

#[test]
fn the_test_cabin_path_is_self_consistent() {
    let s = common::scene("lt50m_B");
    let path = CabinPath::lively(s.target_position(), s.target_orientation());
    for t in [0.0, 0.7, 3.3, 12.9] {
        check_derivatives("cabin", |s| path.at(s), t, 1e-3, 1e-10);
    }
}

#[test]
fn relative_motion_matches_finite_differences() {
    for name in ["lt50m_B", "lt50m_C"] {
        for start in [Start::Abrupt, Start::Ramp] {
            let scene = common::scene(name)
                .edited(|scene| {
                    scene.motion.start = start;
                    // A faster circle makes every derivative term count.
                    scene.motion.speed_m_s = 0.3;
                })
                .unwrap();
            let st = Stewart::from_scene(&scene).unwrap();
            for t in [0.4, 1.1, 2.9, 4.2, 7.7] {
                check_relative_motion(&format!("{name} {start:?}"), |s| st.relative(s).unwrap(), t);
            }
        }
    }
}

/// The platform translating and turning about a tilted axis (a compensation's command): every
/// body's relative motion against finite differences, the strokes' rates, and the legs ending at
/// the turned platform joints.
#[test]
fn relative_motion_of_a_turning_platform_matches_finite_differences() {
    let st = common::stewart("lt50m_C");
    let g = st.geometry();
    let axis = Vec3::new(0.4, -0.3, 1.0).normalize();
    let point = |t: f64| {
        let (s, c) = (2.0 * t).sin_cos();
        let (th, dth, ddth) = (0.05 * s, 0.1 * c, -0.2 * s);
        PathPoint {
            position: g.nominal_center + Vec3::new(0.03 * s, 0.02 * c, 0.01 * s),
            velocity: Vec3::new(0.06 * c, -0.04 * s, 0.02 * c),
            acceleration: Vec3::new(-0.12 * s, -0.08 * c, -0.04 * s),
            orientation: feedcore::rigid::exp_so3(&(axis * th)).to_rotation_matrix().into_inner(),
            angular_velocity: axis * dth,
            angular_acceleration: axis * ddth,
        }
    };
    for t in [0.3, 1.2, 2.6] {
        let rel = |s: f64| st.relative_at(&point(s), s).unwrap();
        check_relative_motion("turning platform", rel, t);
        let now = rel(t);
        let p = point(t);
        for k in 0..LEGS {
            let d = p.position + p.orientation * g.platform_joints[k] - g.base_joints[k];
            assert!((now.strokes[k].length - d.norm()).abs() < 1e-15);
            assert_close("leg axis", &now.bodies[1 + k].orientation.column(2).into_owned(), &d.normalize(), 1e-15);
        }
        // the platform's inertia turns with it
        let j = st.body_inertias()[0].inertia_com;
        assert!((now.bodies[0].inertia - p.orientation * j * p.orientation.transpose()).norm() < 1e-15 * j.norm());
    }
}

#[test]
fn leg_frames_obey_the_joints() {
    let st = common::stewart("lt50m_B");
    let g = st.geometry();
    for t in [0.0, 5.0, 13.0, 27.0] {
        let rel = st.relative(t).unwrap();
        let p = rel.bodies[0].position;
        assert_eq!(rel.bodies[0].orientation, Mat3::identity(), "the platform does not rotate");
        for k in 0..LEGS {
            let (up, lo) = (&rel.bodies[1 + k], &rel.bodies[1 + LEGS + k]);
            let d = p + g.platform_joints[k] - g.base_joints[k];
            let u = d.normalize();
            // both parts share one orientation, with z along the leg
            assert_eq!(up.orientation, lo.orientation);
            assert_close("leg axis", &up.orientation.column(2).into_owned(), &u, 1e-15);
            // the second Hooke axis (body y) is perpendicular to the first (cabin-fixed) one
            assert!(up.orientation.column(1).dot(&g.hooke_first_axis(k)).abs() < 1e-15);
            // relative angular velocity in span(a, b): no spin through the Hooke joint
            let c = g.hooke_first_axis(k).cross(&up.orientation.column(1));
            assert!(up.angular_velocity.dot(&c).abs() < 1e-17);
            assert!((rel.strokes[k].length - d.norm()).abs() < 1e-15);
            // centres of mass on the leg axis at their distances from the joints
            assert_close("upper com", &up.position, &(g.base_joints[k] + u * g.upper.com_from_joint_m), 1e-15);
            assert_close("lower com", &lo.position, &(g.base_joints[k] + d - u * g.lower.com_from_joint_m), 1e-15);
        }
        // mass properties agree with the shared geometry's independent computation
        let shared = g.body_mass_properties(&p);
        for (i, b) in rel.bodies.iter().enumerate() {
            assert_close("com", &shared[i].com, &b.position, 1e-15);
            assert!((shared[i].inertia_com - b.inertia).norm() < 1e-14);
        }
    }
}

#[test]
fn placed_bodies_match_finite_differences_on_a_moving_cabin() {
    let (_, st, path) = common::moving("lt50m_C", 0.3);
    for t in [0.5, 2.2, 6.1] {
        for i in 0..BODIES {
            let body = |s: f64| st.place_bodies(&path.at(s), &st.relative(s).unwrap())[i];
            check_derivatives(&format!("body {i}"), body, t, 1e-3, 1e-10);
        }
    }
}

#[test]
fn ramp_start_is_smooth_and_abrupt_start_is_not() {
    let scene = common::scene("lt50m_B")
        .edited(|scene| {
            scene.motion.start = Start::Ramp;
        })
        .unwrap();
    let ramp = Stewart::from_scene(&scene).unwrap();
    let cabin = common::cabin_at_target(&scene);
    let eps = 1e-9;
    for t0 in [0.0, scene.motion.ramp_time_s] {
        let (a, b) = (ramp.relative(t0 - eps).unwrap(), ramp.relative(t0 + eps).unwrap());
        for i in 0..BODIES {
            let (x, y) = (&a.bodies[i], &b.bodies[i]);
            assert_close("velocity", &x.velocity, &y.velocity, 1e-10);
            assert_close("acceleration", &x.acceleration, &y.acceleration, 1e-10);
            assert_close("angular velocity", &x.angular_velocity, &y.angular_velocity, 1e-10);
            assert_close("angular acceleration", &x.angular_acceleration, &y.angular_acceleration, 1e-10);
        }
        let (wa, wb) = (ramp.wrench(&cabin, t0 - eps).unwrap(), ramp.wrench(&cabin, t0 + eps).unwrap());
        let jump = (wa.to_vector() - wb.to_vector()).norm();
        // 2e-9 s of smooth motion moves the wrench by ~1e-7 N; a jump would be ~0.1 N.
        assert!(jump < 1e-6, "wrench jumps at t = {t0} by {jump:e}");
    }
    // the abrupt start jumps to full speed at t = 0
    let abrupt = Stewart::from_scene(&scene.edited(|s| s.motion.start = Start::Abrupt).unwrap()).unwrap();
    let (a, b) = (abrupt.relative(-eps).unwrap(), abrupt.relative(0.0).unwrap());
    assert!((a.bodies[0].velocity - b.bodies[0].velocity).norm() > 0.019);
    let (wa, wb) = (abrupt.wrench(&cabin, -eps).unwrap(), abrupt.wrench(&cabin, 0.0).unwrap());
    assert!((wa.to_vector() - wb.to_vector()).norm() > 1e-2);
}

#[test]
fn forward_kinematics_inverts_inverse_kinematics() {
    let st = common::stewart("lt50m_B");
    let g = st.geometry();
    let guess = (g.nominal_center, Quat::identity());
    let mut worst: f64 = 0.0;
    // along the prescribed circle
    let mut poses: Vec<(Vec3, Quat)> =
        (0..64).map(|i| (st.path().at(i as f64 * 0.5).position, Quat::identity())).collect();
    // and general poses with rotation
    for i in 0..32 {
        let x = i as f64;
        let c = g.nominal_center + Vec3::new(0.12 * (0.7 * x).sin(), 0.1 * (1.3 * x).cos(), 0.08 * (0.4 * x).sin());
        let th = Vec3::new(0.1 * (0.9 * x).cos(), 0.08 * (1.7 * x).sin(), 0.2 * (0.3 * x).sin());
        poses.push((c, feedcore::rigid::exp_so3(&th)));
    }
    for (c, q) in poses {
        let lengths = leg_lengths(g, &c, &q.to_rotation_matrix().into_inner());
        let (c2, q2) = forward_kinematics(g, &lengths, guess).unwrap();
        worst = worst.max((c2 - c).norm());
        assert!((c2 - c).norm() < 1e-12, "centre off by {:e} m", (c2 - c).norm());
        assert!(rotation_between(&q, &q2).norm() < 1e-12);
    }
    println!("worst forward-kinematics error {worst:e} m");
}
