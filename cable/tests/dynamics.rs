//! Time integration against conservation laws, closed-form motions and its own convergence.

mod common;

use cable::damping::{rayleigh_coefficients, rayleigh_matrix};
use cable::dynamics::{Dynamics, DynamicsOptions};
use cable::modes::modes;
use cable::net::CableNet;
use cable::shooting::CableSpec;
use cable::system::{Coefficients, Config, Support, System};
use common::{equilibrium, scene};
use feedcore::rigid::MassProperties;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::Vector6;
use std::f64::consts::PI;

fn options(rho_inf: f64) -> DynamicsOptions {
    DynamicsOptions { rho_inf, newton_tol: 1e-10, newton_max_iter: 25 }
}

/// Started at the static equilibrium with no disturbance, the cabin stays where it is.
#[test]
fn equilibrium_stays_at_rest() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let (net, eq) = equilibrium(&s);
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let cfg = sys.config_from(&eq);
        let n = sys.dim();
        let mut dy = Dynamics::new(sys, cfg, vec![0.0; n], 0.0, &Vector6::zeros(), options(0.9)).unwrap();
        let p0 = dy.cabin().position;
        let t = std::time::Instant::now();
        let (mut iters, mut facts, mut drift) = (0, 0, 0.0f64);
        for _ in 0..10_000 {
            let st = dy.step(0.01, &Vector6::zeros()).unwrap();
            iters += st.iterations;
            facts += st.factorizations;
            drift = drift.max((dy.cabin().position - p0).norm());
        }
        eprintln!("{name}: drift {drift:.2e} m, {iters} iterations, {facts} factorizations, {:?}", t.elapsed());
        assert!(drift <= 1e-9, "drift {drift:.2e} m");
    }
}

/// The LT50m net at C with the Stewart locked, at its equilibrium.
fn lt50m_c() -> (System, Config) {
    let s = scene("lt50m_C.toml");
    let (net, eq) = equilibrium(&s);
    let sys = System::new(net, eq.lengths(), true, Support::Free);
    let cfg = sys.config_from(&eq);
    (sys, cfg)
}

/// Mass-weighted projection of the displacement from `eq` onto a mass-normalized mode shape.
fn modal_coordinate(sys: &System, eq: &Config, now: &Config, shape: &[f64]) -> f64 {
    let n = sys.dim();
    let c0 = sys.cabin_offset();
    let mut du = vec![0.0; n];
    for (k, (x, x0)) in now.nodes.iter().zip(&eq.nodes).enumerate() {
        du[3 * k..3 * k + 3].copy_from_slice((x - x0).as_slice());
    }
    du[c0..c0 + 3].copy_from_slice((now.position - eq.position).as_slice());
    let rot = (now.orientation * eq.orientation.inverse()).scaled_axis();
    du[c0 + 3..c0 + 6].copy_from_slice(rot.as_slice());
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut m = sys.new_matrix();
    sys.assemble(eq, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut m, Coefficients::MASS)));
    let mut mu = vec![0.0; n];
    m.mul_add(&du, &mut mu);
    mu.iter().zip(shape).map(|(a, b)| a * b).sum()
}

/// Largest drift of the total energy over `steps` steps of size `h` after a kick of the cabin
/// along x (`speed`, m/s), relative to the vibration energy (total minus equilibrium).
fn energy_drift(h: f64, steps: usize, speed: f64) -> f64 {
    let (sys, eq) = lt50m_c();
    let n = sys.dim();
    let e_eq = sys.energy(&eq, &vec![0.0; n], &eq).total();
    let mut v = vec![0.0; n];
    v[sys.cabin_offset()] = speed;
    let reference = eq.clone();
    // a tight Newton tolerance, so that what is measured is the integrator, not the solver
    let tight = DynamicsOptions { newton_tol: 1e-13, ..options(1.0) };
    let mut dy = Dynamics::new(sys, eq, v, 0.0, &Vector6::zeros(), tight).unwrap();
    let e0 = dy.energy(&reference).total();
    let vib = e0 - e_eq;
    let mut worst = 0.0f64;
    for _ in 0..steps {
        dy.step(h, &Vector6::zeros()).unwrap();
        worst = worst.max((dy.energy(&reference).total() - e0).abs() / vib);
    }
    worst
}

/// Undamped, ρ∞ = 1 (the trapezoidal rule). The rule conserves energy exactly only for linear
/// systems; on the geometrically nonlinear net it leaves a bounded O(h²) error that grows with
/// the amplitude. A kick of 2 mm/s (cabin amplitude ≈ 0.7 mm, the scale of the paper's
/// response): 1e-5 of the vibration energy at h = 0.01 s, below 1e-6 at h = 0.0025 s; halving h
/// cuts it by four, and it saturates (300 s: as after 100 s; no leak, no pumping).
#[test]
fn undamped_free_vibration_conserves_energy() {
    let speed = 2e-3;
    let d1 = energy_drift(0.01, 1000, speed);
    let d2 = energy_drift(0.005, 2000, speed);
    let d4 = energy_drift(0.0025, 4000, speed);
    let (d100, d300) = (energy_drift(0.01, 10_000, speed), energy_drift(0.01, 30_000, speed));
    let small = energy_drift(0.01, 1000, speed / 4.0);
    eprintln!(
        "energy drift over 10 s: h = 0.01: {d1:.2e}, 0.005: {d2:.2e}, 0.0025: {d4:.2e}; at 0.01 over 100 s: {d100:.2e}, over 300 s: {d300:.2e}; quarter amplitude: {small:.2e}"
    );
    assert!(d4 < 1e-6, "h = 0.0025: drift {d4:.2e}");
    assert!(
        (3.0..5.0).contains(&(d1 / d2)) && (3.0..5.0).contains(&(d2 / d4)),
        "drift must fall as h²: {d1:.2e} {d2:.2e} {d4:.2e}"
    );
    assert!(d300 < 1.1 * d100, "the drift must stay bounded: {d300:.2e} after 300 s vs {d100:.2e} after 100 s");
    assert!(
        small < 0.5 * d1,
        "the drift must shrink with the amplitude (it is the nonlinearity): {small:.2e} vs {d1:.2e}"
    );
}

/// With Rayleigh damping fitted at modes 1 and 6, a free vibration in mode 1 decays at
/// exp(−ζ ω₁ t), ζ = 0.005.
#[test]
fn rayleigh_damped_mode_decays_at_the_fitted_rate() {
    let (mut sys, eq) = lt50m_c();
    let md = modes(&sys, &eq, 6).unwrap();
    let (w1, w6) = (2.0 * PI * md.frequencies_hz[0], 2.0 * PI * md.frequencies_hz[5]);
    let zeta = 0.005;
    let (alpha, beta) = rayleigh_coefficients(zeta, w1, w6);
    sys.damping = Some(cable::chain_matrix::LinkedChain::new(rayleigh_matrix(&sys, &eq, alpha, beta)));
    // modal damping ratios of modes 1 and 6 from the matrix itself
    for (k, w) in [(0, w1), (5, w6)] {
        let mut cphi = vec![0.0; sys.dim()];
        sys.damping.as_ref().unwrap().mul_add(&md.shapes[k], &mut cphi);
        let z: f64 = cphi.iter().zip(&md.shapes[k]).map(|(a, b)| a * b).sum::<f64>() / (2.0 * w);
        assert!((z - zeta).abs() < 1e-9, "mode {}: ζ = {z}", k + 1);
    }
    // start displaced along mode 1, at rest
    let amplitude = 1e-3;
    let du: Vec<f64> = md.shapes[0].iter().map(|x| x * amplitude).collect();
    let mut start = eq.clone();
    start.set_displaced(&eq, &du);
    let n = sys.dim();
    let shape = md.shapes[0].clone();
    let sys_copy = sys.clone();
    let mut dy = Dynamics::new(sys, start, vec![0.0; n], 0.0, &Vector6::zeros(), options(1.0)).unwrap();
    // sample the modal coordinate and fit the envelope through successive maxima
    let h = 0.005;
    let mut peaks: Vec<(f64, f64)> = Vec::new();
    let (mut q_prev2, mut q_prev) = (f64::NAN, modal_coordinate(&sys_copy, &eq, dy.config(), &shape));
    for k in 0..6000 {
        dy.step(h, &Vector6::zeros()).unwrap();
        let q = modal_coordinate(&sys_copy, &eq, dy.config(), &shape);
        if q_prev > q && q_prev > q_prev2 {
            peaks.push((h * k as f64, q_prev));
        }
        q_prev2 = q_prev;
        q_prev = q;
    }
    let (t0, p0) = peaks[0];
    let (t1, p1) = peaks[peaks.len() - 1];
    let rate = -(p1 / p0).ln() / (t1 - t0);
    let expected = zeta * w1;
    eprintln!("{} peaks over {:.1} s: decay rate {rate:.5} 1/s, ζω₁ = {expected:.5} 1/s", peaks.len(), t1 - t0);
    assert!((rate - expected).abs() < 0.02 * expected, "decay rate {rate} vs {expected}");
}

/// Halving h cuts the error against a fine-step solution by about four (second order).
#[test]
fn second_order_in_the_step_size() {
    let (sys, eq) = lt50m_c();
    let n = sys.dim();
    // a smooth wrench that starts from zero with zero slope
    let wrench = |t: f64| {
        let s = (0.7 * t).sin().powi(2);
        Vector6::new(80.0 * s, -40.0 * s, 30.0 * s, 10.0 * s, -5.0 * s, 8.0 * s)
    };
    let run = |h: f64| {
        let mut dy = Dynamics::new(sys.clone(), eq.clone(), vec![0.0; n], 0.0, &wrench(0.0), options(0.9)).unwrap();
        let steps = (2.0 / h).round() as usize;
        for k in 0..steps {
            dy.step(h, &wrench(h * (k + 1) as f64)).unwrap();
        }
        let c = dy.cabin();
        (c.position, c.orientation)
    };
    let (p_ref, q_ref) = run(0.01 / 32.0);
    let err = |h: f64| {
        let (p, q) = run(h);
        (p - p_ref).norm() + (q * q_ref.inverse()).angle()
    };
    let errors: Vec<f64> = [0.02, 0.01, 0.005].iter().map(|h| err(*h)).collect();
    eprintln!("errors at h = 0.02, 0.01, 0.005: {errors:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.5..4.6).contains(&ratio), "error ratio {ratio:.2}");
    }
}

/// A body hung on one (light, stiff) cable from its centre of mass swings as a simple pendulum:
/// period 2π √(L/g), L the stretched cable length.
#[test]
fn pendulum_period() {
    for elements in [1, 4] {
        let (g, m, l0, ea, mu) = (9.81, 100.0, 5.0, 1.0e9, 1e-4);
        let anchor = Vec3::new(0.0, 0.0, 10.0);
        let net = CableNet {
            anchors: vec![anchor],
            attachments: vec![Vec3::zeros()],
            spec: CableSpec { elements, ea, mass_per_length: mu, gravity: Vec3::new(0.0, 0.0, -g) },
            cabin: MassProperties { mass: m, com: Vec3::zeros(), inertia_com: Mat3::identity() * 2.0 },
            payload: MassProperties::ZERO,
        };
        let sys = System::new(net, vec![l0], true, Support::Free);
        // hanging equilibrium: element j (from the top) carries the body and the nodes below it
        let (le, mn) = (l0 / elements as f64, mu * l0 / elements as f64);
        let body = sys.body.mass;
        let mut z = anchor.z;
        let mut nodes = Vec::new();
        for j in 0..elements {
            let below = body + mn * (elements - 1 - j) as f64;
            z -= le * (1.0 + below * g / ea);
            if j + 1 < elements {
                nodes.push(Vec3::new(0.0, 0.0, z));
            }
        }
        let length = anchor.z - z;
        let cfg = Config { nodes, position: Vec3::new(0.0, 0.0, z), orientation: Quat::identity() };
        let n = sys.dim();
        let mut v = vec![0.0; n];
        let c0 = sys.cabin_offset();
        v[c0] = 0.005; // a small swing in x
        for k in 0..elements - 1 {
            v[3 * k] = 0.005 * (k + 1) as f64 / elements as f64;
        }
        let mut dy = Dynamics::new(sys, cfg, v, 0.0, &Vector6::zeros(), options(1.0)).unwrap();
        // upward zero crossings of x
        let h = 0.002;
        let mut crossings = Vec::new();
        let mut x_prev = 0.0;
        for k in 0..20_000 {
            dy.step(h, &Vector6::zeros()).unwrap();
            let x = dy.cabin().position.x;
            if x_prev < 0.0 && x >= 0.0 {
                let t = h * k as f64 + h * (-x_prev) / (x - x_prev);
                crossings.push(t);
            }
            x_prev = x;
        }
        let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let exact = 2.0 * PI * (length / g).sqrt();
        eprintln!("{elements} element(s): period {period:.6} s, 2π√(L/g) = {exact:.6} s");
        assert!((period - exact).abs() < 2e-5 * exact, "period {period} vs {exact}");
    }
}
