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
//! The least-squares problem is solved by a QR decomposition of V, newest column first, with
//! the QR2 filter (Haelterman et al. 2016): a column that orthogonalization against the newer
//! ones reduces to less than `filter` of its norm carries no new direction and is deleted for
//! good, so old information gives way to new and the system stays well conditioned. The QR is
//! kept from update to update: a new column enters in front by Givens rotations, a deleted one
//! leaves by Givens rotations, the oldest by dropping the last row and column (O(n·m) per
//! update instead of the O(n·m²) of a new factorization). It is built anew, by Gram–Schmidt,
//! where an update would lose accuracy (a new column nearly in the span of the others) and
//! after a discarded window. When no secant information exists yet, the update is a relaxed
//! fixed-point step `x⁺ = x + ω r`.
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

/// A secant pair, the norm of `v` (the filter's reference) and the time window it came from.
struct Column {
    v: Vec<f64>,
    w: Vec<f64>,
    norm: f64,
    window: u64,
}

impl Column {
    fn zeros(n: usize) -> Column {
        Column { v: vec![0.0; n], w: vec![0.0; n], norm: 0.0, window: 0 }
    }
}

/// Below this share of its norm left by orthogonalization, a new column is not rotated into
/// the kept QR (its direction would carry the rounding of the others) but the QR is built anew.
const REBUILD_BELOW: f64 = 1e-8;

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
    /// Q (column j at `q[j*n..]`) and R (row-major, `n` columns) of V: of all `cols` when
    /// `qr_current`.
    q: Vec<f64>,
    rm: Vec<f64>,
    qr_current: bool,
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
            qr_current: true,
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
            let c = other.spare.pop().unwrap_or_else(|| Column::zeros(self.n));
            other.cols.push_back(c);
        }
        for (a, b) in self.cols.iter().zip(other.cols.iter_mut()) {
            b.v.copy_from_slice(&a.v);
            b.w.copy_from_slice(&a.w);
            (b.norm, b.window) = (a.norm, a.window);
        }
        let used = self.cols.len() * self.n;
        other.q[..used].copy_from_slice(&self.q[..used]);
        other.rm[..used].copy_from_slice(&self.rm[..used]);
        other.qr_current = self.qr_current;
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
        // the oldest columns are the last ones: Q and R lose their last column and row
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
            self.qr_current = false;
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
            let mut col = self.spare.pop().unwrap_or_else(|| Column::zeros(n));
            for i in 0..n {
                col.v[i] = self.r[i] - self.r_last[i];
                col.w[i] = xt[i] - self.xt_last[i];
            }
            col.norm = dot(&col.v, &col.v).sqrt();
            col.window = self.window;
            self.push_front(col);
        }
        self.r_last.copy_from_slice(&self.r);
        self.xt_last.copy_from_slice(xt);
        self.has_last = true;

        if !self.qr_current {
            self.factorize();
        }
        let m = self.cols.len();
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

    /// Adds a secant pair as the newest column, rotating it into the kept QR, and applies the
    /// filter to the older columns.
    fn push_front(&mut self, col: Column) {
        let n = self.n;
        if !(col.norm > 0.0) {
            self.spare.push(col); // no direction at all (or not finite): the factorization refuses it too
            return;
        }
        if self.cols.len() == n {
            // the space is spanned: the oldest column adds nothing beside the new one
            let c = self.cols.pop_back().expect("n > 0 columns");
            self.spare.push(c);
        }
        self.cols.push_front(col);
        if !self.qr_current {
            return;
        }
        let m = self.cols.len() - 1; // the columns of the kept QR
        // v = Q p + ρ q_m
        let (q, rm, p) = (&mut self.q, &mut self.rm, &mut self.c);
        q[m * n..(m + 1) * n].copy_from_slice(&self.cols[0].v);
        let rho = orthogonalize(q, n, m, p);
        if !(rho > REBUILD_BELOW * self.cols[0].norm) {
            self.qr_current = false;
            return;
        }
        q[m * n..(m + 1) * n].iter_mut().for_each(|x| *x /= rho);
        // [v V] = [Q q_m] H with H = [(p; ρ), (R; 0)]: shift R right by one column, put (p; ρ)
        // in front; then rotate rows (k, k+1), k = m−1 … 0, to clear the first column below
        // its top (each rotation fills only the diagonal of the column it reaches).
        for i in 0..m {
            rm.copy_within(i * n..i * n + m, i * n + 1);
            rm[i * n] = p[i];
        }
        rm[m * n] = rho;
        rm[m * n + 1..m * n + m + 1].fill(0.0);
        for k in (0..m).rev() {
            eliminate(q, rm, n, k, 0, k + 1..m + 1);
        }
        // The QR2 filter: column j's diagonal is its norm orthogonal to the newer columns.
        let mut j = 1;
        while j < self.cols.len() {
            let d = self.rm[j * n + j].abs();
            let norm0 = self.cols[j].norm;
            if d > self.options.filter * norm0 && d > 1e-13 * norm0 {
                j += 1;
            } else {
                self.delete_column(j);
            }
        }
    }

    /// Deletes column j from `cols` and from the kept QR (Givens rotations restore R's triangle).
    fn delete_column(&mut self, j: usize) {
        let n = self.n;
        let m = self.cols.len();
        let c = self.cols.remove(j).expect("in range");
        self.spare.push(c);
        let (q, rm) = (&mut self.q, &mut self.rm);
        for i in 0..m {
            rm.copy_within(i * n + j + 1..i * n + m, i * n + j);
        }
        // R is now upper Hessenberg from column j on: clear R[l+1][l]
        for l in j..m - 1 {
            eliminate(q, rm, n, l, l, l + 1..m - 1);
        }
    }

    /// QR of V (newest column first) with the QR2 filter, by Gram–Schmidt; deletes the filtered
    /// columns (Q, R of those left, in the order of `cols`).
    fn factorize(&mut self) {
        let n = self.n;
        loop {
            self.drop.clear();
            let mut m = 0;
            for j in 0..self.cols.len() {
                if m == n {
                    self.drop.push(true); // the space is spanned: older columns add nothing
                    continue;
                }
                let norm0 = self.cols[j].norm;
                let (q, rm, p) = (&mut self.q, &mut self.rm, &mut self.c);
                q[m * n..(m + 1) * n].copy_from_slice(&self.cols[j].v);
                let norm = orthogonalize(q, n, m, p);
                for i in 0..m {
                    rm[i * n + m] = p[i];
                }
                let cur = &mut q[m * n..(m + 1) * n];
                let keep = norm0 > 0.0 && norm > self.options.filter * norm0 && norm > 1e-13 * norm0;
                self.drop.push(!keep);
                if keep {
                    rm[m * n + m] = norm;
                    rm[m * n..m * n + m].fill(0.0); // below the diagonal: the rotations read it
                    cur.iter_mut().for_each(|x| *x /= norm);
                    m += 1;
                }
            }
            if !self.drop.iter().any(|d| *d) {
                self.qr_current = true;
                return;
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

/// Orthogonalizes column m of Q (column j at `q[j*n..]`) against columns 0..m by modified
/// Gram–Schmidt, twice (the second pass restores orthogonality); `p[..m]` gets the projections
/// taken off, and the norm left is returned.
fn orthogonalize(q: &mut [f64], n: usize, m: usize, p: &mut [f64]) -> f64 {
    p[..m].fill(0.0);
    let (done, cur) = q.split_at_mut(m * n);
    let cur = &mut cur[..n];
    for _ in 0..2 {
        for i in 0..m {
            let qi = &done[i * n..(i + 1) * n];
            let d = dot(qi, cur);
            p[i] += d;
            for a in 0..n {
                cur[a] -= d * qi[a];
            }
        }
    }
    dot(cur, cur).sqrt()
}

/// Clears `rm[k+1][col]` against `rm[k][col]` by a Givens rotation of rows (k, k+1), applied to
/// the columns `rest` of R too and to columns (k, k+1) of Q, so that Q R is unchanged.
fn eliminate(q: &mut [f64], rm: &mut [f64], n: usize, k: usize, col: usize, rest: std::ops::Range<usize>) {
    let (a, b) = (rm[k * n + col], rm[(k + 1) * n + col]);
    if b == 0.0 {
        return;
    }
    let r = a.hypot(b);
    let (c, s) = (a / r, b / r);
    rm[k * n + col] = r;
    rm[(k + 1) * n + col] = 0.0;
    rotate_rows(rm, n, k, rest, c, s);
    rotate_columns(q, n, k, c, s);
}

/// Applies the rotation `[c s; −s c]` to rows (k, k+1) of the row-major `rm` (row stride n),
/// in the columns `cols`.
fn rotate_rows(rm: &mut [f64], n: usize, k: usize, cols: std::ops::Range<usize>, c: f64, s: f64) {
    for j in cols {
        let (a, b) = (rm[k * n + j], rm[(k + 1) * n + j]);
        rm[k * n + j] = c * a + s * b;
        rm[(k + 1) * n + j] = c * b - s * a;
    }
}

/// The same rotation on columns (k, k+1) of Q (column j at `q[j*n..]`), so that Q R is unchanged.
fn rotate_columns(q: &mut [f64], n: usize, k: usize, c: f64, s: f64) {
    let (left, right) = q.split_at_mut((k + 1) * n);
    let (qk, qk1) = (&mut left[k * n..], &mut right[..n]);
    for a in 0..n {
        let (x, y) = (qk[a], qk1[a]);
        qk[a] = c * x + s * y;
        qk1[a] = c * y - s * x;
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

    /// The kept QR, updated by rotations over thousands of windows, gives the iterates a QR
    /// built anew at every update gives (the same history fed to both), and stays a QR of V.
    #[test]
    fn kept_qr_matches_a_new_factorization_over_many_windows() {
        let n = 6;
        let (a, b, _) = problem(n);
        for filter in [1e-4, 1e-2] {
            let options = IqnOptions { reuse: 8, filter, initial_relaxation: 0.3 };
            let (mut kept, mut fresh) = (Accelerator::new(n, options), Accelerator::new(n, options));
            let (mut worst, mut updates, mut rebuilt) = (0.0f64, 0, 0);
            let mut x = vec![0.0; n];
            for window in 0..3000 {
                let shift = 1.0 + 0.5 * (f64::from(window) * 0.01).sin();
                let bw: Vec<f64> = b.iter().map(|v| v * shift).collect();
                kept.start_window();
                fresh.start_window();
                for _ in 0..12 {
                    // mildly nonlinear, so that the secants keep changing
                    let mut xt = image(&a, &bw, &x);
                    xt.iter_mut().zip(&x).for_each(|(t, v)| *t += 0.05 * v.sin());
                    if xt.iter().zip(&x).all(|(p, q)| (p - q).abs() < 1e-12) {
                        break;
                    }
                    let mut x_fresh = x.clone();
                    fresh.qr_current = false;
                    fresh.update(&mut x_fresh, &xt);
                    rebuilt += usize::from(!kept.qr_current);
                    kept.update(&mut x, &xt);
                    let scale = x_fresh.iter().fold(1.0f64, |m, v| m.max(v.abs()));
                    let diff = x.iter().zip(&x_fresh).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
                    worst = worst.max(diff / scale);
                    assert_eq!(kept.columns(), fresh.columns(), "window {window}");
                    updates += 1;
                }
            }
            // Q orthonormal and Q R = V after all those rotations
            let m = kept.columns();
            let (q, rm) = (&kept.q, &kept.rm);
            let mut defect = 0.0f64;
            for i in 0..m {
                for j in 0..m {
                    let e = f64::from(u8::from(i == j));
                    defect = defect.max((dot(&q[i * n..(i + 1) * n], &q[j * n..(j + 1) * n]) - e).abs());
                }
                let v = &kept.cols[i].v;
                for row in 0..n {
                    let qr: f64 = (0..=i).map(|k| q[k * n + row] * rm[k * n + i]).sum();
                    defect = defect.max((qr - v[row]).abs() / kept.cols[i].norm);
                }
            }
            eprintln!(
                "filter {filter}: {updates} updates, {rebuilt} built anew, {m} columns, largest difference {worst:e}, QR defect {defect:e}"
            );
            assert!(worst < 1e-9, "filter {filter}: iterates differ by {worst:e}");
            assert!(defect < 1e-12, "filter {filter}: QR defect {defect:e}");
            assert!(m > 0 && updates > 5000, "{m} columns, {updates} updates");
        }
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
