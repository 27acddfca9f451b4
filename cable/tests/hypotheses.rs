//! The modal hypotheses of docs/reproduction.md against independent models: a term dropped
//! from the tangent equals the finite-difference tangent of a residual that lacks it (arms or
//! centre of mass frozen in the world), and the straight-cable model's vertical mode equals
//! the spring–mass formula.

mod common;

use cable::element::Bar;
use cable::model::{CableCabin, Payload};
use cable::modes::{Dropped, straight_cable_frequencies, tangent_dropping};
use cable::system::{Config, System};
use common::scene;
use feedcore::Vec3;
use feedcore::scene::StewartMode;
use nalgebra::{DMatrix, Vector6};

/// The residual at rest with the cable-end forces acting on arms, and the weight at a centre
/// of mass, frozen at the reference configuration `cfg0` where `frozen` says so.
fn residual(sys: &System, cfg: &Config, cfg0: &Config, frozen: Dropped) -> Vec<f64> {
    let n = sys.dim();
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    sys.residual(cfg, &zero, &zero, &Vector6::zeros(), &mut r);
    let c0 = sys.cabin_offset();
    let mut moment = Vec3::zeros();
    if frozen.cable_end_rotation {
        // the residual holds + d × pull per cable; the frozen model + d₀ × pull
        let m = sys.free_nodes();
        for i in 0..sys.cables() {
            let (attach, d) = sys.attachment(cfg, i);
            let (_, d0) = sys.attachment(cfg0, i);
            let pull = Bar::pull(&(attach - cfg.nodes[i * m + m - 1]), sys.net.spec.ea, sys.element_length[i]);
            moment -= (d - d0).cross(&pull);
        }
    }
    if frozen.weight_rotation {
        // the residual holds − c × m g; the frozen model − c₀ × m g
        let g = sys.net.spec.gravity * sys.body.mass;
        let c = cfg.orientation * sys.body.com;
        let c_ref = cfg0.orientation * sys.body.com;
        moment += (c - c_ref).cross(&g);
    }
    for k in 0..3 {
        r[c0 + 3 + k] += moment[k];
    }
    r
}

/// Central differences of the frozen model's residual, symmetric part.
fn fd_tangent(sys: &System, cfg0: &Config, frozen: Dropped) -> DMatrix<f64> {
    let n = sys.dim();
    let mut k = DMatrix::zeros(n, n);
    let mut cfg = cfg0.clone();
    let mut du = vec![0.0; n];
    for j in 0..n {
        let h = 1e-7;
        du[j] = h;
        cfg.set_displaced(cfg0, &du);
        let rp = residual(sys, &cfg, cfg0, frozen);
        du[j] = -h;
        cfg.set_displaced(cfg0, &du);
        let rm = residual(sys, &cfg, cfg0, frozen);
        du[j] = 0.0;
        for i in 0..n {
            k[(i, j)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    (&k + k.transpose()) * 0.5
}

#[test]
fn a_dropped_term_equals_the_tangent_of_a_model_without_it() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let model = CableCabin::build(&scene(name), 0).unwrap();
        let sys = model.system(Payload::Locked);
        let cfg = model.equilibrium_config();
        for dropped in [
            Dropped { cable_end_rotation: true, weight_rotation: false },
            Dropped { cable_end_rotation: false, weight_rotation: true },
            Dropped { cable_end_rotation: true, weight_rotation: true },
        ] {
            let analytic = tangent_dropping(&sys, &cfg, dropped).stiffness.to_dense();
            let fd = fd_tangent(&sys, &cfg, dropped);
            let n = sys.dim();
            let (a, f) = (analytic.view((n - 6, n - 6), (6, 6)), fd.view((n - 6, n - 6), (6, 6)));
            let full = tangent_dropping(&sys, &cfg, Dropped::default()).stiffness.to_dense();
            let change = (full.view((n - 6, n - 6), (6, 6)) - a).amax();
            let err = (a - f).amax();
            eprintln!("{name} {dropped:?}: cabin block |analytic − FD| {err:.2e}, the term dropped {change:.3e}");
            assert!(change > 100.0, "the dropped term is hundreds of N·m/rad: {change}");
            assert!(err <= 1e-6 * a.amax(), "{err:e} of {:e}", a.amax());
            let rows = (analytic.rows(n - 6, 6) - fd.rows(n - 6, 6)).amax();
            assert!(rows <= 1e-6 * a.amax(), "cabin rows: {rows:e}");
        }
    }
}

/// At C without the platform the cabin's vertical motion on straight springs decouples from
/// the rest (six-fold symmetry): `k_zz = Σ (EA/L₀ u_z² + T/L (1 − u_z²))`, f = √(k_zz/m)/2π.
#[test]
fn straight_cables_bounce_at_the_spring_mass_frequency() {
    let s = scene("lt50m_C.toml")
        .edited(|s| {
            s.analyses.stewart = StewartMode::Absent;
        })
        .unwrap();
    let model = CableCabin::build(&s, 0).unwrap();
    let sys = model.system(Payload::Locked);
    let cfg = model.equilibrium_config();
    let mut tensions = vec![(0.0, 0.0); 6];
    sys.end_tensions(&cfg, &mut tensions);
    for geometric in [true, false] {
        let mut kzz = 0.0;
        for (i, (_, t)) in tensions.iter().enumerate() {
            let (attach, _) = sys.attachment(&cfg, i);
            let chord = attach - sys.net.anchors[i];
            let uz = chord.z / chord.norm();
            kzz += sys.net.spec.ea / sys.lengths[i] * uz * uz;
            if geometric {
                kzz += t / chord.norm() * (1.0 - uz * uz);
            }
        }
        let f = (kzz / sys.body.mass).sqrt() / (2.0 * std::f64::consts::PI);
        let modes = straight_cable_frequencies(&sys, &cfg, geometric);
        let nearest = modes.iter().map(|m| (m - f).abs()).fold(f64::INFINITY, f64::min);
        eprintln!("geometric {geometric}: spring–mass {f:.6} Hz, modes {modes:?}");
        assert!(nearest <= 1e-9 * f, "{nearest:e}");
    }
}
