//! Form-finding statics against independent references.

use cable::catenary::ElasticCatenary;
use cable::net::CableNet;
use cable::shooting::{CableSpec, solve_chain};
use cable::statics::{CableState, form_find};
use feedcore::Vec3;
use feedcore::scene::{Scene, ValidScene};

fn scene(name: &str) -> ValidScene {
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

/// Checks an equilibrium against the scene by a separate assembly of the forces: every cable
/// ends on its anchor and on its attachment at the target pose, every element is stretched
/// (pulls), every free node balances its element forces and its weight, and the cabin (with the
/// platform locked at its start and the cable end nodes it carries) balances the cable pulls and
/// its weight, in force and in moment about the centre point. Returns the unstretched lengths and
/// the cabin-end tensions.
fn check_equilibrium(s: &ValidScene) -> (Vec<f64>, Vec<f64>) {
    let net = CableNet::from_scene(s);
    let (p, q) = (s.target_position(), s.target_orientation());
    let eq = form_find(&net, p, q).unwrap();
    let g = Vec3::new(0.0, 0.0, -s.gravity_m_s2);
    let mu = s.cables.area_m2 * s.cables.density_kg_m3;
    let k = s.cables.elements;
    let geometry = s.stewart_geometry();
    let body = s.cabin_mass_properties().combined(&geometry.locked_mass_properties(&geometry.start_center));
    let weight = body.mass * s.gravity_m_s2;
    let (mut force, mut moment) = (g * body.mass, (q * body.com).cross(&(g * body.mass)));
    for (i, c) in eq.cables.iter().enumerate() {
        let (nodes, t) = (&c.shape.nodes, &c.shape.tension);
        assert_eq!((nodes.len(), t.len()), (k + 1, k));
        let attach = p + q * s.attachments_body()[i];
        assert!((nodes[0] - s.anchors()[i]).norm() < 1e-9, "cable {i} starts on its anchor");
        assert!((nodes[k] - attach).norm() < 1e-9, "cable {i} ends on its attachment");
        let element = c.unstretched_length / k as f64;
        for j in 0..k {
            let chord = nodes[j + 1] - nodes[j];
            assert!(chord.norm() > element, "cable {i}, element {j} is stretched");
            assert!(t[j].dot(&chord) > 0.0 && t[j].cross(&chord).norm() < 1e-9 * t[j].norm() * chord.norm());
        }
        for j in 1..k {
            let balance = t[j] - t[j - 1] + g * (mu * element);
            assert!(balance.norm() < 1e-8 * t[j].norm(), "cable {i}, node {j}: {balance:?}");
        }
        assert_eq!((c.tension_anchor, c.tension_cabin), (t[0].norm(), t[k - 1].norm()));
        // the last element pulls the cabin back along itself; the end node's half element
        // weighs on the cabin
        let pull = -t[k - 1] + g * (0.5 * mu * element);
        force += pull;
        moment += (attach - p).cross(&pull);
    }
    assert!(force.norm() < 1e-6 * weight, "cabin force balance: {force:?} N against a weight of {weight} N");
    assert!(moment.norm() < 1e-6 * weight, "cabin moment balance: {moment:?} N·m");
    let lengths = eq.cables.iter().map(|c| c.unstretched_length).collect();
    (lengths, eq.cables.iter().map(|c| c.tension_cabin).collect())
}

#[test]
fn form_finding_at_c_and_b_balances_every_node_and_the_cabin() {
    let (_, c) = check_equilibrium(&scene("lt50m_C.toml"));
    let (_, b) = check_equilibrium(&scene("lt50m_B.toml"));
    // lt50m.md: at C every cable pulls several kN; at B cable 4 is nearly slack (~0.2 kN)
    assert!(c.iter().all(|t| *t > 1000.0), "{c:?}");
    assert!((b[4] - 200.0).abs() < 50.0 && b.iter().enumerate().all(|(i, t)| i == 4 || *t > 1000.0), "{b:?}");
    let sb = scene("lt50m_B.toml");
    let eq = form_find(&CableNet::from_scene(&sb), sb.target_position(), sb.target_orientation()).unwrap();
    let states: Vec<CableState> = eq.cables.iter().map(|c| c.state).collect();
    assert_eq!(states[4], CableState::NearlySlack);
    assert!(states.iter().enumerate().all(|(i, s)| i == 4 || *s == CableState::Taut), "{states:?}");
}

/// At C with the platform held at its circle's centre (motion radius 0) the suspended weight
/// acts on the cabin axis, and the net is symmetric under the 120° turns and the mirror plane at
/// 50° of azimuth (anchors at 50° ± 30°, attachments at 50° ± 20°): all six cables come out alike.
#[test]
fn form_finding_at_c_is_symmetric() {
    let s = scene("lt50m_C.toml")
        .edited(|s| {
            s.motion.radius_m = 0.0;
        })
        .unwrap();
    let (lengths, tensions) = check_equilibrium(&s);
    for i in 1..6 {
        assert!((lengths[i] - lengths[0]).abs() < 1e-9 * lengths[0], "{lengths:?}");
        assert!((tensions[i] - tensions[0]).abs() < 1e-6 * tensions[0], "{tensions:?}");
    }
    // and the six vertical pulls carry the cabin, the platform and the six end nodes
    let geometry = s.stewart_geometry();
    let mass = s.cabin.mass_kg + geometry.total_mass();
    let eq = form_find(&CableNet::from_scene(&s), s.target_position(), s.target_orientation()).unwrap();
    let end_nodes = 6.0 * 0.5 * s.cables.area_m2 * s.cables.density_kg_m3 * lengths[0] / s.cables.elements as f64;
    let lift: f64 = eq.cables.iter().map(|c| c.shape.tension[s.cables.elements - 1].z.abs()).sum();
    assert!((lift - (mass + end_nodes) * s.gravity_m_s2).abs() < 1e-6 * lift, "{lift}");
}

/// A pose outside the towers' reach needs a cable to push: reported as infeasible, naming it.
#[test]
fn infeasible_pose_names_the_cable() {
    let s = scene("lt50m_C.toml")
        .edited(|s| {
            s.pose.position_m = [0.0, 40.0, 10.0]; // outside the anchor circle (radius 30 m)
        })
        .unwrap();
    let net = CableNet::from_scene(&s);
    let err = form_find(&net, s.target_position(), s.target_orientation()).unwrap_err();
    let msg = err.to_string();
    eprintln!("{msg}");
    match err {
        cable::statics::StaticsError::Infeasible { cable, tension } => {
            assert!(tension < 0.0);
            assert!(msg.contains(&format!("cable {cable}")), "{msg}");
        }
        other => panic!("expected infeasibility, got {other}"),
    }
}

/// The points and element forces a picture of the net is drawn from are the form-finding's:
/// every node where the shooting put it, every element force the norm of its tension vector,
/// and a small configuration change moves the points as `point_motion` says (to first order).
#[test]
fn the_net_as_points_is_the_equilibrium() {
    use cable::system::{Support, System};
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let net = CableNet::from_scene(&s);
        let eq = form_find(&net, s.target_position(), s.target_orientation()).unwrap();
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let cfg = sys.config_from(&eq);
        let (mut points, mut forces) = (Vec::new(), Vec::new());
        sys.cable_points(&cfg, &mut points);
        sys.element_forces(&cfg, &mut forces);
        let n = s.cables.elements;
        assert_eq!(points.len(), 6 * (n + 1));
        assert_eq!(forces.len(), 6 * n);
        for (i, c) in eq.cables.iter().enumerate() {
            for (j, node) in c.shape.nodes.iter().enumerate() {
                let p = points[i * (n + 1) + j];
                assert!((p - node).norm() <= 1e-12 * node.norm(), "{name} cable {i} node {j}: {p} against {node}");
            }
            // the shooting places nodes to ~1e-13 of the span; EA/L0 makes that ~1e-8 of a tension
            for (e, t) in c.shape.tension.iter().enumerate() {
                let f = forces[i * n + e];
                assert!(
                    (f - t.norm()).abs() <= 2e-8 * t.norm(),
                    "{name} cable {i} element {e}: {f} against {}",
                    t.norm()
                );
            }
        }
        // a small change of every coordinate: the points move by point_motion to first order
        let du: Vec<f64> = (0..sys.dim()).map(|k| 1e-6 * ((k as f64 * 0.7).sin())).collect();
        let mut moved = cfg.clone();
        moved.set_displaced(&cfg, &du);
        let (mut after, mut motion) = (Vec::new(), Vec::new());
        sys.cable_points(&moved, &mut after);
        sys.point_motion(&cfg, &du, &mut motion);
        for k in 0..points.len() {
            let d = after[k] - points[k];
            assert!((d - motion[k]).norm() <= 1e-10, "{name} point {k}: moved {d}, point_motion {}", motion[k]);
        }
        assert!(motion.iter().step_by(n + 1).all(|m| *m == Vec3::zeros()), "anchors do not move");
    }
}
