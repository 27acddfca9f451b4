//! Careless input to the monolithic model: every run either goes on with finite numbers or
//! stops with an error naming the time and the reason (issue 10's cases).

use feedcore::scene::{Scene, ValidScene};
use monolithic::{Monolithic, MonolithicError};

fn scene(name: &str) -> ValidScene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// Runs `steps` steps; every sample must be finite until the run stops, if it does.
fn run(s: &ValidScene, steps: usize) -> Result<f64, MonolithicError> {
    let mut m = Monolithic::new(s)?;
    for _ in 0..steps {
        m.step(0.01)?;
        let sample = m.sample();
        assert!(sample.cabin.non_finite().is_none(), "non-finite cabin motion at t = {}", sample.time);
        assert!(sample.wrench.iter().chain(&sample.actuator_forces).all(|x| x.is_finite()));
        assert!(sample.constraint_residual.is_finite());
    }
    Ok(m.time())
}

#[test]
fn loose_newton_tolerances_are_refused() {
    for tol in [1e300, 0.1, 1e-4] {
        let e = scene("lt50m_C.toml")
            .edited(|s| s.solver.newton_tol = tol)
            .err()
            .unwrap_or_else(|| panic!("newton_tol = {tol} was accepted"));
        eprintln!("{e}");
        assert_eq!(e.key, "solver.newton_tol", "{e}");
        assert!(e.reason.contains("must lie in [1e-14, 1e-6]"), "{e}");
    }
}

/// Motions the platform cannot follow stop with the time and the reason, not with NaN.
#[test]
fn impossible_motions_stop_with_time_and_reason() {
    for (what, edit) in [
        ("speed 2e7 m/s", &(|s: &mut Scene| s.motion.speed_m_s = 2e7) as &dyn Fn(&mut Scene)),
        ("radius 1e-10 m", &|s: &mut Scene| s.motion.radius_m = 1e-10),
    ] {
        let s = scene("lt50m_B.toml").edited(edit).unwrap();
        match run(&s, 300) {
            Ok(t) => eprintln!("{what}: ran to t = {t} s with finite results"),
            Err(e) => {
                eprintln!("{what}: {e}");
                assert!(e.time().is_some() && e.to_string().contains("stopped at t ="), "{e}");
            }
        }
    }
}
