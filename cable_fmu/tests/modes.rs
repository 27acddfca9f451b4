//! Natural frequencies against closed-form references, and the static residual of the
//! form-found equilibrium measured by the dynamic model's own force assembly.

mod common;

use cable_fmu::modes::modes;
use cable_fmu::net::CableNet;
use cable_fmu::shooting::CableSpec;
use cable_fmu::system::{Config, Support, System};
use common::{equilibrium, scene};
use feedcore::rigid::MassProperties;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::Vector6;
use std::f64::consts::PI;

fn hz(omega: f64) -> f64 {
    omega / (2.0 * PI)
}

/// The form-found pose is an equilibrium of the finite-element model: the residual of every
/// node and of the cabin is at most 1e-8 of the suspended weight.
#[test]
fn static_residual_at_the_found_pose() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let (net, eq) = equilibrium(&s);
        let weight = net.suspended().mass * 9.81;
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let n = sys.dim();
        let mut r = vec![0.0; n];
        sys.assemble(&sys.config_from(&eq), &vec![0.0; n], &vec![0.0; n], &Vector6::zeros(), &mut r, None);
        let worst = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        eprintln!("{name}: largest residual {worst:.2e} N of weight {weight:.1} N");
        assert!(worst <= 1e-8 * weight);
    }
}

/// A taut cable without gravity between two fixed points: transverse and axial frequencies of
/// the lumped-mass chain are exact, `ω_j = 2 √(k/m) sin(jπ/2n)` with k = N/L (transverse) or
/// EA/L0 (axial) per element, and approach the continuous string and bar as n grows.
#[test]
fn taut_cable_frequencies() {
    let (span, ea, mu, tension) = (30.0, 1.0e7, 0.8, 3000.0);
    let total_l0 = span / (1.0 + tension / ea);
    for n in [4, 20, 80] {
        let net = CableNet {
            anchors: vec![Vec3::zeros()],
            attachments: vec![Vec3::zeros()],
            spec: CableSpec { elements: n, ea, mass_per_length: mu, gravity: Vec3::zeros() },
            cabin: MassProperties { mass: 1.0, com: Vec3::zeros(), inertia_com: Mat3::identity() },
            payload: MassProperties::ZERO,
        };
        let sys = System::new(net, vec![total_l0], true, Support::Fixed);
        let nodes = (1..n).map(|j| Vec3::new(span * j as f64 / n as f64, 0.0, 0.0)).collect();
        let cfg = Config { nodes, position: Vec3::new(span, 0.0, 0.0), orientation: Quat::identity() };
        let md = modes(&sys, &cfg, 3 * (n - 1)).unwrap();
        let (le, l0e, m) = (span / n as f64, total_l0 / n as f64, mu * total_l0 / n as f64);
        let chain = |k: f64, j: usize| hz(2.0 * (k / m).sqrt() * (j as f64 * PI / (2.0 * n as f64)).sin());
        let mut expected: Vec<f64> =
            (1..n).flat_map(|j| [chain(tension / le, j), chain(tension / le, j), chain(ea / l0e, j)]).collect();
        expected.sort_by(f64::total_cmp);
        for (f, e) in md.frequencies_hz.iter().zip(&expected) {
            assert!((f - e).abs() < 1e-9 * e, "n = {n}: {f} vs {e}");
        }
        // the continuous string: f₁ = (1/2L) √(N/μ'), μ' the stretched mass per length
        let string = (tension / (mu * total_l0 / span)).sqrt() / (2.0 * span);
        let first = md.frequencies_hz[0];
        eprintln!("n = {n}: first transverse {first:.6} Hz, continuous string {string:.6} Hz");
        assert!((first - string).abs() < 0.5 / (n * n) as f64 * string, "chain → string as 1/n²");
    }
}

/// A rigid body held at the origin by six pretensioned single-element cables along ±x, ±y, ±z,
/// attached at distance a from its centre: translations ω² = (2 EA/L0 + 4 N/L)/m, rotations
/// ω² = 4 N a (1 + a/L)/J — the rotational stiffness comes only from the geometric stiffness of
/// the cables and of the end forces on the rotating arms.
#[test]
fn rigid_body_on_cables_has_closed_form_frequencies() {
    let (a, len, ea, tension) = (0.5, 4.0, 2.0e6, 5000.0);
    let (m, j) = (300.0, [40.0, 55.0, 70.0]);
    let l0 = len / (1.0 + tension / ea);
    let axes = [Vec3::x(), -Vec3::x(), Vec3::y(), -Vec3::y(), Vec3::z(), -Vec3::z()];
    let net = CableNet {
        anchors: axes.iter().map(|e| e * (a + len)).collect(),
        attachments: axes.iter().map(|e| e * a).collect(),
        spec: CableSpec { elements: 1, ea, mass_per_length: 1e-12, gravity: Vec3::zeros() },
        cabin: MassProperties { mass: m, com: Vec3::zeros(), inertia_com: Mat3::from_diagonal(&Vec3::from(j)) },
        payload: MassProperties::ZERO,
    };
    let sys = System::new(net, vec![l0; 6], true, Support::Free);
    let cfg = Config { nodes: vec![], position: Vec3::zeros(), orientation: Quat::identity() };
    let md = modes(&sys, &cfg, 6).unwrap();
    let translation = hz(((2.0 * ea / l0 + 4.0 * tension / len) / sys.body.mass).sqrt());
    let rotation = |jj: f64| hz((4.0 * tension * a * (1.0 + a / len) / jj).sqrt());
    let mut expected = vec![translation, translation, translation, rotation(j[0]), rotation(j[1]), rotation(j[2])];
    expected.sort_by(f64::total_cmp);
    for (f, e) in md.frequencies_hz.iter().zip(&expected) {
        assert!((f - e).abs() < 1e-8 * e, "{f} vs {e}");
    }
}
