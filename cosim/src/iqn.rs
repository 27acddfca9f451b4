//! Interface quasi-Newton acceleration of a fixed point `x = H(x)` from its residual history
//! alone (no derivatives): IQN-ILS (Degroote et al. 2009).
//!
//! Every evaluation gives `x̃ = H(x)` and the residual `r = x̃ − x`. Successive evaluations give
//! secant pairs: `v = Δr` (columns of V) and `w = Δx̃` (columns of W). The next iterate is
//!
//!   `x⁺ = x̃ + W c` with `c = argmin ‖V c + r‖`,
//!
//! the columns of this time window and of the last `reuse` windows. The implicit inverse
//! Jacobian `J = W (VᵀV)⁻¹ Vᵀ` maps a residual change to an image change (for a linear H:
//! `J = A (A − I)⁻¹`, and the update is Newton's once V spans the space, so a linear problem of n
//! unknowns converges after at most n + 1 updates). The multi-vector variant (IQN-IMVJ, an
//! explicit J carried across windows) was tried on LT50m and needed more iterations everywhere
//! (docs/coupling.md), so it is not offered.
//!
//! The least-squares problem is solved by a QR decomposition built newest column first, with
//! the QR2 filter (Haelterman et al. 2016): a column that orthogonalization reduces to less than
//! `filter` of its norm carries no new direction and is deleted for good, so old information
//! gives way to new and the system stays well conditioned. When no secant information exists
//! yet, the update is a relaxed fixed-point step `x⁺ = x + ω r`.
//!
//! All vectors are as scaled by the caller (per unit group), so the least-squares norm weighs
//! forces and positions alike. Buffers are allocated once: at most n columns survive the filter.

use std::collections::VecDeque;

use crate::dense::dot;

/// Tuning of the interface quasi-Newton schemes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IqnOptions {
    /// Past time windows whose secant pairs IQN-ILS reuses (q).
    pub reuse: usize,
    /// QR2 filter limit in [0, 1): a column keeping less than this fraction of its norm after
    /// orthogonalization against the newer ones is deleted.
    pub filter: f64,
    /// Relaxation of the fixed-point step taken while no secant information exists.
    pub initial_relaxation: f64,
}

impl Default for IqnOptions {
    fn default() -> IqnOptions {
        IqnOptions { reuse: 32, filter: 1e-4, initial_relaxation: 0.1 }
    }
}

/// A secant pair and the time window it came from.
struct Column {
    v: Vec<f64>,
    w: Vec<f64>,
    window: u64,
}

/// The history and the buffers of one interface quasi-Newton iteration.
pub struct Accelerator {
    n: usize,
    options: IqnOptions,
    /// Newest first.
    cols: VecDeque<Column>,
    spare: Vec<Column>,
    window: u64,
    r: Vec<f64>,
    r_last: Vec<f64>,
    xt_last: Vec<f64>,
    has_last: bool,
    /// Q (column j at `q[j*n..]`) and R (row-major, `n` columns) of V.
    q: Vec<f64>,
    rm: Vec<f64>,
    c: Vec<f64>,
    drop: Vec<bool>,
}

impl Accelerator {
    pub fn new(n: usize, options: IqnOptions) -> Accelerator {
        Accelerator {
            n,
            options,
            cols: VecDeque::with_capacity(n + 1),
            spare: Vec::new(),
            window: 0,
            r: vec![0.0; n],
            r_last: vec![0.0; n],
            xt_last: vec![0.0; n],
            has_last: false,
            q: vec![0.0; n * n],
            rm: vec![0.0; n * n],
            c: vec![0.0; n],
            drop: Vec::with_capacity(n + 1),
        }
    }

    /// Secant pairs kept now.
    pub fn columns(&self) -> usize {
        self.cols.len()
    }

    /// Copies the whole history into `other` (of the same size), reusing its buffers: a step
    /// that is undone must leave the history as it was, for the step taken again to repeat
    /// the same iterates.
    pub fn copy_into(&self, other: &mut Accelerator) {
        while other.cols.len() > self.cols.len() {
            let c = other.cols.pop_back().expect("longer");
            other.spare.push(c);
        }
        while other.cols.len() < self.cols.len() {
            let c =
                other.spare.pop().unwrap_or_else(|| Column { v: vec![0.0; self.n], w: vec![0.0; self.n], window: 0 });
            other.cols.push_back(c);
        }
        for (a, b) in self.cols.iter().zip(other.cols.iter_mut()) {
            b.v.copy_from_slice(&a.v);
            b.w.copy_from_slice(&a.w);
            b.window = a.window;
        }
        other.window = self.window;
        other.has_last = self.has_last;
        other.r_last.copy_from_slice(&self.r_last);
        other.xt_last.copy_from_slice(&self.xt_last);
    }

    /// A new time window: forget the last iterate and the windows beyond the reuse limit.
    pub(crate) fn start_window(&mut self) {
        self.window += 1;
        self.has_last = false;
        let keep_from = self.window.saturating_sub(self.options.reuse as u64);
        while self.cols.back().is_some_and(|c| c.window < keep_from) {
            let c = self.cols.pop_back().expect("checked");
            self.spare.push(c);
        }
    }

    /// The window failed or was rejected: forget its secants.
    pub(crate) fn discard_window(&mut self) {
        while self.cols.front().is_some_and(|c| c.window == self.window) {
            let c = self.cols.pop_front().expect("checked");
            self.spare.push(c);
        }
        self.has_last = false;
    }

    /// Given the iterate `x` and its image `xt = H(x)`, overwrites `x` with the next iterate.
    pub fn update(&mut self, x: &mut [f64], xt: &[f64]) {
        let n = self.n;
        for i in 0..n {
            self.r[i] = xt[i] - x[i];
        }
        if self.has_last {
            let mut col = self.spare.pop().unwrap_or_else(|| Column { v: vec![0.0; n], w: vec![0.0; n], window: 0 });
            for i in 0..n {
                col.v[i] = self.r[i] - self.r_last[i];
                col.w[i] = xt[i] - self.xt_last[i];
            }
            col.window = self.window;
            self.cols.push_front(col);
        }
        self.r_last.copy_from_slice(&self.r);
        self.xt_last.copy_from_slice(xt);
        self.has_last = true;

        let m = self.factorize();
        if m == 0 {
            let w = self.options.initial_relaxation;
            for i in 0..n {
                x[i] += w * self.r[i];
            }
            return;
        }
        // c = −R⁻¹ Qᵀ r
        for j in 0..m {
            self.c[j] = -dot(&self.q[j * n..(j + 1) * n], &self.r);
        }
        back_substitute(&self.rm, n, m, &mut self.c[..m]);
        x.copy_from_slice(xt);
        for (j, col) in self.cols.iter().take(m).enumerate() {
            for i in 0..n {
                x[i] += self.c[j] * col.w[i];
            }
        }
    }

    /// QR of V (newest column first) with the QR2 filter; deletes the filtered columns and
    /// returns how many remain (Q, R of those, in the order of `cols`).
    fn factorize(&mut self) -> usize {
        let n = self.n;
        loop {
            self.drop.clear();
            let mut m = 0;
            for j in 0..self.cols.len() {
                if m == n {
                    self.drop.push(true); // the space is spanned: older columns add nothing
                    continue;
                }
                let v = &self.cols[j].v;
                let norm0 = dot(v, v).sqrt();
                let (q, rm) = (&mut self.q, &mut self.rm);
                q[m * n..(m + 1) * n].copy_from_slice(v);
                for i in 0..m {
                    rm[i * n + m] = 0.0;
                }
                // modified Gram–Schmidt, twice (the second pass restores orthogonality)
                for _ in 0..2 {
                    for i in 0..m {
                        let (done, cur) = q.split_at_mut(m * n);
                        let qi = &done[i * n..(i + 1) * n];
                        let cur = &mut cur[..n];
                        let p = dot(qi, cur);
                        rm[i * n + m] += p;
                        for a in 0..n {
                            cur[a] -= p * qi[a];
                        }
                    }
                }
                let cur = &mut q[m * n..(m + 1) * n];
                let norm = dot(cur, cur).sqrt();
                let keep = norm0 > 0.0 && norm > self.options.filter * norm0 && norm > 1e-13 * norm0;
                self.drop.push(!keep);
                if keep {
                    rm[m * n + m] = norm;
                    cur.iter_mut().for_each(|x| *x /= norm);
                    m += 1;
                }
            }
            if !self.drop.iter().any(|d| *d) {
                return m;
            }
            // delete the filtered columns and factorize again (Q and R must match `cols`)
            for j in (0..self.cols.len()).rev() {
                if self.drop[j] {
                    let c = self.cols.remove(j).expect("in range");
                    self.spare.push(c);
                }
            }
        }
    }
}

/// Solves `R z = b` in place for the leading m × m block of the upper triangular `rm` (row
/// stride n).
fn back_substitute(rm: &[f64], n: usize, m: usize, b: &mut [f64]) {
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|j| rm[i * n + j] * b[j]).sum();
        b[i] = (b[i] - s) / rm[i * n + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// H(x) = A x + b with a loop gain of spectral radius > 1 (the plain fixed point diverges).
    fn problem(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut a = vec![0.0; n * n];
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = 0.6 * rnd();
            }
            a[i * n + i] -= 1.5; // strongly coupled: |eigenvalues| beyond 1
        }
        let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
        // the fixed point: (I − A) x = b
        let mut m: Vec<f64> = (0..n * n).map(|k| f64::from(u8::from(k / n == k % n)) - a[k]).collect();
        let mut x = b.clone();
        assert!(crate::dense::solve_in_place(&mut m, n, &mut x));
        (a, b, x)
    }

    fn image(a: &[f64], b: &[f64], x: &[f64]) -> Vec<f64> {
        let n = b.len();
        (0..n).map(|i| dot(&a[i * n..(i + 1) * n], x) + b[i]).collect()
    }

    /// On a linear problem IQN-ILS reaches the fixed point after at most n + 1 updates (one
    /// relaxation, then n least-squares updates: V then spans the space and the update is
    /// Newton's), whatever the relaxation; the plain fixed point diverges on it.
    #[test]
    fn ils_solves_a_linear_problem_of_n_unknowns_in_n_plus_1_updates() {
        for n in [1, 3, 8] {
            let (a, b, exact) = problem(n);
            for filter in [0.0, 1e-3] {
                let mut acc = Accelerator::new(n, IqnOptions { reuse: 0, filter, initial_relaxation: 0.3 });
                acc.start_window();
                let mut x = vec![0.0; n];
                let mut updates = 0;
                let err = |x: &[f64]| x.iter().zip(&exact).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
                while err(&x) > 1e-10 {
                    let xt = image(&a, &b, &x);
                    acc.update(&mut x, &xt);
                    updates += 1;
                    assert!(updates <= n + 1, "n = {n}, filter {filter}: error {:e} after {updates} updates", err(&x));
                }
                eprintln!("n = {n}, filter {filter}: {updates} updates");
            }
            // the plain fixed point runs away
            let mut x = vec![0.0; n];
            for _ in 0..50 {
                x = image(&a, &b, &x);
            }
            assert!(x.iter().zip(&exact).any(|(p, q)| (p - q).abs() > 1.0), "n = {n}");
        }
    }

    /// With reuse, the next time window of the same linear problem (a new right-hand side) is
    /// solved by the first least-squares update: V from the last window spans the space.
    #[test]
    fn reused_columns_solve_the_next_window_in_one_update() {
        let n = 5;
        let (a, b, _) = problem(n);
        let solve = |acc: &mut Accelerator, b: &[f64]| {
            acc.start_window();
            let mut x = vec![0.0; n];
            for updates in 0..=n + 1 {
                let xt = image(&a, b, &x);
                let r = xt.iter().zip(&x).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
                if r < 1e-10 {
                    return updates;
                }
                acc.update(&mut x, &xt);
            }
            panic!("no convergence");
        };
        let mut acc = Accelerator::new(n, IqnOptions { reuse: 4, filter: 1e-6, initial_relaxation: 0.3 });
        let first = solve(&mut acc, &b);
        let b2: Vec<f64> = b.iter().map(|x| 2.0 * x + 0.1).collect();
        let second = solve(&mut acc, &b2);
        eprintln!("{first} then {second} updates");
        assert!(first <= n + 1 && second == 1, "{first}, {second}");
    }

    /// The filter deletes a column that repeats an older direction; the least-squares system
    /// stays solvable.
    #[test]
    fn filter_deletes_dependent_columns() {
        let n = 3;
        let mut acc = Accelerator::new(n, IqnOptions { reuse: 8, filter: 1e-2, initial_relaxation: 0.5 });
        // H(x) = 0.5 x along one direction only: every secant is parallel
        acc.start_window();
        let mut x = vec![1.0, 1.0, 1.0];
        for _ in 0..4 {
            let xt: Vec<f64> = x.iter().map(|v| 0.5 * v).collect();
            acc.update(&mut x, &xt);
        }
        assert!(acc.columns() <= 1, "{} columns kept", acc.columns());
        assert!(x.iter().all(|v| v.abs() < 1e-12), "{x:?}");
    }
}
