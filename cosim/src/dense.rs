//! Small dense linear algebra for the interface (tens of unknowns), in reused buffers.

/// Solves the dense system `a x = b` (row-major `a`, n × n) in place by Gaussian elimination
/// with partial pivoting. `b` becomes x; false if `a` is singular.
pub fn solve_in_place(a: &mut [f64], n: usize, b: &mut [f64]) -> bool {
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i * n + c].abs().total_cmp(&a[j * n + c].abs())).expect("n > c");
        if a[p * n + c] == 0.0 || !a[p * n + c].is_finite() {
            return false;
        }
        if p != c {
            for j in 0..n {
                a.swap(p * n + j, c * n + j);
            }
            b.swap(p, c);
        }
        for i in c + 1..n {
            let f = a[i * n + c] / a[c * n + c];
            if f != 0.0 {
                for j in c..n {
                    a[i * n + j] -= f * a[c * n + j];
                }
                b[i] -= f * b[c];
            }
        }
    }
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|j| a[c * n + j] * b[j]).sum();
        b[c] = (b[c] - s) / a[c * n + c];
    }
    true
}

/// Solves `(I − M) x = b` (row-major `M`, n × n) for the interface Newton step, in reused
/// buffers. With a block `p` of unknowns whose own block `M_pp` is zero (the inputs of a unit
/// none of whose inputs takes its own outputs), those are eliminated first:
/// `x_p = b_p + M_pq x_q` and `(I − M_qq − M_qp M_pq) x_q = b_q + M_qp b_p`, a dense system of
/// the other |q| unknowns only (LT50m: the 6 wrench inputs instead of all 25).
pub struct IdentityMinus {
    n: usize,
    p: std::ops::Range<usize>,
    /// The unknowns outside `p`.
    q: Vec<usize>,
    reduced: Vec<f64>,
    rhs: Vec<f64>,
    /// `M_pq`, |p| × |q|.
    mpq: Vec<f64>,
}

impl IdentityMinus {
    /// For n unknowns, eliminating `p` first (empty: a dense solve of all). The caller
    /// guarantees `M_pp = 0` for every `M` it passes to [`IdentityMinus::solve`].
    pub fn new(n: usize, p: std::ops::Range<usize>) -> IdentityMinus {
        assert!(p.end <= n, "the eliminated block {p:?} lies outside the {n} unknowns");
        let q: Vec<usize> = (0..n).filter(|i| !p.contains(i)).collect();
        let nq = q.len();
        let mpq = vec![0.0; p.len() * nq];
        IdentityMinus { n, p, q, reduced: vec![0.0; nq * nq], rhs: vec![0.0; nq], mpq }
    }

    /// The unknowns solved densely.
    pub fn reduced_size(&self) -> usize {
        self.q.len()
    }

    /// `b` becomes x; false if the (reduced) matrix is singular.
    pub fn solve(&mut self, m: &[f64], b: &mut [f64]) -> bool {
        let n = self.n;
        debug_assert!(m.len() == n * n && b.len() == n);
        self.solve_by_rows(|i| (1.0, &m[i * n..(i + 1) * n]), b)
    }

    /// As [`IdentityMinus::solve`] with row i of `M` given as `(g, r)`: `M_ij = g · r_j` (the
    /// interface: an input's gain times its source output's row of ∂Y/∂U, no n × n copy).
    pub fn solve_by_rows<'m>(&mut self, row: impl Fn(usize) -> (f64, &'m [f64]), b: &mut [f64]) -> bool {
        let nq = self.q.len();
        let IdentityMinus { p, q, reduced, rhs, mpq, .. } = self;
        // M_pq, compact
        for (k, i) in p.clone().enumerate() {
            let (g, r) = row(i);
            for (x, &qc) in mpq[k * nq..(k + 1) * nq].iter_mut().zip(q.iter()) {
                *x = g * r[qc];
            }
        }
        let bp = &b[p.clone()];
        for (a, &qa) in q.iter().enumerate() {
            let (g, r) = row(qa);
            let out = &mut reduced[a * nq..(a + 1) * nq];
            for (c, &qc) in q.iter().enumerate() {
                out[c] = f64::from(u8::from(a == c)) - g * r[qc];
            }
            let mut ra = b[qa];
            for ((&rk, &bk), mk) in r[p.clone()].iter().zip(bp).zip(mpq.chunks_exact(nq)) {
                let mqi = g * rk;
                if mqi != 0.0 {
                    for (o, x) in out.iter_mut().zip(mk) {
                        *o -= mqi * x;
                    }
                    ra += mqi * bk;
                }
            }
            rhs[a] = ra;
        }
        if !solve_in_place(reduced, nq, rhs) {
            return false;
        }
        for (k, i) in p.clone().enumerate() {
            b[i] += mpq[k * nq..(k + 1) * nq].iter().zip(rhs.iter()).map(|(m, x)| m * x).sum::<f64>();
        }
        for (&qa, x) in q.iter().zip(rhs.iter()) {
            b[qa] = *x;
        }
        true
    }
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_solve_needs_pivoting_and_matches_the_product() {
        // a zero leading entry forces a row swap
        let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3).map(|i| (0..3).map(|j| a0[i * 3 + j] * x[j]).sum()).collect();
        let mut a = a0.to_vec();
        assert!(solve_in_place(&mut a, 3, &mut b));
        for k in 0..3 {
            assert!((b[k] - x[k]).abs() < 1e-14);
        }
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(!solve_in_place(&mut singular, 2, &mut [1.0, 1.0]));
    }

    /// (I − M) x against the right-hand side, largest difference.
    fn misfit(m: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let n = x.len();
        (0..n).map(|i| (x[i] - (0..n).map(|j| m[i * n + j] * x[j]).sum::<f64>() - b[i]).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn block_elimination_solves_what_the_dense_solve_solves() {
        // two units: inputs 0..3 take unit B's outputs, 3..7 unit A's; M_pp = 0 for either block
        let n = 7;
        let mut m = vec![0.0; n * n];
        let mut seed = 0.3f64;
        let mut next = || {
            seed = (seed * 9301.0 + 0.49297).fract();
            2.0 * seed - 1.0
        };
        for i in 0..n {
            for j in 0..n {
                if (i < 3) != (j < 3) {
                    m[i * n + j] = next();
                }
            }
        }
        let b: Vec<f64> = (0..n).map(|_| next()).collect();
        let mut dense = IdentityMinus::new(n, 0..0);
        assert_eq!(dense.reduced_size(), n);
        let mut x_dense = b.clone();
        assert!(dense.solve(&m, &mut x_dense));
        assert!(misfit(&m, &x_dense, &b) < 1e-13);
        for p in [3..7, 0..3] {
            let mut blocks = IdentityMinus::new(n, p.clone());
            assert_eq!(blocks.reduced_size(), n - p.len());
            let mut x = b.clone();
            assert!(blocks.solve(&m, &mut x));
            assert!(misfit(&m, &x, &b) < 1e-13, "{p:?}");
            assert!(x.iter().zip(&x_dense).all(|(a, d)| (a - d).abs() < 1e-13), "{p:?}");
        }
        // a singular reduced system is reported: M_qp M_pq = I makes I − M_qp M_pq zero
        let mut s = vec![0.0; 4];
        (s[1], s[2]) = (1.0, 1.0);
        assert!(!IdentityMinus::new(2, 1..2).solve(&s, &mut [1.0, 1.0]));
    }
}
