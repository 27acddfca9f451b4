//! The discrete-time algebraic Riccati equation, by the structure-preserving doubling algorithm.
//!
//! Control form, with a cross weight N between state and input:
//!
//! ```text
//! X = AᵀXA − (AᵀXB + N)(R + BᵀXB)⁻¹(BᵀXA + Nᵀ) + Q,   K = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ)
//! ```
//!
//! The cross weight is removed first (`A ← A − BR⁻¹Nᵀ`, `Q ← Q − NR⁻¹Nᵀ`), which leaves
//! `X = AᵀX(I + GX)⁻¹A + H` with `G = BR⁻¹Bᵀ`, `H = Q`. Doubling (Chu, Fan, Lin 2005, SDA) then
//! iterates `W = I + GₖHₖ`, `Aₖ₊₁ = AₖW⁻¹Aₖ`, `Gₖ₊₁ = Gₖ + AₖW⁻¹GₖAₖᵀ`, `Hₖ₊₁ = Hₖ + AₖᵀHₖW⁻¹Aₖ`;
//! `Hₖ` reaches the stabilizing solution quadratically: after k steps it holds what 2ᵏ steps of
//! the plain recursion would, so a closed loop whose slowest pole is 0.99999 per step needs about
//! 25 of them. Every solution is checked by its residual and by the closed loop's spectral radius
//! before it is returned. The filter's equation is the dual (`Aᵀ`, `Cᵀ`).

use crate::sampled::symmetrize;
use nalgebra::DMatrix;

/// Most doubling steps: 2⁸⁰ steps of the plain recursion.
const MAX_DOUBLINGS: usize = 80;
/// Stop when a step changes the solution by less than this, relative.
const CONVERGED: f64 = 1e-15;
/// Largest relative residual accepted.
pub const RESIDUAL_BOUND: f64 = 1e-9;

/// A solution of the DARE and the gain it gives.
#[derive(Clone, Debug)]
pub struct Dare {
    pub x: DMatrix<f64>,
    /// K = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ): the control u = −Kx.
    pub gain: DMatrix<f64>,
    /// ‖right-hand side − X‖_F / max(‖X‖_F, ‖Q‖_F).
    pub residual: f64,
    /// Spectral radius of A − BK.
    pub closed_loop_radius: f64,
    pub doublings: usize,
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RiccatiError {
    #[error("the {what} weight is not positive definite: every input (measurement) needs a positive weight (noise)")]
    NotPositive { what: &'static str },
    #[error("matrices of mismatched sizes: {0}")]
    Shape(String),
    #[error(
        "no stabilizing solution: after {doublings} doublings the solution still moves by {change:.2e} (relative); a mode that no input reaches (or no measurement sees) is not damped"
    )]
    NoConvergence { doublings: usize, change: f64 },
    #[error("a number is not finite after {doublings} doublings")]
    NotFinite { doublings: usize },
    #[error("the solution's residual {residual:.2e} exceeds {RESIDUAL_BOUND:e}")]
    Residual { residual: f64 },
    #[error("the closed loop is not stable: spectral radius {radius:.12} (a mode on the unit circle no input reaches)")]
    Unstable { radius: f64 },
    #[error("singular matrix: {0}")]
    Singular(&'static str),
}

fn check(cond: bool, what: impl FnOnce() -> String) -> Result<(), RiccatiError> {
    if cond { Ok(()) } else { Err(RiccatiError::Shape(what())) }
}

/// Spectral radius of a square matrix, as `‖A^(2^k)‖^(1/2^k)` after 48 squarings (normalized at
/// each, its logarithm accumulated): Gelfand's formula, accurate to about ln(‖A‖ cond)/2⁴⁸ —
/// and it needs no eigenvalue iteration, which may stall on the many zero eigenvalues of delay
/// lines.
pub fn spectral_radius(a: &DMatrix<f64>) -> f64 {
    let mut m = a.clone();
    let mut log_scale = 0.0;
    for k in 0..48 {
        let s = m.norm();
        if !(s > 0.0) || !s.is_finite() {
            return if s == 0.0 { 0.0 } else { f64::INFINITY };
        }
        m /= s;
        log_scale += s.ln() / 2f64.powi(k);
        m = &m * &m;
    }
    (log_scale + m.norm().ln() / 2f64.powi(48)).exp()
}

/// The right-hand side of the control DARE at `x`, and the gain.
fn rhs(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    n: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), RiccatiError> {
    let xa = x * a;
    let s = r + b.transpose() * x * b;
    let t = b.transpose() * &xa + n.transpose();
    let chol = s.clone().cholesky().ok_or(RiccatiError::NotPositive { what: "input (R + BᵀXB)" })?;
    let gain = chol.solve(&t);
    let mut out = a.transpose() * &xa - t.transpose() * &gain + q;
    symmetrize(&mut out);
    Ok((out, gain))
}

/// Solves the control DARE with cross weight `n` (Q: n×n, R: m×m, N: n×m).
pub fn dare(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    n: &DMatrix<f64>,
) -> Result<Dare, RiccatiError> {
    let (dim, m) = (a.nrows(), b.ncols());
    check(a.is_square() && b.nrows() == dim, || format!("A {}×{}, B {}×{}", a.nrows(), a.ncols(), b.nrows(), m))?;
    check(q.shape() == (dim, dim), || format!("Q {:?} for {dim} states", q.shape()))?;
    check(r.shape() == (m, m), || format!("R {:?} for {m} inputs", r.shape()))?;
    check(n.shape() == (dim, m), || format!("N {:?} for {dim} states and {m} inputs", n.shape()))?;
    let chol = r.clone().cholesky().ok_or(RiccatiError::NotPositive { what: "input" })?;
    let r_inv_bt = chol.solve(&b.transpose());
    let r_inv_nt = chol.solve(&n.transpose());
    let mut ak = a - b * &r_inv_nt;
    let mut gk = b * &r_inv_bt;
    let mut hk = q - n * &r_inv_nt;
    symmetrize(&mut gk);
    symmetrize(&mut hk);
    let eye = DMatrix::<f64>::identity(dim, dim);
    let mut doublings = 0;
    loop {
        let w = &eye + &gk * &hk;
        let lu = w.lu();
        let wa = lu.solve(&ak).ok_or(RiccatiError::Singular("I + GH in the doubling"))?;
        let wg = lu.solve(&gk).ok_or(RiccatiError::Singular("I + GH in the doubling"))?;
        let mut h_next = &hk + ak.transpose() * &hk * &wa;
        let mut g_next = &gk + &ak * &wg * ak.transpose();
        symmetrize(&mut h_next);
        symmetrize(&mut g_next);
        ak = &ak * &wa;
        doublings += 1;
        if !h_next.iter().chain(g_next.iter()).chain(ak.iter()).all(|v| v.is_finite()) {
            return Err(RiccatiError::NotFinite { doublings });
        }
        let change = (&h_next - &hk).norm() / h_next.norm().max(f64::MIN_POSITIVE);
        hk = h_next;
        gk = g_next;
        if change <= CONVERGED && ak.norm() <= 1e-12 * (1.0 + hk.norm()) {
            break;
        }
        if doublings >= MAX_DOUBLINGS {
            return Err(RiccatiError::NoConvergence { doublings, change });
        }
    }
    let x = hk;
    let (right, gain) = rhs(a, b, q, r, n, &x)?;
    let residual = (&right - &x).norm() / x.norm().max(q.norm()).max(f64::MIN_POSITIVE);
    if !(residual <= RESIDUAL_BOUND) {
        return Err(RiccatiError::Residual { residual });
    }
    let closed_loop_radius = spectral_radius(&(a - b * &gain));
    if !(closed_loop_radius < 1.0) {
        return Err(RiccatiError::Unstable { radius: closed_loop_radius });
    }
    Ok(Dare { x, gain, residual, closed_loop_radius, doublings })
}

/// The filter's DARE: `P = APAᵀ − (APCᵀ + S)(R + CPCᵀ)⁻¹(CPAᵀ + Sᵀ) + Q` for `x' = Ax + w`,
/// `y = Cx + v`, Cov(w) = Q, Cov(v) = R, E[wvᵀ] = S. Returns P (the one-step prediction's
/// covariance) in `x` and the predictor's gain `(APCᵀ + S)(R + CPCᵀ)⁻¹` transposed in `gain`.
pub fn filter_dare(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    s: &DMatrix<f64>,
) -> Result<Dare, RiccatiError> {
    dare(&a.transpose(), &c.transpose(), q, r, s).map_err(|e| match e {
        RiccatiError::NotPositive { .. } => RiccatiError::NotPositive { what: "measurement noise" },
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar DARE against its closed form: x = a²x − a²x²b²/(r + b²x) + q, i.e.
    /// b²x² + (r(1 − a²) − qb²)x − qr = 0, its positive root.
    #[test]
    fn scalar_equation_against_its_closed_form() {
        for (a, b, q, r) in [(0.9, 1.0, 1.0, 1.0), (1.2, 0.5, 2.0, 0.1), (1.0, 1.0, 1e-3, 1.0), (-0.5, 2.0, 3.0, 7.0)] {
            let m = |v: f64| DMatrix::from_element(1, 1, v);
            let d = dare(&m(a), &m(b), &m(q), &m(r), &m(0.0)).unwrap();
            let (qa, qb, qc) = (b * b, r * (1.0 - a * a) - q * b * b, -q * r);
            let exact = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
            assert!((d.x[(0, 0)] - exact).abs() < 1e-12 * exact, "{a} {b}: {} vs {exact}", d.x[(0, 0)]);
            assert!(d.residual < 1e-13 && d.closed_loop_radius < 1.0);
        }
    }

    /// A random stabilizable system of 12 states, 3 inputs, with a cross weight: the residual is
    /// at round-off, the closed loop stable, and the gain the one the plain recursion reaches.
    #[test]
    fn a_larger_system_with_a_cross_weight() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let (n, m) = (12, 3);
        let a = DMatrix::from_fn(n, n, |_, _| next() * 0.6);
        let b = DMatrix::from_fn(n, m, |_, _| next());
        let f = DMatrix::from_fn(n + m, n + m, |_, _| next());
        let w = &f * f.transpose() + DMatrix::identity(n + m, n + m) * 0.1;
        let (q, nn, r) = (
            w.view((0, 0), (n, n)).into_owned(),
            w.view((0, n), (n, m)).into_owned(),
            w.view((n, n), (m, m)).into_owned(),
        );
        let d = dare(&a, &b, &q, &r, &nn).unwrap();
        assert!(d.residual < 1e-12, "{}", d.residual);
        // the plain recursion from X = Q reaches the same solution
        let mut x = q.clone();
        for _ in 0..2000 {
            x = rhs(&a, &b, &q, &r, &nn, &x).unwrap().0;
        }
        assert!((&x - &d.x).norm() < 1e-9 * d.x.norm());
    }

    #[test]
    fn an_undamped_mode_no_input_reaches_is_refused() {
        // a rotation (eigenvalues on the unit circle) the input does not touch, with weight on it
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let a = DMatrix::from_row_slice(3, 3, &[c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 0.5]);
        let b = DMatrix::from_row_slice(3, 1, &[0.0, 0.0, 1.0]);
        let e = dare(&a, &b, &DMatrix::identity(3, 3), &DMatrix::identity(1, 1), &DMatrix::zeros(3, 1)).unwrap_err();
        assert!(matches!(e, RiccatiError::NoConvergence { .. } | RiccatiError::Unstable { .. }), "{e}");
        let e = dare(&a, &b, &DMatrix::identity(3, 3), &DMatrix::zeros(1, 1), &DMatrix::zeros(3, 1)).unwrap_err();
        assert!(matches!(e, RiccatiError::NotPositive { .. }), "{e}");
    }
}
