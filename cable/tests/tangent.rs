//! The assembled matrices are the exact derivatives of the residual: central finite
//! differences of the residual with respect to positions (rotations through the exponential
//! map), velocities and accelerations, away from equilibrium and with the cabin moving.

mod common;

use cable::system::{Coefficients, Config, Support, System};
use common::{Rng, equilibrium, scene};
use nalgebra::{DMatrix, Vector6};

fn residual(sys: &System, cfg: &Config, v: &[f64], a: &[f64], w: &Vector6<f64>) -> Vec<f64> {
    let mut r = vec![0.0; sys.dim()];
    sys.assemble(cfg, v, a, w, &mut r, None);
    r
}

/// Compares the whole matrix, and separately the cabin rows (whose entries are far smaller than
/// the stiffest element's), each relative to its own largest entry.
fn check(name: &str, analytic: &DMatrix<f64>, fd: &DMatrix<f64>) {
    let n = analytic.nrows();
    for (part, rows) in [("all", 0..n), ("cabin rows", n - 6..n)] {
        let a = analytic.rows(rows.start, rows.len());
        let f = fd.rows(rows.start, rows.len());
        let scale = a.amax();
        let err = (a - f).amax();
        eprintln!("{name}, {part}: max |analytic − FD| = {err:.3e} of max entry {scale:.3e}");
        assert!(err <= 1e-6 * scale, "{name}, {part}: relative error {:.3e}", err / scale);
    }
    // each 3×3 block of the cabin's own 6×6, relative to its own largest entry
    for (bi, bj) in [(0, 0), (0, 3), (3, 0), (3, 3)] {
        let a = analytic.view((n - 6 + bi, n - 6 + bj), (3, 3));
        let f = fd.view((n - 6 + bi, n - 6 + bj), (3, 3));
        let scale = a.amax().max(f.amax());
        let err = (a - f).amax();
        eprintln!("{name}, cabin block ({bi}, {bj}): max |analytic − FD| = {err:.3e} of {scale:.3e}");
        assert!(err <= 1e-6 * scale.max(1e-9), "{name}, cabin block ({bi}, {bj}): {err:.3e} of {scale:.3e}");
    }
}

/// Every element at least 1e-5 of its length away from the slack limit.
fn all_taut_with_margin(sys: &System, cfg: &Config) -> bool {
    let m = sys.free_nodes();
    (0..sys.cables()).all(|i| {
        let (attach, _) = sys.attachment(cfg, i);
        let mut points = vec![sys.net.anchors[i]];
        points.extend_from_slice(&cfg.nodes[i * m..i * m + m]);
        points.push(attach);
        points.windows(2).all(|w| (w[1] - w[0]).norm() > sys.element_length[i] * (1.0 + 1e-5))
    })
}

#[test]
fn tangent_mass_and_damping_match_finite_differences() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let (net, eq) = equilibrium(&s);
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let n = sys.dim();
        let mut rng = Rng(42);
        // A state away from equilibrium: displaced, moving, accelerating. Displacements stay
        // small enough that every element stays taut (the tension-only kink is not smooth).
        let base = sys.config_from(&eq);
        let mut du: Vec<f64> = (0..n).map(|_| 2e-5 * rng.next()).collect();
        du[n - 6..].iter_mut().for_each(|x| *x *= 10.0);
        let mut cfg = base.clone();
        cfg.set_displaced(&base, &du);
        assert!(all_taut_with_margin(&sys, &cfg), "test state must keep every element taut");
        let v: Vec<f64> = (0..n).map(|_| 0.3 * rng.next()).collect();
        let a: Vec<f64> = (0..n).map(|_| 0.5 * rng.next()).collect();
        let w = Vector6::new(120.0, -80.0, -1800.0, 40.0, 25.0, -10.0);

        let mut r = vec![0.0; n];
        let mut mat = sys.new_matrix();
        let dense = |coef: Coefficients, mat: &mut cable::chain_matrix::ChainMatrix, r: &mut Vec<f64>| {
            sys.assemble(&cfg, &v, &a, &w, r, Some((mat, coef)));
            mat.to_dense()
        };
        let k = dense(Coefficients::STIFFNESS, &mut mat, &mut r);
        let c = dense(Coefficients::DAMPING, &mut mat, &mut r);
        let m = dense(Coefficients::MASS, &mut mat, &mut r);

        let (mut kfd, mut cfd, mut mfd) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n), DMatrix::zeros(n, n));
        let h = 1e-6;
        for j in 0..n {
            let mut e = vec![0.0; n];
            e[j] = h;
            let (mut cp, mut cm) = (cfg.clone(), cfg.clone());
            cp.set_displaced(&cfg, &e);
            e[j] = -h;
            cm.set_displaced(&cfg, &e);
            let col =
                |rp: Vec<f64>, rm: Vec<f64>| rp.iter().zip(&rm).map(|(p, m)| (p - m) / (2.0 * h)).collect::<Vec<_>>();
            let kc = col(residual(&sys, &cp, &v, &a, &w), residual(&sys, &cm, &v, &a, &w));
            let shift = |x: &[f64], d: f64| -> Vec<f64> {
                let mut y = x.to_vec();
                y[j] += d;
                y
            };
            let cc = col(residual(&sys, &cfg, &shift(&v, h), &a, &w), residual(&sys, &cfg, &shift(&v, -h), &a, &w));
            let mc = col(residual(&sys, &cfg, &v, &shift(&a, h), &w), residual(&sys, &cfg, &v, &shift(&a, -h), &w));
            for i in 0..n {
                kfd[(i, j)] = kc[i];
                cfd[(i, j)] = cc[i];
                mfd[(i, j)] = mc[i];
            }
        }
        check(&format!("{name} stiffness"), &k, &kfd);
        check(&format!("{name} gyroscopic damping"), &c, &cfd);
        check(&format!("{name} mass"), &m, &mfd);
    }
}
