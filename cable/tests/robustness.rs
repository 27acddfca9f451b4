//! Careless input to the cable–cabin dynamics: a run either goes on with finite numbers or stops
//! with an error that names the time and what went wrong — never NaN reported as success.

mod common;

use cable::dynamics::{CableFault, Dynamics, DynamicsError, DynamicsOptions};
use cable::model::{CableCabin, ModelError, Payload};
use feedcore::genalpha::{OptionsError, StepError};
use nalgebra::Vector6;

/// Tolerances that would let Newton accept unconverged steps are refused: by the scene, naming
/// the key, and by the dynamics itself when a caller builds it with its own options.
#[test]
fn loose_newton_tolerances_are_refused() {
    let scene = common::scene("lt50m_C_cable_only.toml");
    let model = CableCabin::build(&scene, 0).unwrap();
    let sys = model.system(Payload::Locked);
    for tol in [1e300, 0.1, 1e-3] {
        let e = scene.edited(|s| s.solver.newton_tol = tol).expect_err("the scene accepted it");
        assert_eq!(e.key, "solver.newton_tol", "{e}");

        let options = DynamicsOptions { rho_inf: 0.9, newton_tol: tol, newton_max_iter: 40 };
        let (eq, v) = (model.equilibrium_config(), vec![0.0; sys.dim()]);
        match Dynamics::new(sys.clone(), eq, v, 0.0, &Vector6::zeros(), options) {
            Err(e @ DynamicsError::Options(OptionsError::ToleranceTooLoose { .. })) => {
                let text = e.to_string();
                eprintln!("{text}");
                assert!(text.contains("newton_tol") && text.contains(&format!("{tol:e}")), "{text}");
            }
            Err(other) => panic!("newton_tol = {tol}: unexpected error {other}"),
            Ok(_) => panic!("newton_tol = {tol} was accepted"),
        }
    }
}

/// A wrench that is not a number stops the step, naming the wrench and the time.
#[test]
fn a_nan_wrench_is_refused() {
    let model = CableCabin::build(&common::scene("lt50m_C_cable_only.toml"), 0).unwrap();
    let mut dy = model.dynamics(Payload::Locked, 0.0).unwrap();
    dy.step(0.01, &Vector6::zeros()).unwrap();
    let bad = Vector6::new(0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0);
    let e = dy.step(0.01, &bad).unwrap_err();
    assert!(
        matches!(&e, DynamicsError::Stopped { reason: StepError::Model(CableFault::Wrench(_)), time } if (time - 0.02).abs() < 1e-12),
        "{e}"
    );
    assert!(e.to_string().contains("t = 0.020000 s") && e.to_string().contains("wrench is not finite"), "{e}");
    // the state is as before the refused step
    assert!((dy.time() - 0.01).abs() < 1e-15);
}

/// A wrench of 1e300 N drives the motion beyond any finite number: the run stops at the step
/// where that happens, naming the quantity, instead of reporting NaN positions.
#[test]
fn a_diverging_motion_stops_with_the_time_and_the_quantity() {
    let model = CableCabin::build(&common::scene("lt50m_C_cable_only.toml"), 0).unwrap();
    let mut dy = model.dynamics(Payload::Locked, 0.0).unwrap();
    let huge = Vector6::new(1e300, 0.0, 0.0, 0.0, 0.0, 0.0);
    let mut stopped = None;
    for k in 1..=100 {
        match dy.step(0.01, &huge) {
            Ok(_) => {
                let c = dy.cabin();
                assert!(c.non_finite().is_none(), "step {k} reported a non-finite cabin motion as success");
            }
            Err(e) => {
                stopped = Some(e);
                break;
            }
        }
    }
    let e = stopped.expect("a 1e300 N wrench must stop the run");
    eprintln!("{e}");
    let text = e.to_string();
    assert!(text.contains("stopped at t =") && (text.contains("NaN") || text.contains("inf")), "{text}");
}

/// A net of other than six cables cannot be form-found (six lengths balance the cabin's six
/// equations): refused with the count, not a panic on the six-column Jacobian.
#[test]
fn a_net_of_eight_cables_is_refused_by_name() {
    let path = format!("{}/../scenes/lt50m_C_cable_only.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let eight = "angle_deg = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]";
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    // the anchors' and the attachments' rings (the first two), both of eight
    for line in lines.iter_mut().filter(|l| l.starts_with("angle_deg")).take(2) {
        *line = eight.to_owned();
    }
    let scene = feedcore::scene::Scene::from_toml(&lines.join("\n"), "eight.toml").unwrap();
    assert_eq!(scene.cable_count(), 8);
    match CableCabin::build(&scene, 0) {
        Err(e @ ModelError::Statics(cable::statics::StaticsError::CableCount { count: 8 })) => {
            assert!(e.to_string().contains("six cables") && e.to_string().contains('8'), "{e}");
        }
        Err(other) => panic!("unexpected error {other}"),
        Ok(_) => panic!("eight cables were form-found"),
    }
}
