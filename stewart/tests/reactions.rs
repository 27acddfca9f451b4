//! Joint reactions and actuator forces from the multiplier solve, against the momentum form of
//! the wrench, a dense solve of eq. (5), per-body Newton–Euler balances, and a statics-only
//! virtual-work computation through the legs' 6×6 Jacobian.

mod common;

use common::CabinPath;
use feedcore::rigid::exp_so3;
use feedcore::scene::{LEGS, ValidScene};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{DMatrix, DVector, Matrix6, Vector6};
use stewart::constraints::{CABIN, CONSTRAINTS, ConstraintRow, lower, upper};
use stewart::{CabinMotion, Evaluation, Stewart};

#[test]
fn hooke_reactions_add_up_to_the_momentum_wrench() {
    for name in ["lt50m_B", "lt50m_C"] {
        let (_, st, path) = common::moving(name, 0.3);
        for t in [0.0, 1.5, 7.0, 19.0, 33.0] {
            let cabin = path.at(t);
            let e = st.evaluate(&cabin, t).unwrap();
            let w = st.wrench(&cabin, t).unwrap();
            let err = (e.wrench.to_vector() - w.to_vector()).norm() / w.to_vector().norm();
            assert!(err < 1e-12, "{name} t={t}: {:?} vs {:?}", e.wrench, w);
            // and from the leg reactions at the Hooke centres
            let mut sum = Vector6::zeros();
            for k in 0..LEGS {
                let at = cabin.position + cabin.orientation * st.geometry().base_joints[k];
                let f = -e.legs[k].hooke_force;
                let m = (at - cabin.position).cross(&f) - e.legs[k].hooke_moment;
                sum += Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z);
            }
            assert!((sum - w.to_vector()).norm() < 1e-12 * w.to_vector().norm());
        }
    }
}

/// The generalized forces f − M v̇ of the 13 bodies, written out independently of the library.
fn net_forces(st: &Stewart, cabin: &CabinMotion, t: f64) -> DVector<f64> {
    let bodies = st.place_bodies(cabin, &st.relative(t).unwrap());
    let mut q = DVector::zeros(6 * BODIES);
    for (i, (b, inertia)) in bodies.iter().zip(st.body_inertias()).enumerate() {
        let r = b.orientation.to_rotation_matrix().into_inner();
        let j = r * inertia.inertia_com * r.transpose();
        let f = (st.gravity() - b.acceleration) * inertia.mass;
        let m = -(j * b.angular_acceleration + b.angular_velocity.cross(&(j * b.angular_velocity)));
        q.rows_mut(6 * i, 3).copy_from(&f);
        q.rows_mut(6 * i + 3, 3).copy_from(&m);
    }
    q
}

#[test]
fn multipliers_solve_the_full_system_of_eq_5() {
    let scene = common::scene("lt50m_B");
    let st = Stewart::from_scene(&scene).unwrap();
    let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
    for t in [0.3, 12.0] {
        let cabin = path.at(t);
        let e = st.evaluate(&cabin, t).unwrap();
        let system = st.system_motion(&cabin, t).unwrap();
        let mut rows = [ConstraintRow::EMPTY; CONSTRAINTS];
        st.constraints(&system, t, &mut rows).unwrap();
        let mut jt = DMatrix::zeros(6 * BODIES, CONSTRAINTS);
        for (r, row) in rows.iter().enumerate() {
            for n in 0..2 {
                if row.bodies[n] != CABIN {
                    for c in 0..6 {
                        jt[(6 * row.bodies[n] + c, r)] += row.jacobian[n][c];
                    }
                }
            }
        }
        let q = net_forces(&st, &cabin, t);
        let dense = jt.clone().lu().solve(&q).unwrap();
        let ours = DVector::from_row_slice(&e.multipliers);
        let err = (&dense - &ours).amax() / dense.amax();
        assert!(err < 1e-11, "t={t}: multipliers differ by {err:e}");
        assert!((&jt * &ours - &q).amax() < 1e-10 * q.amax());
    }
}

#[test]
fn every_body_is_in_newton_euler_balance_with_its_joint_reactions() {
    let (_, st, path) = common::moving("lt50m_C", 0.3);
    let t = 5.5;
    let cabin = path.at(t);
    let e = st.evaluate(&cabin, t).unwrap();
    let bodies = st.place_bodies(&cabin, &st.relative(t).unwrap());
    let q = net_forces(&st, &cabin, t);
    let g = st.geometry();
    let scale = 184.8 * 9.81;
    let sphere = |k: usize| e.platform.position + e.platform.orientation * g.platform_joints[k];
    // (force, moment about the body's centre of mass) that must equal −(f − M v̇) minus gravity,
    // i.e. reactions + (f − M v̇) = 0
    let check = |i: usize, f: Vec3, m: Vec3| {
        let qf = Vec3::new(q[6 * i], q[6 * i + 1], q[6 * i + 2]);
        let qm = Vec3::new(q[6 * i + 3], q[6 * i + 4], q[6 * i + 5]);
        assert!((f + qf).norm() < 1e-11 * scale, "body {i}: force {f:?} vs {qf:?}");
        assert!((m + qm).norm() < 1e-11 * scale, "body {i}: moment {m:?} vs {qm:?}");
    };
    let (mut fp, mut mp) = (Vec3::zeros(), Vec3::zeros());
    for k in 0..LEGS {
        let r = &e.legs[k];
        let f = r.spherical_force;
        fp += f;
        mp += (sphere(k) - e.platform.position).cross(&f);
        // upper part: the cabin at the Hooke centre, the lower part through the slide
        let hooke = cabin.position + cabin.orientation * g.base_joints[k];
        let (u, d) = (&bodies[upper(k)], &bodies[lower(k)]);
        let f_up = r.hooke_force - r.prismatic_force;
        let m_up = r.hooke_moment + (hooke - u.position).cross(&r.hooke_force)
            - (r.prismatic_moment + (sphere(k) - u.position).cross(&r.prismatic_force));
        check(upper(k), f_up, m_up);
        // lower part: the upper part through the slide, the platform at the sphere
        let f_lo = r.prismatic_force - r.spherical_force;
        let m_lo = r.prismatic_moment + (sphere(k) - d.position).cross(&(r.prismatic_force - r.spherical_force));
        check(lower(k), f_lo, m_lo);
        // the actuator is the slide's only axial force: tension pulls the lower part up the leg
        let axis = (sphere(k) - hooke).normalize();
        assert!((r.prismatic_force.dot(&axis) + e.actuator_forces[k]).abs() < 1e-11 * scale);
    }
    check(0, fp, mp);
}

/// Gravity potential of the platform and legs with the platform at (c, R) in the cabin frame, and
/// the six leg lengths, written from the scene numbers alone.
fn potential_and_lengths(scene: &ValidScene, c: &Vec3, r: &Mat3, gravity_cabin: &Vec3) -> (f64, [f64; 6]) {
    let s = &scene.stewart;
    let base = s.base_joints.points();
    let plat = s.platform_joints.points();
    let mut v = -s.platform.mass_kg * gravity_cabin.dot(c);
    let mut lengths = [0.0; 6];
    for k in 0..6 {
        let sph = c + r * plat[k];
        let d = sph - base[k];
        lengths[k] = d.norm();
        let u = d / lengths[k];
        let cu = base[k] + u * s.upper_leg.com_from_joint_m;
        let cl = sph - u * s.lower_leg.com_from_joint_m;
        v -= gravity_cabin.dot(&(cu * s.upper_leg.mass_kg + cl * s.lower_leg.mass_kg));
    }
    (v, lengths)
}

/// Actuator tensions holding the platform at rest at `center` by virtual work:
/// Σ −T_k δℓ_k − δV = 0 for every pose change, i.e. T = −J⁻ᵀ ∇V, both by 4th-order differences.
fn virtual_work_tensions(scene: &ValidScene, center: &Vec3, gravity_cabin: &Vec3) -> [f64; 6] {
    let h = 1e-4;
    let mut grad = Vector6::zeros();
    let mut jac = Matrix6::zeros();
    for c in 0..6 {
        let at = |s: f64| {
            let mut x = *center;
            let mut r = Mat3::identity();
            if c < 3 {
                x[c] += s;
            } else {
                r = exp_so3(&Vec3::ith(c - 3, s)).to_rotation_matrix().into_inner();
            }
            potential_and_lengths(scene, &x, &r, gravity_cabin)
        };
        let stencil = |f: &dyn Fn(f64) -> f64| (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h);
        grad[c] = stencil(&|s| at(s).0);
        for k in 0..6 {
            jac[(k, c)] = stencil(&|s| at(s).1[k]);
        }
    }
    let t = -jac.transpose().lu().solve(&grad).unwrap();
    std::array::from_fn(|k| t[k])
}

/// The scene's platform held at rest at `offset` from its nominal centre (no motion).
fn at_rest(scene: ValidScene, offset: Vec3) -> (ValidScene, Stewart) {
    let scene = scene
        .edited(|s| {
            let c = Vec3::from(s.stewart.platform.nominal_center_m) + offset;
            s.stewart.platform.nominal_center_m = c.into();
            s.motion.radius_m = 0.0;
        })
        .unwrap();
    let st = Stewart::from_scene(&scene).unwrap();
    (scene, st)
}

#[test]
fn static_actuator_forces_match_virtual_work() {
    for name in ["lt50m_B", "lt50m_C"] {
        for offset in [Vec3::new(0.1, 0.0, 0.0), Vec3::zeros(), Vec3::new(-0.05, 0.07, 0.03)] {
            let (scene, st) = at_rest(common::scene(name), offset);
            let cabin = common::cabin_at_target(&scene);
            let e = st.evaluate(&cabin, 3.0).unwrap();
            let g_cabin = cabin.orientation.inverse() * st.gravity();
            let center = st.geometry().start_center;
            let expected = virtual_work_tensions(&scene, &center, &g_cabin);
            println!("{name} offset {:?}: tensions {:?}", offset.as_slice(), e.actuator_forces);
            for k in 0..6 {
                let err = (e.actuator_forces[k] - expected[k]).abs() / expected[k].abs();
                assert!(err < 1e-8, "{name} leg {}: {} vs {} (virtual work)", k + 1, e.actuator_forces[k], expected[k]);
                if name == "lt50m_C" {
                    assert!(e.actuator_forces[k] > 0.0, "a platform hanging from a level cabin pulls on its legs");
                }
            }
        }
    }
}

fn rotate_z(v: &Vec3, deg: f64) -> Vec3 {
    Quat::from_axis_angle(&Vec3::z_axis(), deg.to_radians()) * v
}

fn mirror_y(v: &Vec3) -> Vec3 {
    Vec3::new(v.x, -v.y, v.z)
}

#[test]
fn level_cabin_reactions_have_the_platform_symmetry() {
    // Platform at the nominal centre: three-fold symmetry about z and a mirror plane y = 0.
    let (scene, st) = at_rest(common::scene("lt50m_C"), Vec3::zeros());
    let e: Evaluation = st.evaluate(&common::cabin_at_target(&scene), 1.0).unwrap();
    let tol = 1e-10 * e.actuator_forces[0];
    for k in 0..6 {
        assert!((e.actuator_forces[k] - e.actuator_forces[0]).abs() < tol, "{:?}", e.actuator_forces);
    }
    for (from, to) in [(0, 2), (2, 4), (1, 3), (3, 5)] {
        let (a, b) = (&e.legs[from], &e.legs[to]);
        assert!((rotate_z(&a.hooke_force, 120.0) - b.hooke_force).norm() < tol);
        assert!((rotate_z(&a.spherical_force, 120.0) - b.spherical_force).norm() < tol);
    }
    // mirror pairs: leg 1 ↔ 2; the moments are axial vectors (mirror with a sign flip)
    let (a, b) = (&e.legs[0], &e.legs[1]);
    assert!((mirror_y(&a.hooke_force) - b.hooke_force).norm() < tol);
    assert!((mirror_y(&a.hooke_moment) + b.hooke_moment).norm() < tol);

    // At the start point (on the mirror plane) only the mirror symmetry remains.
    let (scene, st) = at_rest(common::scene("lt50m_C"), Vec3::new(0.1, 0.0, 0.0));
    let e = st.evaluate(&common::cabin_at_target(&scene), 1.0).unwrap();
    let f = e.actuator_forces;
    for (a, b) in [(0, 1), (2, 5), (3, 4)] {
        assert!((f[a] - f[b]).abs() < tol, "legs {} and {}: {f:?}", a + 1, b + 1);
        assert!((mirror_y(&e.legs[a].spherical_force) - e.legs[b].spherical_force).norm() < tol);
    }
    assert!((f[0] - f[2]).abs() > 1.0, "off centre the three-fold symmetry is broken: {f:?}");
}
