//! Natural frequencies against closed-form references and against a dense eigen solver, the
//! symmetry of the tangent stiffness, and the static residual of the form-found equilibrium
//! measured by the dynamic model's own force assembly.

mod common;

use cable::modes::{Modes, modes, tangent};
use cable::net::CableNet;
use cable::shooting::CableSpec;
use cable::system::{Coefficients, Config, Support, System};
use common::{equilibrium, scene};
use faer::{Mat, Side};
use feedcore::rigid::{MassProperties, skew};
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{DMatrix, DVector, Matrix6, Vector6};
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

/// The dense oracle: K and M assembled into dense matrices, `M = L Lᵀ` (L block diagonal:
/// √m on the nodes, the Cholesky factor of the cabin block), and the symmetric eigenproblem
/// `L⁻¹ K L⁻ᵀ y = λ y` solved by faer's dense solver. Frequencies (Hz) and mass-normalized shapes.
fn dense_modes(sys: &System, cfg: &Config, count: usize) -> (Vec<f64>, Vec<DVector<f64>>) {
    let n = sys.dim();
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut mat = sys.new_matrix();
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut mat, Coefficients::STIFFNESS)));
    let k = mat.to_dense();
    let k = (&k + k.transpose()) * 0.5;
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut mat, Coefficients::MASS)));
    let m = mat.to_dense();
    let dof = if sys.support == Support::Fixed { n - 6 } else { n };
    let c0 = sys.cabin_offset();
    let mut d = DMatrix::<f64>::zeros(dof, dof);
    for i in 0..c0 {
        d[(i, i)] = 1.0 / m[(i, i)].sqrt();
    }
    if dof == n {
        let mc: Matrix6<f64> = m.fixed_view::<6, 6>(c0, c0).into_owned();
        let linv = mc.cholesky().unwrap().l().try_inverse().unwrap();
        d.fixed_view_mut::<6, 6>(c0, c0).copy_from(&linv);
    }
    let a = &d * k.view((0, 0), (dof, dof)) * d.transpose();
    let a = Mat::<f64>::from_fn(dof, dof, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = a.self_adjoint_eigen(Side::Lower).unwrap();
    let (s, u) = (evd.S().column_vector(), evd.U());
    let count = count.min(dof);
    let freqs = (0..count).map(|j| s[j].signum() * s[j].abs().sqrt() / (2.0 * PI)).collect();
    let shapes = (0..count)
        .map(|j| {
            let phi = d.transpose() * DVector::from_fn(dof, |i, _| u[(i, j)]);
            let mut full = DVector::zeros(n);
            full.rows_mut(0, dof).copy_from(&phi);
            full
        })
        .collect();
    (freqs, shapes)
}

/// Shift-invert Lanczos on the chain-structured K and M gives the dense solver's modes at
/// 20 elements per cable, at both poses: frequencies to 1e-9 relative, and shapes that span the
/// same directions (M-inner product of the two unit shapes 1 to 1e-9, i.e. an angle below
/// 5e-5 rad; and entry by entry to 1e-6 of the largest).
#[test]
fn sparse_modes_equal_the_dense_solver() {
    for name in ["lt50m_C.toml", "lt50m_B.toml"] {
        let s = scene(name);
        let (net, eq) = equilibrium(&s);
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let cfg = sys.config_from(&eq);
        let count = 12;
        let sparse = modes(&sys, &cfg, count).unwrap();
        let (freqs, shapes) = dense_modes(&sys, &cfg, count);
        let m = tangent(&sys, &cfg).mass.to_dense();
        eprintln!("{name}: {:?}; residual {:.1e}; {:?}", sparse.frequencies_hz, sparse.residual, sparse.stats);
        assert_eq!(sparse.frequencies_hz.len(), count);
        for k in 0..count {
            let (fs, fd) = (sparse.frequencies_hz[k], freqs[k]);
            let phi = DVector::from_column_slice(&sparse.shapes[k]);
            let cosine = (phi.transpose() * &m * &shapes[k])[(0, 0)];
            let sign = cosine.signum();
            let entry = (&phi - &shapes[k] * sign).amax() / shapes[k].amax();
            eprintln!(
                "  mode {}: {fs:.12} vs {fd:.12} Hz ({:.1e}); 1 − |cos| = {:.1e}; entries {entry:.1e}",
                k + 1,
                (fs - fd) / fd,
                1.0 - cosine.abs()
            );
            assert!((fs - fd).abs() <= 1e-9 * fd, "{name} mode {}: {fs} vs {fd}", k + 1);
            assert!(1.0 - cosine.abs() <= 1e-9, "{name} mode {}: M-cosine {cosine}", k + 1);
            assert!(entry <= 1e-6, "{name} mode {}: shapes differ by {entry:.1e}", k + 1);
        }
        assert!(sparse.residual < 1e-10, "{name}: residual {:.1e}", sparse.residual);
    }
}

/// The antisymmetric part of K is half the unbalanced moment on the cabin, `−½ [M]×`, and
/// nothing else: zero at the form-found equilibrium, and exactly that at a pose turned away
/// from it — the reason why the symmetric Lanczos method applies (see `modes.rs`).
#[test]
fn stiffness_is_symmetric_at_the_equilibrium_and_only_there() {
    let s = scene("lt50m_B.toml");
    let (net, eq) = equilibrium(&s);
    let sys = System::new(net, eq.lengths(), true, Support::Free);
    let cfg = sys.config_from(&eq);
    let at_rest = tangent(&sys, &cfg);
    eprintln!("asymmetry at the equilibrium: {:.1e}", at_rest.asymmetry);
    assert!(at_rest.asymmetry < 1e-10);

    let mut turned = cfg.clone();
    turned.orientation = feedcore::rigid::exp_so3(&Vec3::new(0.02, -0.01, 0.03)) * cfg.orientation;
    let n = sys.dim();
    let (zero, mut r) = (vec![0.0; n], vec![0.0; n]);
    let mut k = sys.new_matrix();
    sys.assemble(&turned, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut k, Coefficients::STIFFNESS)));
    let kd = k.to_dense();
    let mut anti = &kd - kd.transpose();
    let c0 = sys.cabin_offset();
    let moment = Vec3::new(r[c0 + 3], r[c0 + 4], r[c0 + 5]);
    let expected = -skew(&moment);
    let block = anti.fixed_view::<3, 3>(c0 + 3, c0 + 3).into_owned();
    eprintln!(
        "unbalanced moment {:?} N·m; K − Kᵀ (rotation block) vs −[M]×: {:.1e}",
        moment.as_slice(),
        (block - expected).amax()
    );
    assert!(moment.norm() > 100.0, "the turned pose must be off equilibrium");
    assert!((block - expected).amax() <= 1e-9 * moment.norm());
    anti.fixed_view_mut::<3, 3>(c0 + 3, c0 + 3).fill(0.0);
    assert!(anti.amax() <= 1e-12 * kd.amax(), "asymmetry outside the cabin's rotation block: {:.1e}", anti.amax());
}

/// The modes' cost and memory stay proportional to the model size: the Lanczos basis holds a
/// fixed number of vectors and the number of solves does not grow with the mesh. (The
/// recomputed residual grows with the mesh as the solves' round-off does, ε·κ(K) with
/// κ(K) ∝ n²: 3e-12 at 20 elements, 2e-10 at 320.)
#[test]
fn lanczos_work_does_not_grow_with_the_mesh() {
    let base = scene("lt50m_C.toml");
    let mut work = Vec::new();
    for elements in [20, 80, 320, 1280] {
        let s = base.edited(|s| s.cables.elements = elements).unwrap();
        let (net, eq) = equilibrium(&s);
        let sys = System::new(net, eq.lengths(), true, Support::Free);
        let md: Modes = modes(&sys, &sys.config_from(&eq), 6).unwrap();
        eprintln!("{elements} elements: {:?}, f = {:?}, residual {:.1e}", md.stats, md.frequencies_hz, md.residual);
        assert!(md.residual < 1e-12 * (elements * elements) as f64);
        assert!(md.stats.basis_size <= 2 * 6 + 17);
        work.push(md.stats.solves);
    }
    assert!(work[3] <= 2 * work[0], "solves at 20, 80, 320, 1280 elements: {work:?}");
}
