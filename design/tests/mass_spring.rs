//! The LQG design of a single mass–spring–damper against its closed form.
//!
//! `m ẍ + c ẋ + k x = u + w`, w white of intensity W, position measured with white noise of
//! intensity V, cost `q x² + ρ u²`. The continuous LQG's cost is `tr(Q P) + tr(X L V Lᵀ)` with
//! X and P the two Riccati solutions, both closed-form for a second-order plant by the symmetric
//! root locus: the regulated loop is `m ẍ + β ẋ + γ x = w` with `γ² = k² + q/ρ`,
//! `β² = c² + 2m(γ − k)`; the filter's error poles solve `s² + β_f s + γ_f` with
//! `γ_f² = a² + W/(V m²)`, `β_f² = b² + 2(γ_f − a)` (a = k/m, b = c/m). The sampled-data design
//! at period T (measurement noise V/T per sample) tends to it as T → 0, at second order (the
//! command made from the sample it follows, the estimate current).

use design::h2::ClosedLoop;
use design::lqg::{Measurement, Plant, synthesize};
use nalgebra::DMatrix;

/// The mass–spring–damper (mass, damping, stiffness), the cost's weights on the position and on
/// the force, the intensities of the disturbance force and of the position's measurement noise.
struct Case {
    m: f64,
    c: f64,
    k: f64,
    q: f64,
    rho: f64,
    w: f64,
    v: f64,
}

const CASE: Case = Case { m: 2.0, c: 0.4, k: 8.0, q: 100.0, rho: 0.01, w: 1.0, v: 1e-4 };

fn plant(t: f64) -> Plant {
    let Case { m, c, k, q, rho, w, v } = CASE;
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -k / m, -c / m]);
    let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / m]);
    let disturbance = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, w / (m * m)]);
    let weight = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![q, 0.0, rho]));
    Plant {
        period: t,
        a,
        b,
        w: disturbance,
        f: DMatrix::zeros(0, 2),
        e: DMatrix::zeros(0, 0),
        v: DMatrix::zeros(0, 0),
        phases: vec![Measurement {
            c: DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            r: DMatrix::from_element(1, 1, v / t),
        }],
        weight,
    }
}

/// The continuous LQG's optimal cost, closed form, both ways.
fn closed_form() -> (f64, f64) {
    let Case { m, c, k, q, rho, w, v } = CASE;
    let gamma = (k * k + q / rho).sqrt();
    let beta = (c * c + 2.0 * m * (gamma - k)).sqrt();
    let (k1, k2) = (gamma - k, beta - c);
    let (x12, x22) = (rho * m * k1, rho * m * k2);
    let (a, b) = (k / m, c / m);
    let x11 = a * x22 + b * x12 + x12 * x22 / (rho * m * m);
    let gf = (a * a + w / (v * m * m)).sqrt();
    let bf = (b * b + 2.0 * (gf - a)).sqrt();
    let l1 = bf - b;
    let l2 = gf - a - b * l1;
    let (p11, p12) = (v * l1, v * l2);
    let p22 = a * p11 + b * p12 + p11 * p12 / v;
    // tr(QP) + tr(X L V Lᵀ), L = (l1, l2)
    let one = q * p11 + v * (x11 * l1 * l1 + 2.0 * x12 * l1 * l2 + x22 * l2 * l2);
    // tr(X G W Gᵀ) + tr(P Kᵀ ρ K)
    let other = x22 * w / (m * m) + rho * (p11 * k1 * k1 + 2.0 * p12 * k1 * k2 + p22 * k2 * k2);
    (one, other)
}

fn sampled_cost(t: f64) -> f64 {
    let Case { q, rho, .. } = CASE;
    let p = plant(t);
    let syn = synthesize(&p).unwrap();
    assert!(syn.regulator.residual < 1e-10 && syn.filter.residual < 1e-10);
    let cl = ClosedLoop::new(&p, &syn).unwrap();
    let h = DMatrix::from_row_slice(2, 2, &[q.sqrt(), 0.0, 0.0, 0.0]);
    let d = DMatrix::from_row_slice(2, 1, &[0.0, rho.sqrt()]);
    cl.mean_square(&h, &d)
}

#[test]
fn the_sampled_lqg_tends_to_the_closed_form_at_second_order() {
    let (exact, other) = closed_form();
    assert!((exact - other).abs() < 1e-12 * exact, "{exact} vs {other}");
    let errors: Vec<f64> = [4e-3, 2e-3, 1e-3].iter().map(|&t| (sampled_cost(t) - exact) / exact).collect();
    eprintln!("closed form {exact:.6e}; relative error of the sampled design at T = 4, 2, 1 ms: {errors:?}");
    // holding the command and measuring at samples costs more than the continuous design
    assert!(errors.iter().all(|e| *e > 0.0), "{errors:?}");
    assert!(errors[2] < 1e-5, "{errors:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.6..4.4).contains(&ratio), "second order: {errors:?}");
    }
}

/// The predicted mean squares against a long seeded run of the same linear closed loop: within
/// four standard errors of the run's batch means.
#[test]
fn predicted_mean_squares_match_a_long_run_of_the_linear_loop() {
    let t = 2e-3;
    let p = plant(t);
    let syn = synthesize(&p).unwrap();
    let cl = ClosedLoop::new(&p, &syn).unwrap();
    let position = (DMatrix::from_row_slice(1, 2, &[1.0, 0.0]), DMatrix::zeros(1, 1));
    let force = (DMatrix::zeros(1, 2), DMatrix::from_element(1, 1, 1.0));
    let run = design::simulate::run(
        &p,
        &syn,
        &[position.clone(), force.clone()],
        design::simulate::Length { substeps: 4, warmup: 2000, samples: 400_000, batches: 20, seed: 11 },
    );
    for (i, (h, d)) in [position, force].iter().enumerate() {
        let predicted = cl.mean_square(h, d);
        let (measured, se) = run.mean_square(i);
        eprintln!("output {i}: predicted {predicted:.5e}, run {measured:.5e} ± {se:.1e}");
        assert!((measured - predicted).abs() < 4.0 * se, "output {i}: {measured} ± {se} vs {predicted}");
        assert!(se < 0.05 * predicted, "the run is long enough to say something: {se} of {predicted}");
    }
}
