//! The momentum-consistent start (`[motion] start = "consistent"`): right after t = 0 the
//! momentum of the cabin with everything on it is zero, computed here body by body from the
//! monolithic model's start velocities (not from the formula that set them).

use feedcore::scene::{Scene, Start, ValidScene};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};
use monolithic::model::Model;
use stewart::CABIN;

fn scene(name: &str, start: Start) -> ValidScene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR")))
        .unwrap()
        .edited(|s| s.motion.start = start)
        .unwrap()
}

/// Linear momentum and angular momentum about the cabin centre point of the cabin (with the
/// cables' end nodes riding on it) and the 13 Stewart bodies, world frame; and the linear
/// momentum of the Stewart bodies alone.
fn momentum(name: &str, start: Start) -> (Vec3, Vec3, Vec3) {
    let st = Model::build(&scene(name, start)).unwrap();
    let (m, v) = (&st.model, &st.velocity);
    let at = |o: usize| Vec3::new(v[o], v[o + 1], v[o + 2]);
    let p = st.config.cable.position;
    // the cabin: body frame mass properties about its centre point
    let rot = st.config.cable.orientation.to_rotation_matrix().into_inner();
    let body = &m.system.body;
    let c0 = m.body_offset(CABIN);
    let (vc, wc) = (at(c0), at(c0 + 3));
    let arm = rot * body.com;
    let v_com = vc + wc.cross(&arm);
    let mut linear = v_com * body.mass;
    let mut angular = arm.cross(&(v_com * body.mass)) + rot * body.inertia_com * rot.transpose() * wc;
    let mut payload = Vec3::zeros();
    for b in 0..BODIES {
        let o = m.body_offset(b);
        let (vb, wb) = (at(o), at(o + 3));
        let pose = &st.config.bodies[b];
        let rb: Mat3 = pose.orientation.to_rotation_matrix().into_inner();
        let mass = m.bodies[b].mass;
        linear += vb * mass;
        payload += vb * mass;
        angular += (pose.position - p).cross(&(vb * mass)) + rb * m.bodies[b].inertia_com * rb.transpose() * wb;
    }
    (linear, angular, payload)
}

#[test]
fn the_consistent_start_creates_no_momentum() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        // the abrupt start: the platform's momentum appears from nothing
        let (lin_a, ang_a, _) = momentum(name, Start::Abrupt);
        let (lin, ang, payload) = momentum(name, Start::Consistent);
        eprintln!(
            "{name}: abrupt |p| {:.4e} kg·m/s, |L| {:.4e} kg·m²/s; consistent |p| {:.2e}, |L| {:.2e}; Stewart bodies alone {:.4e}",
            lin_a.norm(),
            ang_a.norm(),
            lin.norm(),
            ang.norm(),
            payload.norm()
        );
        // the platform and the lower leg parts at about 0.02 m/s: ≈ 2 kg·m/s
        assert!(lin_a.norm() > 1.0 && ang_a.norm() > 1.0);
        assert!(lin.norm() <= 1e-12 * lin_a.norm(), "{name}: {lin:?}");
        assert!(ang.norm() <= 1e-12 * ang_a.norm(), "{name}: {ang:?}");
        // the Stewart bodies keep part of their momentum, the cabin carries the opposite
        assert!(payload.norm() > 0.2 * lin_a.norm());
    }
}

#[test]
fn the_ramped_and_the_abrupt_start_leave_the_cabin_at_rest() {
    for start in [Start::Abrupt, Start::Ramp] {
        let st = Model::build(&scene("lt50m_C.toml", start)).unwrap();
        let c0 = st.model.body_offset(CABIN);
        assert!(st.velocity[c0..c0 + 6].iter().all(|x| *x == 0.0), "{start:?}");
    }
}
