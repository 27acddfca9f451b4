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
}
