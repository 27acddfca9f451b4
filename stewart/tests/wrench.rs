//! The wrench on the cabin: statics, added mass, momentum balance and its Jacobians, each against
//! an independent computation.

mod common;

use common::{CabinPath, derivative};
use feedcore::Vec3;
use feedcore::rigid::exp_so3;
use feedcore::scene::Start;
use nalgebra::{Matrix6, Vector6};
use stewart::{CabinMotion, Stewart};

const TOTAL_MASS: f64 = 184.8;

#[test]
fn static_wrench_is_the_weight_through_the_centre_of_mass() {
    for name in ["lt50m_B", "lt50m_C"] {
        let scene = common::scene(name);
        let st = Stewart::from_scene(&scene).unwrap();
        let (x, q) = (scene.target_position(), scene.target_orientation());
        let g = st.geometry();
        let locked = g.locked_mass_properties(&g.start_center);
        assert!((locked.mass - TOTAL_MASS).abs() < 1e-12);
        let weight = Vec3::new(0.0, 0.0, -TOTAL_MASS * scene.gravity_m_s2);
        let moment = (q * locked.com).cross(&weight);
        for w in [st.static_wrench(&x, &q).unwrap(), st.wrench(&CabinMotion::at_rest(x, q), -1.0).unwrap()] {
            assert!((w.force - weight).norm() < 1e-12 * weight.norm(), "{name}: {:?}", w.force);
            assert!((w.moment - moment).norm() < 1e-12 * weight.norm(), "{name}: {:?} vs {moment:?}", w.moment);
        }
    }
}

#[test]
fn added_mass_is_the_locked_spatial_mass_matrix() {
    for name in ["lt50m_B", "lt50m_C"] {
        let scene = common::scene(name);
        let st = Stewart::from_scene(&scene).unwrap();
        let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
        for t in [0.0, 3.0, 11.0, 25.0] {
            let cabin = path.at(t);
            let (w0, jac) = st.wrench_with_jacobians(&cabin, t).unwrap();
            // pure translational acceleration: the force changes by exactly −m·a
            let a = Vec3::new(0.7, -1.3, 2.1);
            let w1 = st.wrench(&CabinMotion { acceleration: cabin.acceleration + a, ..cabin }, t).unwrap();
            assert!((w1.force - w0.force + a * TOTAL_MASS).norm() < 1e-12 * TOTAL_MASS * a.norm());
            // the added mass is the frozen platform's spatial mass matrix about the cabin centre
            // point (parallel-axis theorem, shared geometry), seen in the world
            let rel = st.relative(t).unwrap();
            let r = cabin.orientation.to_rotation_matrix().into_inner();
            let locked = st.geometry().locked_mass_properties(&rel.bodies[0].position);
            let expected = locked.transformed(&r, &cabin.position).spatial_matrix_about(&cabin.position);
            let added = jac.added_mass();
            assert!((added - expected).norm() < 1e-12 * expected.norm(), "{name} t={t}:\n{added}\n{expected}");
            assert!((added - added.transpose()).norm() < 1e-12 * added.norm());
        }
    }
}

/// Linear momentum P and angular momentum about `origin` of the 13 bodies, from their velocities.
fn momenta(st: &Stewart, cabin: &CabinMotion, t: f64, origin: &Vec3) -> Vector6<f64> {
    let bodies = st.place_bodies(cabin, &st.relative(t).unwrap());
    let mut h = Vector6::zeros();
    for (b, inertia) in bodies.iter().zip(st.body_inertias()) {
        let r = b.orientation.to_rotation_matrix().into_inner();
        let p = b.velocity * inertia.mass;
        let l = (b.position - origin).cross(&p) + r * inertia.inertia_com * r.transpose() * b.angular_velocity;
        h += Vector6::new(p.x, p.y, p.z, l.x, l.y, l.z);
    }
    h
}

#[test]
fn reversed_wrench_plus_gravity_is_the_rate_of_momentum() {
    for (name, start, speed) in
        [("lt50m_B", Start::Abrupt, 0.02), ("lt50m_C", Start::Ramp, 0.02), ("lt50m_B", Start::Ramp, 0.5)]
    {
        let scene = common::scene(name)
            .edited(|scene| {
                scene.motion.start = start;
                scene.motion.speed_m_s = speed;
            })
            .unwrap();
        let st = Stewart::from_scene(&scene).unwrap();
        let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
        let origin = scene.target_position() + Vec3::new(0.3, -0.2, 0.1);
        let mut worst: f64 = 0.0;
        for i in 0..40 {
            let t = 0.5 + i as f64 * 2.0;
            let cabin = path.at(t);
            let w = st.wrench(&cabin, t).unwrap();
            let rate = derivative(|s| momenta(&st, &path.at(s), s, &origin), t, 2e-3);
            let bodies = st.place_bodies(&cabin, &st.relative(t).unwrap());
            let g = st.gravity();
            let mut applied = Vector6::zeros();
            for (b, inertia) in bodies.iter().zip(st.body_inertias()) {
                let f = g * inertia.mass;
                let m = (b.position - origin).cross(&f);
                applied += Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
            }
            // the cabin acts on the platform with −F at the cabin centre point and −M
            let m_cabin = -w.moment - (cabin.position - origin).cross(&w.force);
            applied += Vector6::new(-w.force.x, -w.force.y, -w.force.z, m_cabin.x, m_cabin.y, m_cabin.z);
            let scale = TOTAL_MASS * scene.gravity_m_s2;
            let error = (applied - rate).amax() / scale;
            worst = worst.max(error);
            assert!(error < 1e-9, "{name} {start:?} t={t}: {applied} vs {rate} (error {error:e})");
        }
        println!("{name} {start:?} speed {speed}: worst momentum-balance error {worst:e} (relative to the weight)");
    }
}

/// Central differences of the wrench with respect to the six components of one input group.
fn finite_difference(mut wrench: impl FnMut(usize, f64) -> Vector6<f64>, h: f64) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    for k in 0..6 {
        m.set_column(k, &((wrench(k, h) - wrench(k, -h)) / (2.0 * h)));
    }
    m
}

fn assert_matrix_close(what: &str, analytic: &Matrix6<f64>, fd: &Matrix6<f64>, tol: f64) {
    // relative to the matrix's size; each column also against its own size where it is not zero
    let scale = analytic.norm().max(1e-300);
    let err = (analytic - fd).norm() / scale;
    assert!(err < tol, "{what}: relative error {err:e}\nanalytic {analytic}\nfd {fd}");
    for k in 0..6 {
        let (a, f) = (analytic.column(k), fd.column(k));
        assert!((a - f).norm() <= tol * a.norm().max(1e-9 * scale), "{what} column {k}: {a} vs {f}");
    }
}

fn split(x: &Vector6<f64>) -> (Vec3, Vec3) {
    (x.fixed_rows::<3>(0).into_owned(), x.fixed_rows::<3>(3).into_owned())
}

#[test]
fn jacobians_match_central_differences() {
    for (name, speed) in [("lt50m_B", 0.02), ("lt50m_C", 0.02), ("lt50m_B", 0.5)] {
        let (_, st, path) = common::moving(name, speed);
        for t in [0.0, 1.9, 8.4, 23.0] {
            let cabin = path.at(t);
            let (_, jac) = st.wrench_with_jacobians(&cabin, t).unwrap();
            // ∂W/∂(two 3-vectors of the motion) by central differences; `nudge` moves the motion by
            // the first and the second part of a 6-vector
            let fd = |nudge: fn(&mut CabinMotion, Vec3, Vec3), h: f64| {
                let wrench = |k: usize, h: f64| {
                    let mut x = Vector6::zeros();
                    x[k] = h;
                    let (p, q) = split(&x);
                    let mut c = cabin;
                    nudge(&mut c, p, q);
                    st.wrench(&c, t).unwrap().to_vector()
                };
                finite_difference(wrench, h)
            };
            let fd_acc = fd(
                |c, a, al| (c.acceleration, c.angular_acceleration) = (c.acceleration + a, c.angular_acceleration + al),
                1e-3,
            );
            let fd_vel =
                fd(|c, v, w| (c.velocity, c.angular_velocity) = (c.velocity + v, c.angular_velocity + w), 1e-4);
            let fd_pose =
                fd(|c, dr, dth| (c.position, c.orientation) = (c.position + dr, exp_so3(&dth) * c.orientation), 1e-5);
            assert_matrix_close(&format!("{name} t={t} ∂W/∂(a,α)"), &jac.acceleration, &fd_acc, 1e-6);
            assert_matrix_close(&format!("{name} t={t} ∂W/∂(v,ω)"), &jac.velocity, &fd_vel, 1e-6);
            assert_matrix_close(&format!("{name} t={t} ∂W/∂(δr,δθ)"), &jac.pose, &fd_pose, 1e-6);
            // the wrench does not depend on the cabin position or its linear velocity
            assert_eq!(jac.pose.fixed_columns::<3>(0).norm(), 0.0);
            assert_eq!(jac.velocity.fixed_columns::<3>(0).norm(), 0.0);
        }
    }
}

#[test]
fn jacobians_returned_with_the_wrench_belong_to_it() {
    let st = common::stewart("lt50m_C");
    let cabin = CabinMotion::at_rest(Vec3::new(0.0, 0.0, 9.8), feedcore::Quat::identity());
    let (w, _) = st.wrench_with_jacobians(&cabin, 4.0).unwrap();
    assert_eq!(w, st.wrench(&cabin, 4.0).unwrap());
}

#[test]
fn fixed_cabin_force_averages_to_the_weight_over_a_revolution() {
    // With the cabin held, F = m g − S̈ (S the first moment of mass); S̈ integrates to the change
    // of Ṡ, which is zero over a revolution at constant speed: the mean force is the weight.
    for name in ["lt50m_B", "lt50m_C"] {
        let scene = common::scene(name);
        let st = Stewart::from_scene(&scene).unwrap();
        let (x, q) = (scene.target_position(), scene.target_orientation());
        let end = st.path().revolution_time().unwrap();
        let n = 2000;
        let history = st.fixed_cabin(&x, &q, (0..n).map(|i| end * i as f64 / n as f64)).unwrap();
        let mean = history.iter().map(|e| e.wrench.force).sum::<Vec3>() / n as f64;
        let weight = Vec3::new(0.0, 0.0, -TOTAL_MASS * scene.gravity_m_s2);
        assert!((mean - weight).norm() < 1e-10 * weight.norm(), "{name}: {mean:?}");
        // and it does vary: the platform's circle is felt by the cabin
        let range = st.fixed_cabin_range(&x, &q, scene.solver.dt_s).unwrap();
        assert!(range.wrench_max[0] - range.wrench_min[0] > 0.1);
        assert!(range.samples > 3000 && (range.duration - 10.0 * std::f64::consts::PI).abs() < 1e-9);
    }
}
