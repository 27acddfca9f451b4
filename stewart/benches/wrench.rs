//! Cost of the calls the co-simulation makes every step: the wrench on the cabin, with and
//! without its Jacobians, and of the full joint-reaction solve and the constraint equations.

use std::hint::black_box;

use feedcore::benchkit::bench;
use feedcore::scene::Scene;
use feedcore::{Quat, Vec3};
use stewart::{CONSTRAINTS, CabinMotion, ConstraintRow, Stewart};

fn main() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/lt50m_B.toml");
    let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    let st = Stewart::from_scene(&scene).unwrap();
    let cabin = CabinMotion {
        position: scene.target_position(),
        orientation: scene.target_orientation() * Quat::from_scaled_axis(Vec3::new(1e-3, -2e-3, 5e-4)),
        velocity: Vec3::new(1e-3, -2e-3, 4e-4),
        angular_velocity: Vec3::new(2e-4, 1e-4, -3e-4),
        acceleration: Vec3::new(0.01, 0.02, -0.005),
        angular_acceleration: Vec3::new(-0.002, 0.001, 0.003),
    };
    // a different time each call, as in a run (nothing cached between calls)
    let mut t = 0.0;
    let mut next = || {
        t += 0.01;
        t
    };
    println!("Stewart model, scene {}", scene.name);
    bench("relative kinematics (13 bodies)", 1.0, || st.relative(black_box(next())).unwrap());
    bench("wrench", 1.0, || st.wrench(black_box(&cabin), black_box(next())).unwrap());
    bench("wrench + Jacobians", 1.0, || st.wrench_with_jacobians(black_box(&cabin), black_box(next())).unwrap());
    let rel = st.relative(1.0).unwrap();
    let g = st.gravity();
    bench("wrench + Jacobians, relative state reused", 1.0, || {
        rel.wrench_with_jacobians(black_box(&cabin), black_box(&g))
    });
    bench("evaluate (78 multipliers, reactions)", 1.0, || st.evaluate(black_box(&cabin), black_box(next())).unwrap());
    let system = st.system_motion(&cabin, 1.0).unwrap();
    let mut rows = [ConstraintRow::EMPTY; CONSTRAINTS];
    bench("constraint equations (78 rows)", 1.0, || {
        st.constraints(black_box(&system), black_box(1.0), &mut rows).unwrap();
        rows[0].value
    });
    let strokes = st.strokes(1.0).unwrap();
    bench("joints: Φ, Φ_q, γ (78 rows, strokes given)", 1.0, || {
        st.joints().evaluate(black_box(&system), &strokes, &mut rows);
        rows[0].value
    });
    bench("joints: Φ, Φ_q only (a Newton iteration)", 1.0, || {
        st.joints().evaluate_positions(black_box(&system), &strokes, &mut rows);
        rows[0].value
    });
    bench("strokes ℓ_k(t) alone", 1.0, || st.strokes(black_box(next())).unwrap());
}
