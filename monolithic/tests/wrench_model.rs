//! `[analyses] wrench = "inertial_only"`: the platform's weight shift left out. Checked against
//! an independent static solution: with a slow start the cabin follows the inertial wrench of
//! the platform on a fixed cabin (the Stewart model with gravity off) through the cable net's
//! condensed static stiffness, `K_c δ = W_inertial(t)`.

use cable::model::{CableCabin, Payload};
use cable::modes::tangent;
use feedcore::Vec3;
use feedcore::rigid::RigidMotion;
use feedcore::scene::{Scene, Start, ValidScene, WrenchModel};
use monolithic::Monolithic;
use nalgebra::{DMatrix, Vector6};
use stewart::Stewart;

fn scene(name: &str) -> ValidScene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// The cable net's stiffness condensed onto the cabin (free nodes in static equilibrium), with
/// the platform riding on the cabin as at its start.
fn condensed_stiffness(s: &ValidScene) -> (nalgebra::Matrix6<f64>, Vec3) {
    let model = CableCabin::build(s, 0).unwrap();
    let sys = model.system(Payload::Locked);
    let k: DMatrix<f64> = tangent(&sys, &model.equilibrium_config()).stiffness.to_dense();
    let n = k.nrows() - 6;
    let knn = k.view((0, 0), (n, n)).into_owned();
    let knc = k.view((0, n), (n, 6)).into_owned();
    let kcn = k.view((n, 0), (6, n)).into_owned();
    let x = knn.lu().solve(&knc).unwrap();
    let kc = k.view((n, n), (6, 6)) - kcn * x;
    (nalgebra::Matrix6::from_iterator(kc.iter().copied()), model.equilibrium.position)
}

#[test]
fn without_the_weight_shift_the_cabin_follows_the_inertial_wrench_statically() {
    let s = scene("lt50m_C.toml")
        .edited(|s| {
            s.analyses.wrench = WrenchModel::InertialOnly;
            s.motion.start = Start::Ramp;
            s.motion.ramp_time_s = 10.0;
        })
        .unwrap();
    let (kc, p0) = condensed_stiffness(&s);
    let kc_inv = kc.try_inverse().unwrap();
    let stewart = Stewart::from_scene(&s).unwrap();
    let q0 = nalgebra::UnitQuaternion::identity();
    let static_disp = |t: f64| {
        let w = stewart.relative(t).unwrap().wrench(&RigidMotion::at_rest(p0, q0), &Vec3::zeros());
        let w6 = Vector6::new(w.force.x, w.force.y, w.force.z, w.moment.x, w.moment.y, w.moment.z);
        let d = kc_inv * w6;
        Vec3::new(d[0], d[1], d[2]) * 1e3
    };
    let mut m = Monolithic::new(&s).unwrap();
    let (mut worst, mut peak) = (0.0f64, 0.0f64);
    let h = 0.01;
    for k in 1..=6000 {
        m.step(h).unwrap();
        let t = k as f64 * h;
        if t >= 30.0 {
            let d = (m.sample().cabin.position - p0) * 1e3;
            let e = static_disp(t);
            worst = worst.max((d - e).norm());
            peak = peak.max(e.norm());
        }
    }
    eprintln!("static inertial response {peak:.4e} mm; run − static ≤ {worst:.3e} mm");
    assert!(peak > 5e-3 && peak < 0.05, "{peak}");
    assert!(worst <= 0.1 * peak, "{worst:e} against {peak:e}");
    // with the weight shift the response is three orders larger
    let full = scene("lt50m_C.toml")
        .edited(|full| {
            full.motion.start = Start::Ramp;
            full.motion.ramp_time_s = 10.0;
        })
        .unwrap();
    let mut m = Monolithic::new(&full).unwrap();
    for _ in 0..3000 {
        m.step(h).unwrap();
    }
    assert!((m.sample().cabin.position - p0).norm() * 1e3 > 100.0 * peak);
}

/// With the platform held still nothing moves the cabin: under either wrench model it rests at
/// the static equilibrium the form finding put at the target pose (cable 4 nearly slack at B),
/// to the solver's tolerance, over 1 s.
#[test]
fn held_still_either_wrench_model_rests_at_the_static_equilibrium() {
    for wrench in [WrenchModel::Full, WrenchModel::InertialOnly] {
        let s = scene("lt50m_B.toml")
            .edited(|s| {
                s.motion.speed_m_s = 0.0;
                s.analyses.wrench = wrench;
            })
            .unwrap();
        let target = s.target_position();
        let mut m = Monolithic::new(&s).unwrap();
        let mut drift = 0.0f64;
        for _ in 0..100 {
            m.step(0.01).unwrap();
            drift = drift.max((m.sample().cabin.position - target).norm());
        }
        assert!(drift < 1e-9, "{wrench:?}: {drift:e} m");
    }
}
