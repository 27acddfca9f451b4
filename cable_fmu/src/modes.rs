//! Natural frequencies and mode shapes about a static equilibrium.
//!
//! The full tangent stiffness K (elastic and geometric stiffness of every element, the stiffness
//! of the cable-end forces acting on the cabin's rotating arms, and of the weights acting at
//! the cabin's centre of mass) and the mass matrix M (lumped nodes, the cabin's rigid-body mass
//! about its centre point) give the generalized symmetric eigenproblem `K φ = ω² M φ`. M is
//! block diagonal, so `M = L Lᵀ` is cheap and the problem becomes `L⁻¹ K L⁻ᵀ y = ω² y`, solved
//! densely (a few hundred unknowns) with faer.

use faer::{Mat, Side};
use nalgebra::{DMatrix, Matrix6, Vector6};

use crate::system::{Coefficients, Config, Support, System};

#[derive(Clone, Debug)]
pub struct Modes {
    /// Ascending. A negative value is an unstable direction: −√|λ|/2π.
    pub frequencies_hz: Vec<f64>,
    /// Mass-normalized shapes (φᵀ M φ = 1), laid out like the system's velocity vectors
    /// (free nodes, then the cabin; all zero for the cabin when it is held fixed).
    pub shapes: Vec<Vec<f64>>,
    /// Largest asymmetry of K before symmetrization, relative to its largest entry: zero at an
    /// exact equilibrium, so it measures how well the equilibrium was found.
    pub stiffness_asymmetry: f64,
}

impl Modes {
    /// The cabin's part (translation, rotation) of mode `k`.
    pub fn cabin_part(&self, k: usize) -> Vector6<f64> {
        let s = &self.shapes[k];
        Vector6::from_column_slice(&s[s.len() - 6..])
    }
}

/// The `count` lowest modes of `sys` at the equilibrium configuration `cfg` (at rest, no external
/// wrench).
pub fn modes(sys: &System, cfg: &Config, count: usize) -> Result<Modes, String> {
    let n = sys.dim();
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut mat = sys.new_matrix();
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut mat, Coefficients::STIFFNESS)));
    let k = mat.to_dense();
    sys.assemble(cfg, &zero, &zero, &Vector6::zeros(), &mut r, Some((&mut mat, Coefficients::MASS)));
    let m = mat.to_dense();
    let asym = (&k - k.transpose()).amax() / k.amax();
    let k = (&k + k.transpose()) * 0.5;

    // Keep the cabin's unknowns only if it moves.
    let dof = if sys.support == Support::Fixed { n - 6 } else { n };
    let c0 = sys.cabin_offset();
    // D = L⁻¹ with M = L Lᵀ: 1/√m on the nodes, the inverse Cholesky factor on the cabin.
    let mut d = DMatrix::<f64>::zeros(dof, dof);
    for i in 0..c0 {
        if m[(i, i)] <= 0.0 {
            return Err(format!("node mass {} at unknown {i} is not positive", m[(i, i)]));
        }
        d[(i, i)] = 1.0 / m[(i, i)].sqrt();
    }
    if dof == n {
        let mc: Matrix6<f64> = m.fixed_view::<6, 6>(c0, c0).into_owned();
        let l = mc.cholesky().ok_or("the cabin mass matrix is not positive definite")?.l();
        let linv = l.try_inverse().ok_or("singular cabin mass factor")?;
        d.fixed_view_mut::<6, 6>(c0, c0).copy_from(&linv);
    }
    let kk = k.view((0, 0), (dof, dof));
    let a = &d * kk * d.transpose();
    let a = Mat::<f64>::from_fn(dof, dof, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = a.self_adjoint_eigen(Side::Lower).map_err(|e| format!("eigen solver failed: {e:?}"))?;
    let (s, u) = (evd.S().column_vector(), evd.U());
    let count = count.min(dof);
    let mut frequencies_hz = Vec::with_capacity(count);
    let mut shapes = Vec::with_capacity(count);
    for j in 0..count {
        let lambda = s[j];
        frequencies_hz.push(lambda.signum() * lambda.abs().sqrt() / (2.0 * std::f64::consts::PI));
        let y = nalgebra::DVector::from_fn(dof, |i, _| u[(i, j)]);
        let phi = d.transpose() * y;
        let mut full = vec![0.0; n];
        full[..dof].copy_from_slice(phi.as_slice());
        shapes.push(full);
    }
    Ok(Modes { frequencies_hz, shapes, stiffness_asymmetry: asym })
}
