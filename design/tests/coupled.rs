//! The LQG design of the shipped scene's model: its Riccati solutions, its predictions against a
//! long run of the linear closed loop, the optimum against other controllers, careless settings.

use design::h2::ClosedLoop;
use design::lqg::synthesize;
use design::plant::{Instruments, of_scene};
use feedcore::scene::{Scene, ValidScene};
use nalgebra::DMatrix;

fn scene(edit: &str, with: &str) -> Result<ValidScene, feedcore::scene::SceneError> {
    let path = format!("{}/../scenes/lt50m_C_lqg.toml", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(edit.is_empty() || text.contains(edit), "{edit}");
    Scene::from_toml(&text.replacen(edit, with, 1), "lqg.toml")
}

/// Both Riccati equations are solved to round-off, their closed loops are stable, and the
/// filter's covariance returns to itself over the fixes' period.
#[test]
fn the_riccati_solutions_hold_by_their_residuals() {
    let s = scene("", "").unwrap();
    let cp = of_scene(&s).unwrap();
    let syn = synthesize(&cp.plant).unwrap();
    eprintln!(
        "{} states; regulator {:.1e} (radius {:.9}), filter {:.1e} (radius {:.9}), period {:.1e}",
        cp.plant.states(),
        syn.regulator.residual,
        syn.regulator.closed_loop_radius,
        syn.filter.residual,
        syn.filter.closed_loop_radius,
        syn.periodicity_gap
    );
    assert!(syn.regulator.residual < 1e-12 && syn.filter.residual < 1e-12);
    assert!(syn.regulator.closed_loop_radius < 1.0 && syn.filter.closed_loop_radius < 1.0);
    assert!(syn.periodicity_gap < 1e-10);
}

/// The predicted mean squares of the feed's error and its tilt against a seeded run of the same
/// linear closed loop (200 000 readings, 2000 s, the plant stepped twice a reading; within four
/// standard errors of its batch means).
#[test]
fn the_predictions_match_a_long_run_of_the_linear_loop() {
    let s = scene("", "").unwrap();
    let cp = of_scene(&s).unwrap();
    let syn = synthesize(&cp.plant).unwrap();
    let cl = ClosedLoop::new(&cp.plant, &syn).unwrap();
    let outputs = [cp.feed.clone(), cp.tilt.clone()];
    let run = design::simulate::run(
        &cp.plant,
        &syn,
        &outputs,
        design::simulate::Length { substeps: 2, warmup: 2000, samples: 200_000, batches: 20, seed: 5 },
    );
    for (i, (h, d)) in outputs.iter().enumerate() {
        let predicted = cl.mean_square(h, d);
        let (measured, se) = run.mean_square(i);
        eprintln!(
            "output {i}: predicted RMS {:.5e}, run {:.5e} (± {:.1e} relative)",
            predicted.sqrt(),
            measured.sqrt(),
            se / measured
        );
        assert!((measured - predicted).abs() < 4.0 * se, "output {i}: {measured} ± {se} against {predicted}");
        assert!(se < 0.05 * predicted, "output {i}: a run this long says little: {se} of {predicted}");
    }
}

/// What the bound bounds: another linear time-invariant controller (the LQG's gains moved) has a
/// larger cost — the weighted sum the LQG minimizes — on the same model.
#[test]
fn no_other_gain_has_a_lower_cost() {
    let s = scene("", "").unwrap();
    let cp = of_scene(&s).unwrap();
    let syn = synthesize(&cp.plant).unwrap();
    let nc = cp.plant.continuous_states();
    let m = cp.plant.inputs();
    // the cost as the plant's weight defines it: zᵀz with z = W^{1/2} (x_c, u)
    let root = cp.plant.weight.clone().cholesky().map(|c| c.l().transpose()).unwrap_or_else(|| {
        let e = cp.plant.weight.clone().symmetric_eigen();
        let mut v = e.eigenvectors.clone();
        for (j, l) in e.eigenvalues.iter().enumerate() {
            v.column_mut(j).scale_mut(l.max(0.0).sqrt());
        }
        v.transpose()
    });
    let (h, d) = (root.columns(0, nc).into_owned(), root.columns(nc, m).into_owned());
    let cost = |syn: &design::lqg::Synthesis| ClosedLoop::new(&cp.plant, syn).unwrap().mean_square(&h, &d);
    let best = cost(&syn);
    let mut seed = 3u64;
    for scale in [0.02, 0.1] {
        let mut other = syn.clone();
        let k = &mut other.controller.k;
        let bump = DMatrix::from_fn(k.nrows(), k.ncols(), |_, _| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        });
        *k += bump.component_mul(k) * scale;
        let c = cost(&other);
        eprintln!("gains moved by {scale}: cost {c:.6e} against {best:.6e}");
        assert!(c > best, "{c} vs {best}");
    }
}

/// Careless settings are refused, naming what to change: a reading without noise (a filter would
/// trust it without limit), an undamped mode (no stabilizing controller for what the platform
/// cannot reach), a fix that comes every 2.5 readings.
#[test]
fn careless_settings_are_refused_by_name() {
    let s = scene("accel_noise_density = 6e-4", "accel_noise_density = 0.0").unwrap();
    let e = Instruments::of(&s)
        .and_then(|i| design::plant::build(&s, s.control.as_ref().unwrap().lqg.as_ref().unwrap(), &i).map(|_| ()));
    let e = e.unwrap_err().to_string();
    assert!(e.contains("control.imu.accel_noise_density") && e.contains("[control.imu.filter]"), "{e}");
    let e = scene("damping_ratios = [", "damping_ratios = [0.0, ").unwrap_err().to_string();
    assert!(e.contains("control.lqg.damping_ratios") || e.contains("control.lqg.modes_hz"), "{e}");
    let text = std::fs::read_to_string(format!("{}/../scenes/lt50m_C_lqg.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let zero = text.replacen("damping_ratios = [", "damping_ratios = [0.0, ", 1).replacen(
        "modes_hz = [",
        "modes_hz = [0.3, ",
        1,
    );
    let zero = zero.replacen("cabin_shapes = [", "cabin_shapes = [[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ", 1);
    let e = Scene::from_toml(&zero, "lqg.toml").unwrap_err().to_string();
    assert!(e.contains("control.lqg.damping_ratios[0]") && e.contains("stabilizing"), "{e}");
    let e = scene("sample_rate_hz = 50.0", "sample_rate_hz = 40.0").unwrap_err().to_string();
    assert!(e.contains("control.sample_rate_hz") && e.contains("whole"), "{e}");
}
