//! Bad geometry and bad input give clear errors naming the leg and the time.

mod common;

use feedcore::Vec3;
use feedcore::scene::LEGS;
use stewart::{CabinMotion, Stewart, StewartError};

#[test]
fn legs_too_short_for_the_stroke_are_rejected_at_the_start() {
    let scene = common::scene("lt50m_C")
        .edited(|scene| {
            scene.stewart.upper_leg.length_m = 1.5; // a leg can be no shorter than its longer part
        })
        .unwrap();
    let err = Stewart::from_scene(&scene).unwrap_err();
    let StewartError::LegLength { leg, time, length, shortest, .. } = err.clone() else { panic!("{err}") };
    assert_eq!((time, shortest), (0.0, 1.5));
    assert!(length < shortest && (1..=LEGS).contains(&leg));
    let text = err.to_string();
    assert!(text.contains(&format!("leg {leg}")) && text.contains("t = 0 s") && text.contains("shorter"), "{text}");
}

#[test]
fn a_leg_too_long_somewhere_on_the_circle_is_found_with_its_time() {
    let scene = common::scene("lt50m_C");
    let st = Stewart::from_scene(&scene).unwrap();
    // the longest leg over one revolution, sampled finely
    let end = st.path().revolution_time().unwrap();
    let longest = (0..=10000)
        .map(|i| st.relative(end * i as f64 / 10000.0).unwrap().strokes.iter().map(|s| s.length).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    let start_longest = st.relative(0.0).unwrap().strokes.iter().map(|s| s.length).fold(0.0, f64::max);
    assert!(longest > start_longest + 1e-3);
    // parts that reach all but 1 mm of it (upper 0.8 m stays, the lower part is shortened)
    let scene = scene.edited(|s| s.stewart.lower_leg.length_m = longest - 1e-3 - s.stewart.upper_leg.length_m).unwrap();
    let err = Stewart::from_scene(&scene).unwrap_err();
    let StewartError::LegLength { leg, time, length, longest: limit, .. } = err.clone() else { panic!("{err}") };
    assert!(time > 0.0 && length > limit);
    // the named leg really is too long then, by a direct computation
    let g = scene.stewart_geometry();
    let phi = 0.2 * time;
    let center = g.nominal_center + Vec3::new(phi.cos(), phi.sin(), 0.0) * 0.1;
    assert!((g.leg_vector(leg - 1, &center).norm() - length).abs() < 1e-12);
    assert!(err.to_string().contains(&format!("leg {leg} at t = {time} s")), "{err}");
    println!("{err}");
}

#[test]
fn a_leg_along_its_hooke_axis_is_singular() {
    let scene = common::scene("lt50m_C");
    let mut g = scene.stewart_geometry();
    // put leg 3's platform joint so that the leg runs along its first Hooke axis at the start
    let k = 2;
    g.platform_joints[k] = g.base_joints[k] + g.hooke_first_axis(k) * 1.2 - g.start_center;
    let err = Stewart::new(g, &scene.motion, scene.gravity()).unwrap_err();
    assert!(matches!(err, StewartError::HookeSingular { leg: 3, time: 0.0, .. }), "{err}");
    assert!(err.to_string().contains("leg 3 at t = 0 s"));
}

#[test]
fn parallel_legs_are_a_singular_pose() {
    // platform joints right below the base joints: all six legs parallel
    let scene = common::scene("lt50m_C")
        .edited(|s| {
            s.stewart.platform_joints = s.stewart.base_joints.clone();
            s.stewart.platform_joints.z_m = 0.0;
        })
        .unwrap();
    let err = Stewart::from_scene(&scene).unwrap_err();
    assert!(matches!(err, StewartError::SingularPose { time: 0.0, .. }), "{err}");
    assert!(err.to_string().contains("singular pose"));
}

#[test]
fn non_finite_inputs_are_named() {
    let scene = common::scene("lt50m_C");
    let st = Stewart::from_scene(&scene).unwrap();
    let cabin = common::cabin_at_target(&scene);
    let err = st.wrench(&cabin, f64::NAN).unwrap_err();
    assert!(err.to_string().contains("time = NaN"), "{err}");
    let bad = CabinMotion { angular_velocity: Vec3::new(0.0, f64::INFINITY, 0.0), ..cabin };
    for err in [st.wrench(&bad, 1.0).unwrap_err(), st.evaluate(&bad, 1.0).unwrap_err()] {
        assert!(err.to_string().contains("cabin angular_velocity"), "{err}");
    }
    let err = Stewart::new(scene.stewart_geometry(), &scene.motion, Vec3::new(0.0, 0.0, f64::NAN)).unwrap_err();
    assert!(err.to_string().contains("gravity"));
}
