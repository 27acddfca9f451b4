//! The monolithic eq. (7) reference model: rest, constraint drift, and convergence in h.

use feedcore::scene::{Scene, ValidScene};
use monolithic::Monolithic;

fn scene(name: &str) -> ValidScene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// With the platform held still the system starts in equilibrium and stays there.
#[test]
fn platform_held_still_stays_at_rest() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name)
            .edited(|s| {
                s.motion.speed_m_s = 0.0;
            })
            .unwrap();
        let mut m = Monolithic::new(&s).unwrap();
        let p0 = m.sample().cabin.position;
        let mut drift = 0.0f64;
        for _ in 0..10_000 {
            m.step(0.01).unwrap();
            drift = drift.max((m.sample().cabin.position - p0).norm());
        }
        eprintln!("{name}: drift over 100 s {drift:.2e} m");
        assert!(drift <= 1e-9, "{name}: drift {drift:.2e} m");
    }
}

/// Index 3: the position constraints hold at every step to the Newton tolerance.
#[test]
fn constraints_hold_over_100_s() {
    let mut m = Monolithic::new(&scene("lt50m_B.toml")).unwrap();
    let mut worst = 0.0f64;
    for _ in 0..10_000 {
        m.step(0.01).unwrap();
        worst = worst.max(m.sample().constraint_residual);
    }
    eprintln!("largest constraint residual over 100 s: {worst:.2e}");
    assert!(worst <= 1e-9, "constraint drift {worst:.2e}");
}

/// Halving h cuts the error against a fine-step solution by about four (largest error of the
/// cabin-centre position over 3 s, sampled every 0.04 s).
#[test]
fn second_order_in_the_step_size() {
    let s = scene("lt50m_C.toml")
        .edited(|s| {
            s.motion.start = feedcore::scene::Start::Ramp; // smooth start: the error is the integrator's
            s.motion.ramp_time_s = 1.0;
            s.solver.newton_tol = 1e-13; // the integrator's error, not the solver's
        })
        .unwrap();
    let run = |h: f64| {
        let mut m = Monolithic::new(&s).unwrap();
        let per_sample = (0.04 / h).round() as usize;
        (0..75)
            .map(|_| {
                for _ in 0..per_sample {
                    m.step(h).unwrap();
                }
                m.sample().cabin.position
            })
            .collect::<Vec<_>>()
    };
    let reference = run(0.01 / 16.0);
    let errors: Vec<f64> = [0.02, 0.01, 0.005]
        .iter()
        .map(|h| run(*h).iter().zip(&reference).map(|(p, r)| (p - r).norm()).fold(0.0, f64::max))
        .collect();
    eprintln!("errors at h = 0.02, 0.01, 0.005: {errors:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.3..4.7).contains(&ratio), "error ratio {ratio:.2}");
    }
}
