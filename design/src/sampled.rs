//! A continuous-time system sampled at period T with its input held (zero-order hold), by Van
//! Loan's block exponentials (C. F. Van Loan, Computing integrals involving the matrix
//! exponential, IEEE TAC 1978): the transition and input matrices, the covariance white noise adds
//! over a period, the weights that make a sum over the samples the integral of a continuous cost,
//! and the discrete Lyapunov equation.

use nalgebra::DMatrix;

/// `ẋ = Ax + Bu` over `t` with `u` held: `(e^{At}, ∫₀ᵗ e^{As} ds B)`.
pub fn hold(a: &DMatrix<f64>, b: &DMatrix<f64>, t: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let mut big = DMatrix::zeros(n + m, n + m);
    big.view_mut((0, 0), (n, n)).copy_from(&(a * t));
    big.view_mut((0, n), (n, m)).copy_from(&(b * t));
    let e = big.exp();
    (e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned())
}

/// The covariance white noise of intensity `w` (`ẋ = Ax + ξ`, E[ξ(t)ξ(s)ᵀ] = w δ(t − s)) adds
/// over `t`: `∫₀ᵗ e^{As} w e^{Aᵀs} ds`.
pub fn noise(a: &DMatrix<f64>, w: &DMatrix<f64>, t: f64) -> DMatrix<f64> {
    let n = a.nrows();
    let mut big = DMatrix::zeros(2 * n, 2 * n);
    big.view_mut((0, 0), (n, n)).copy_from(&(-a * t));
    big.view_mut((0, n), (n, n)).copy_from(&(w * t));
    big.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * t));
    let e = big.exp();
    let f22 = e.view((n, n), (n, n)).into_owned();
    let f12 = e.view((0, n), (n, n)).into_owned();
    let mut q = f22.transpose() * f12;
    symmetrize(&mut q);
    q
}

/// The weights of the sampled cost: for `ẋ = Ax + Bu` with `u` held over each period and the
/// weight `w` on `(x, u)` (n + m square), `∫₀ᵗ (x, u)ᵀ w (x, u) ds = (x₀, u)ᵀ W (x₀, u)`; returns W
/// split as (Q: n×n, N: n×m, R: m×m).
pub fn cost(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    w: &DMatrix<f64>,
    t: f64,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let k = n + m;
    let mut ah = DMatrix::zeros(k, k);
    ah.view_mut((0, 0), (n, n)).copy_from(a);
    ah.view_mut((0, n), (n, m)).copy_from(b);
    let mut big = DMatrix::zeros(2 * k, 2 * k);
    big.view_mut((0, 0), (k, k)).copy_from(&(-ah.transpose() * t));
    big.view_mut((0, k), (k, k)).copy_from(&(w * t));
    big.view_mut((k, k), (k, k)).copy_from(&(&ah * t));
    let e = big.exp();
    let f22 = e.view((k, k), (k, k)).into_owned();
    let f12 = e.view((0, k), (k, k)).into_owned();
    let mut total = f22.transpose() * f12;
    symmetrize(&mut total);
    (
        total.view((0, 0), (n, n)).into_owned(),
        total.view((0, n), (n, m)).into_owned(),
        total.view((n, n), (m, m)).into_owned(),
    )
}

pub(crate) fn symmetrize(m: &mut DMatrix<f64>) {
    let n = m.nrows();
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (m[(i, j)] + m[(j, i)]);
            m[(i, j)] = v;
            m[(j, i)] = v;
        }
    }
}

/// Most doubling steps of the Lyapunov solver (2⁸⁰ steps of `X ← AXAᵀ + Q`).
const MAX_DOUBLINGS: usize = 80;

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LyapunovError {
    #[error("the system is not stable: spectral radius {radius:.12} (no stationary covariance)")]
    Unstable { radius: f64 },
    #[error("no convergence after {MAX_DOUBLINGS} doublings (change {change:.2e})")]
    NoConvergence { change: f64 },
    #[error("the solution's residual {residual:.2e} is too large")]
    Residual { residual: f64 },
}

/// The stationary covariance `X = AXAᵀ + Q` of a stable `x' = Ax + w` (Cov w = Q), by doubling
/// (`Xₖ₊₁ = Xₖ + AₖXₖAₖᵀ`, `Aₖ₊₁ = Aₖ²`), checked by its residual.
pub fn lyapunov(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>, LyapunovError> {
    let radius = crate::riccati::spectral_radius(a);
    if !(radius < 1.0) {
        return Err(LyapunovError::Unstable { radius });
    }
    let mut x = q.clone();
    let mut ak = a.clone();
    let mut doublings = 0;
    loop {
        let next = &x + &ak * &x * ak.transpose();
        ak = &ak * &ak;
        let change = (&next - &x).norm() / next.norm().max(f64::MIN_POSITIVE);
        x = next;
        symmetrize(&mut x);
        doublings += 1;
        if change <= 1e-16 && ak.norm() < 1e-14 {
            break;
        }
        if doublings >= MAX_DOUBLINGS || !change.is_finite() {
            return Err(LyapunovError::NoConvergence { change });
        }
    }
    let residual = (a * &x * a.transpose() + q - &x).norm() / x.norm().max(f64::MIN_POSITIVE);
    if !(residual <= 1e-10) {
        return Err(LyapunovError::Residual { residual });
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator: the held-input step against the closed form, the noise covariance
    /// against a fine quadrature, the sampled cost against a fine quadrature.
    #[test]
    fn van_loan_integrals_against_quadrature() {
        let (w0, z) = (3.0, 0.1);
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w0 * w0, -2.0 * z * w0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let t = 0.2;
        let (ad, bd) = hold(&a, &b, t);
        // quadrature of e^{As} by many small exact steps of a Taylor series
        let steps = 20_000;
        let h = t / steps as f64;
        let small = {
            let ah = &a * h;
            DMatrix::identity(2, 2) + &ah + &ah * &ah / 2.0 + &ah * &ah * &ah / 6.0 + &ah * &ah * &ah * &ah / 24.0
        };
        let w = DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, 0.2, 0.1, 0.2, 0.5]);
        let noise_w = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 1.7]);
        let (mut e, mut int_b) = (DMatrix::identity(2, 2), DMatrix::zeros(2, 1));
        let (mut q_noise, mut q_cost) = (DMatrix::zeros(2, 2), DMatrix::zeros(3, 3));
        for k in 0..=steps {
            let weight = if k == 0 || k == steps { 0.5 * h } else { h };
            // (x, u) at s for x₀ = columns, u: [e^{As}, ∫e^{As}B]
            let mut m = DMatrix::zeros(3, 3);
            m.view_mut((0, 0), (2, 2)).copy_from(&e);
            m.view_mut((0, 2), (2, 1)).copy_from(&int_b);
            m[(2, 2)] = 1.0;
            q_cost += m.transpose() * &w * &m * weight;
            q_noise += &e * &noise_w * e.transpose() * weight;
            if k < steps {
                int_b += (&e + &small * &e) * &b * (0.5 * h);
                e = &small * &e;
            }
        }
        // the reference accumulates 2e4 roundings of 1e-16
        assert!((&ad - &e).norm() < 1e-10, "{ad} vs {e}");
        assert!((&bd - &int_b).norm() < 1e-8);
        let qn = noise(&a, &noise_w, t);
        assert!((&qn - &q_noise).norm() < 1e-8 * qn.norm(), "{qn} vs {q_noise}");
        let (qd, nd, rd) = cost(&a, &b, &w, t);
        assert!((&qd - q_cost.view((0, 0), (2, 2))).norm() < 1e-8 * qd.norm());
        assert!((&nd - q_cost.view((0, 2), (2, 1))).norm() < 1e-8 * qd.norm());
        assert!((&rd - q_cost.view((2, 2), (1, 1))).norm() < 1e-8 * qd.norm());
    }

    #[test]
    fn lyapunov_of_a_scalar_and_an_unstable_system() {
        let m = |v: f64| DMatrix::from_element(1, 1, v);
        let x = lyapunov(&m(0.8), &m(2.0)).unwrap();
        assert!((x[(0, 0)] - 2.0 / (1.0 - 0.64)).abs() < 1e-13);
        assert!(matches!(lyapunov(&m(1.0), &m(1.0)), Err(LyapunovError::Unstable { .. })));
    }
}
