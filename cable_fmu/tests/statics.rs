//! Form-finding statics against independent references.

use cable_fmu::catenary::ElasticCatenary;
use cable_fmu::net::CableNet;
use cable_fmu::shooting::{CableSpec, solve_chain};
use cable_fmu::statics::{CableState, form_find};
use feedcore::Vec3;
use feedcore::scene::Scene;

fn scene(name: &str) -> Scene {
    Scene::load(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// Compares one FE cable from `a` to `b` with Irvine's elastic catenary for k = 5 … 80 elements.
/// Returns the largest relative end-tension error for each k. The support reactions (end
/// element force plus the end node's weight) are compared with the catenary's end tensions, and
/// every node with the catenary point at its Lagrangian coordinate.
fn catenary_errors(a: Vec3, b: Vec3, length: f64) -> Vec<(usize, f64)> {
    let (ea, mu, g) = (1.0247e7, 0.813, 9.81);
    let cat = ElasticCatenary::solve(a, b, length, ea, mu * g);
    let mut errors = Vec::new();
    let mut previous_shape = None;
    for k in [5, 10, 20, 40, 80] {
        let spec = CableSpec { elements: k, ea, mass_per_length: mu, gravity: Vec3::new(0.0, 0.0, -g) };
        let c = solve_chain(&spec, &a, &b, length, None).unwrap();
        let half_node = Vec3::new(0.0, 0.0, -g) * (0.5 * mu * length / k as f64);
        // the support holds the end node against the end element and the node's weight
        let reaction_a = (c.tension[0] + half_node).norm();
        let reaction_b = (c.tension[k - 1] - half_node).norm();
        let err_a = (reaction_a - cat.tension(0.0)).abs() / cat.tension(0.0);
        let err_b = (reaction_b - cat.tension(length)).abs() / cat.tension(length);
        let shape = (0..=k).map(|j| (c.nodes[j] - cat.point(length * j as f64 / k as f64)).norm()).fold(0.0, f64::max);
        eprintln!(
            "L0/chord {:.4}, k = {k:2}: end tension error {err_a:.2e} / {err_b:.2e}, shape error {shape:.2e} m",
            length / (b - a).norm()
        );
        if let Some(p) = previous_shape {
            let rate: f64 = p / shape;
            assert!((3.5..4.5).contains(&rate), "shape error must fall by ~4 per halving: {rate:.2}");
        }
        previous_shape = Some(shape);
        errors.push((k, err_a.max(err_b)));
    }
    for w in errors.windows(2) {
        let rate = w[0].1 / w[1].1;
        assert!((3.5..4.5).contains(&rate), "tension error must fall by ~4 per halving: {rate:.2}");
    }
    errors
}

/// The LT50m cable 0 at pose C (its end points and unstretched length from the form finding):
/// within 0.1 % in end tension at k = 20, converging at second order.
#[test]
fn lt50m_cable_converges_to_the_elastic_catenary() {
    let s = scene("lt50m_C.toml");
    let net = CableNet::from_scene(&s);
    let eq = form_find(&net, s.target_position(), s.target_orientation()).unwrap();
    let shape = &eq.cables[0].shape;
    let errors = catenary_errors(shape.nodes[0], shape.nodes[shape.nodes.len() - 1], eq.cables[0].unstretched_length);
    let at20 = errors.iter().find(|(k, _)| *k == 20).unwrap().1;
    assert!(at20 < 1e-3, "k = 20: {at20:.2e}");
}

/// Over a range of sag the error is second order with a nearly constant coefficient,
/// error ≈ c/k² with c ≈ 0.3–0.6: it comes from the straight elements' chords being shorter than
/// the curved arc they replace (L³κ²/24 per element).
#[test]
fn fe_cable_converges_to_the_elastic_catenary_at_any_sag() {
    let (a, b) = (Vec3::new(28.19, 10.26, 30.0), Vec3::new(0.87, 0.5, 9.55));
    for ratio in [1.0005, 1.002, 1.01, 1.05] {
        let errors = catenary_errors(a, b, (b - a).norm() * ratio);
        for (k, e) in errors {
            let c = e * (k * k) as f64;
            assert!((0.2..0.7).contains(&c), "L0/chord {ratio}, k {k}: error·k² = {c:.3}");
        }
    }
}

#[test]
fn form_finding_at_c_and_b() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let net = CableNet::from_scene(&s);
        let eq = form_find(&net, s.target_position(), s.target_orientation()).unwrap();
        eprintln!("{name}: residual {:.2e}, {} iterations", eq.residual, eq.newton_iterations);
        for (i, c) in eq.cables.iter().enumerate() {
            eprintln!(
                "  cable {}: L0 {:.6} m, anchor {:.1} N, cabin {:.1} N, {:?}, lowest z {:.3}",
                i + 1,
                c.unstretched_length,
                c.tension_anchor,
                c.tension_cabin,
                c.state,
                c.lowest_point_z
            );
        }
        let _ = CableState::Taut;
    }
}

/// A pose outside the towers' reach needs a cable to push: reported as infeasible, naming it.
#[test]
fn infeasible_pose_names_the_cable() {
    let mut s = scene("lt50m_C.toml");
    s.pose.position_m = [0.0, 40.0, 10.0]; // outside the anchor circle (radius 30 m)
    let net = CableNet::from_scene(&s);
    let err = form_find(&net, s.target_position(), s.target_orientation()).unwrap_err();
    let msg = err.to_string();
    eprintln!("{msg}");
    match err {
        cable_fmu::statics::StaticsError::Infeasible { cable, tension } => {
            assert!(tension < 0.0);
            assert!(msg.contains(&format!("cable {cable}")), "{msg}");
        }
        other => panic!("expected infeasibility, got {other}"),
    }
}
