//! The integrators a Model Exchange unit is stepped by: Dormand–Prince 5(4) for non-stiff models
//! and an L-stable ESDIRK 3(2) for stiff ones, each with its local error estimate and a dense
//! output between the ends of its last step (for locating state events). The right-hand side is
//! the FMU ([`Rhs`]); every buffer is allocated once, at set-up.
//!
//! Why not a crate: the right-hand side is an FMU whose time, states and inputs are set before
//! every evaluation and whose failures carry context; a unit's solver state (step size, the
//! derivative kept from the last step) is saved and restored bit for bit with the FMU for the
//! iterating schemes; steps must allocate nothing. The crates looked at (`ode_solvers`,
//! `diffsol`, `russell_ode`) take a closure without failures, own their state, allocate per
//! call or link BLAS; none saves and restores its state.

use crate::system::UnitError;

/// The right-hand side `ẋ = f(t, x)`.
pub(crate) trait Rhs {
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), UnitError>;
}

/// Which integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Dormand–Prince 5(4), explicit, error control on the embedded 4th-order solution.
    Dopri5,
    /// ESDIRK 3(2) with four stages (Kennedy & Carpenter's ESDIRK3(2)4L[2]SA form: L-stable,
    /// stiffly accurate, stage order 2), Newton on each stage with a finite-difference Jacobian.
    Esdirk3,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Dopri5 => "dopri5",
            Method::Esdirk3 => "esdirk3",
        }
    }

    /// The order of the error estimate, for the step-size controller.
    fn estimate_order(self) -> f64 {
        match self {
            Method::Dopri5 => 4.0,
            Method::Esdirk3 => 2.0,
        }
    }
}

// Dormand–Prince 5(4): nodes, coefficients, the error weights (5th minus 4th order) and the
// dense output's (Hairer, Nørsett & Wanner, Solving ODEs I, the code DOPRI5).
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
];
const E: [f64; 7] =
    [71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0];
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// γ of the ESDIRK: the root of 6γ³ − 18γ² + 9γ − 1 = 0 that makes it L-stable.
const GAMMA: f64 = 0.435_866_521_508_459;
/// The third node.
const C3: f64 = 0.6;

/// The ESDIRK's coefficients from γ and c₃: stage order 2 at stages 2 and 3, order 3, stiffly
/// accurate (the last stage is the solution); the embedded second-order weights use stages 1
/// and 3 only.
struct Esdirk {
    c: [f64; 4],
    a: [[f64; 4]; 4],
    b_hat: [f64; 4],
}

fn esdirk() -> Esdirk {
    let g = GAMMA;
    let (c2, c3) = (2.0 * g, C3);
    let a32 = (c3 * c3 / 2.0 - g * c3) / c2;
    let a31 = c3 - a32 - g;
    // b1 + b2 + b3 = 1 − γ, c2 b2 + c3 b3 = 1/2 − γ, c2² b2 + c3² b3 = 1/3 − γ
    let (r2, r3) = (0.5 - g, 1.0 / 3.0 - g);
    let det = c2 * c3 * c3 - c3 * c2 * c2;
    let b2 = (r2 * c3 * c3 - c3 * r3) / det;
    let b3 = (c2 * r3 - c2 * c2 * r2) / det;
    let b1 = 1.0 - g - b2 - b3;
    Esdirk {
        c: [0.0, c2, c3, 1.0],
        a: [[0.0; 4], [g, g, 0.0, 0.0], [a31, a32, g, 0.0], [b1, b2, b3, g]],
        b_hat: [1.0 - 0.5 / c3, 0.0, 0.5 / c3, 0.0],
    }
}

/// Tolerances of the integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    pub rtol: f64,
    pub atol: f64,
}

/// What one attempted step gave.
pub(crate) struct Attempt {
    /// The scaled error norm (≤ 1: accept).
    pub err: f64,
    /// The implicit stages did not converge (retry smaller, whatever `err` says).
    pub failed: bool,
}

/// One integrator with its buffers; the state it keeps between steps is [`Integrator::h`].
pub(crate) struct Integrator {
    pub method: Method,
    pub tol: Tolerances,
    /// The next step size to try (0: not yet chosen).
    pub h: f64,
    n: usize,
    /// Stage derivatives, seven for Dormand–Prince (the seventh is f at the new point).
    k: Vec<Vec<f64>>,
    tmp: Vec<f64>,
    pub x_new: Vec<f64>,
    pub f_new: Vec<f64>,
    err: Vec<f64>,
    /// Dense output: the step's start and size, and its coefficients.
    t0: f64,
    step: f64,
    dense: [Vec<f64>; 5],
    // the implicit method's Newton matrix (row-major, LU in place), pivots, Jacobian, residual
    jac: Vec<f64>,
    lu: Vec<f64>,
    piv: Vec<usize>,
    res: Vec<f64>,
    fx: Vec<f64>,
    pub jacobians: u64,
}

impl Integrator {
    pub(crate) fn new(method: Method, tol: Tolerances, n: usize) -> Integrator {
        let v = || vec![0.0; n];
        Integrator {
            method,
            tol,
            h: 0.0,
            n,
            k: (0..7).map(|_| v()).collect(),
            tmp: v(),
            x_new: v(),
            f_new: v(),
            err: v(),
            t0: 0.0,
            step: 0.0,
            dense: [v(), v(), v(), v(), v()],
            jac: vec![0.0; n * n],
            lu: vec![0.0; n * n],
            piv: vec![0; n],
            res: v(),
            fx: v(),
            jacobians: 0,
        }
    }

    fn scale(&self, a: f64, b: f64) -> f64 {
        self.tol.atol + self.tol.rtol * a.abs().max(b.abs())
    }

    /// The scaled RMS norm of `v` against `x` and `x_new`.
    fn norm(&self, v: &[f64], x: &[f64]) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let s: f64 = (0..self.n).map(|i| (v[i] / self.scale(x[i], self.x_new[i])).powi(2)).sum();
        (s / self.n as f64).sqrt()
    }

    /// A first step size from the state and its derivative (Hairer's starting heuristic),
    /// at most `h_max`.
    pub(crate) fn initial_step(&self, x: &[f64], f: &[f64], h_max: f64) -> f64 {
        let d = |v: &[f64]| {
            let s: f64 = (0..self.n).map(|i| (v[i] / (self.tol.atol + self.tol.rtol * x[i].abs())).powi(2)).sum();
            (s / self.n.max(1) as f64).sqrt()
        };
        let (d0, d1) = (d(x), d(f));
        let h = if d0 < 1e-5 || d1 < 1e-5 { 1e-6 } else { 0.01 * d0 / d1 };
        h.min(h_max)
    }

    /// The next step size after a step with error norm `err` (accepted or not).
    pub(crate) fn next_size(&self, h: f64, err: f64, accepted: bool) -> f64 {
        let q = self.method.estimate_order() + 1.0;
        let factor = if err == 0.0 { 5.0 } else { 0.9 * err.powf(-1.0 / q) };
        let limit = if accepted { 5.0 } else { 1.0 };
        h * factor.clamp(0.2, limit)
    }

    /// One step of size `h` from `(t, x)` with `f0 = f(t, x)`: `x_new`, `f_new = f(t + h, x_new)`
    /// (the right-hand side is left at the new point), the error, the dense output.
    pub(crate) fn attempt(
        &mut self,
        rhs: &mut dyn Rhs,
        t: f64,
        h: f64,
        x: &[f64],
        f0: &[f64],
    ) -> Result<Attempt, UnitError> {
        (self.t0, self.step) = (t, h);
        match self.method {
            Method::Dopri5 => self.dopri(rhs, t, h, x, f0),
            Method::Esdirk3 => self.esdirk(rhs, t, h, x, f0),
        }
    }

    fn dopri(&mut self, rhs: &mut dyn Rhs, t: f64, h: f64, x: &[f64], f0: &[f64]) -> Result<Attempt, UnitError> {
        let n = self.n;
        self.k[0].copy_from_slice(f0);
        for s in 1..7 {
            for i in 0..n {
                let mut acc = 0.0;
                for j in 0..s {
                    acc += A[s][j] * self.k[j][i];
                }
                self.tmp[i] = x[i] + h * acc;
            }
            let t_s = if s == 6 { t + h } else { t + C[s] * h };
            rhs.eval(t_s, &self.tmp, &mut self.k[s])?;
            if s == 6 {
                self.x_new.copy_from_slice(&self.tmp);
            }
        }
        self.f_new.copy_from_slice(&self.k[6]);
        for i in 0..n {
            let mut e = 0.0;
            for s in 0..7 {
                e += E[s] * self.k[s][i];
            }
            self.err[i] = h * e;
        }
        let err = self.norm(&self.err, x);
        // dense output (continuous extension of order 4)
        for i in 0..n {
            let d1 = self.x_new[i] - x[i];
            let d2 = h * self.k[0][i] - d1;
            let d3 = d1 - h * self.k[6][i] - d2;
            let mut d4 = 0.0;
            for s in 0..7 {
                d4 += D[s] * self.k[s][i];
            }
            self.dense[0][i] = x[i];
            self.dense[1][i] = d1;
            self.dense[2][i] = d2;
            self.dense[3][i] = d3;
            self.dense[4][i] = h * d4;
        }
        Ok(Attempt { err, failed: false })
    }

    /// The state at `t` inside the last step.
    pub(crate) fn dense_at(&self, t: f64, out: &mut [f64]) {
        let th = ((t - self.t0) / self.step).clamp(0.0, 1.0);
        let th1 = 1.0 - th;
        let d = &self.dense;
        for i in 0..self.n {
            out[i] = d[0][i] + th * (d[1][i] + th1 * (d[2][i] + th * (d[3][i] + th1 * d[4][i])));
        }
    }

    fn esdirk(&mut self, rhs: &mut dyn Rhs, t: f64, h: f64, x: &[f64], f0: &[f64]) -> Result<Attempt, UnitError> {
        let n = self.n;
        let m = esdirk();
        self.k[0].copy_from_slice(f0);
        // the Jacobian at the step's start, by forward differences; the Newton matrix I − hγJ
        self.jacobian(rhs, t, x, f0)?;
        for r in 0..n {
            for c in 0..n {
                self.lu[r * n + c] = f64::from(u8::from(r == c)) - h * GAMMA * self.jac[r * n + c];
            }
        }
        if !lu_factor(&mut self.lu, &mut self.piv, n) {
            return Ok(Attempt { err: f64::INFINITY, failed: true });
        }
        for s in 1..4 {
            // X = base + hγ f(X), base = x + h Σ_{j<s} a_sj k_j; start from the explicit guess
            for i in 0..n {
                let mut acc = 0.0;
                for j in 0..s {
                    acc += m.a[s][j] * self.k[j][i];
                }
                self.res[i] = x[i] + h * acc; // base
                self.tmp[i] = x[i] + m.c[s] * h * self.k[0][i];
            }
            let t_s = t + m.c[s] * h;
            let mut converged = false;
            let mut last = f64::INFINITY;
            for _ in 0..10 {
                rhs.eval(t_s, &self.tmp, &mut self.fx)?;
                // the correction −(X − hγ f(X) − base), solved with the Newton matrix
                for i in 0..n {
                    self.err[i] = -(self.tmp[i] - h * GAMMA * self.fx[i] - self.res[i]);
                }
                lu_solve(&self.lu, &self.piv, n, &mut self.err);
                for i in 0..n {
                    self.tmp[i] += self.err[i];
                }
                let size = {
                    let s: f64 = (0..n).map(|i| (self.err[i] / self.scale(x[i], self.tmp[i])).powi(2)).sum();
                    (s / n.max(1) as f64).sqrt()
                };
                if !size.is_finite() || size > 2.0 * last {
                    break;
                }
                last = size;
                if size <= 1e-3 {
                    converged = true;
                    break;
                }
            }
            if !converged {
                return Ok(Attempt { err: f64::INFINITY, failed: true });
            }
            rhs.eval(t_s, &self.tmp, &mut self.fx)?;
            self.k[s].copy_from_slice(&self.fx);
        }
        // stiffly accurate: the last stage is the solution; the error against the embedded
        // second-order solution, filtered by (I − hγJ)⁻¹ so that stiff components do not swamp it
        self.x_new.copy_from_slice(&self.tmp);
        self.f_new.copy_from_slice(&self.k[3]);
        for i in 0..n {
            let mut hat = x[i];
            for j in 0..4 {
                hat += h * m.b_hat[j] * self.k[j][i];
            }
            self.err[i] = self.x_new[i] - hat;
        }
        lu_solve(&self.lu, &self.piv, n, &mut self.err);
        let err = self.norm(&self.err, x);
        // dense output: the cubic Hermite interpolant of both ends, in the same form
        for i in 0..n {
            let d1 = self.x_new[i] - x[i];
            let d2 = h * f0[i] - d1;
            let d3 = d1 - h * self.f_new[i] - d2;
            self.dense[0][i] = x[i];
            self.dense[1][i] = d1;
            self.dense[2][i] = d2;
            self.dense[3][i] = d3;
            self.dense[4][i] = 0.0;
        }
        Ok(Attempt { err, failed: false })
    }

    /// `∂f/∂x` at `(t, x)` by forward differences into `self.jac` (row-major).
    fn jacobian(&mut self, rhs: &mut dyn Rhs, t: f64, x: &[f64], f0: &[f64]) -> Result<(), UnitError> {
        let n = self.n;
        self.jacobians += 1;
        self.tmp.copy_from_slice(x);
        for c in 0..n {
            let delta = f64::EPSILON.sqrt() * x[c].abs().max(self.tol.atol / self.tol.rtol.max(1e-300)).max(1e-8);
            self.tmp[c] = x[c] + delta;
            rhs.eval(t, &self.tmp, &mut self.fx)?;
            for r in 0..n {
                self.jac[r * n + c] = (self.fx[r] - f0[r]) / delta;
            }
            self.tmp[c] = x[c];
        }
        Ok(())
    }
}

/// LU with partial pivoting in place (row-major, n × n); false if singular.
fn lu_factor(a: &mut [f64], piv: &mut [usize], n: usize) -> bool {
    for k in 0..n {
        let p = (k..n).max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs())).unwrap_or(k);
        piv[k] = p;
        if !(a[p * n + k].abs() > 0.0) {
            return false;
        }
        if p != k {
            for c in 0..n {
                a.swap(k * n + c, p * n + c);
            }
        }
        for i in k + 1..n {
            let l = a[i * n + k] / a[k * n + k];
            a[i * n + k] = l;
            for c in k + 1..n {
                a[i * n + c] -= l * a[k * n + c];
            }
        }
    }
    true
}

fn lu_solve(a: &[f64], piv: &[usize], n: usize, b: &mut [f64]) {
    for k in 0..n {
        b.swap(k, piv[k]);
        for i in k + 1..n {
            b[i] -= a[i * n + k] * b[k];
        }
    }
    for k in (0..n).rev() {
        for c in k + 1..n {
            b[k] -= a[k * n + c] * b[c];
        }
        b[k] /= a[k * n + k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct F<G: FnMut(f64, &[f64], &mut [f64])>(G);
    impl<G: FnMut(f64, &[f64], &mut [f64])> Rhs for F<G> {
        fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) -> Result<(), UnitError> {
            (self.0)(t, x, dx);
            Ok(())
        }
    }

    /// Integrates `rhs` from `x0` over [0, t_end] with error control; returns the end state.
    fn integrate(method: Method, rtol: f64, rhs: &mut dyn Rhs, x0: &[f64], t_end: f64) -> (Vec<f64>, u64) {
        let n = x0.len();
        let mut it = Integrator::new(method, Tolerances { rtol, atol: rtol }, n);
        let (mut t, mut x, mut f) = (0.0, x0.to_vec(), vec![0.0; n]);
        rhs.eval(t, &x, &mut f).unwrap();
        let mut h = it.initial_step(&x, &f, t_end);
        let mut steps = 0;
        while t < t_end {
            h = h.min(t_end - t);
            let a = it.attempt(rhs, t, h, &x, &f).unwrap();
            if !a.failed && a.err <= 1.0 {
                t += h;
                x.copy_from_slice(&it.x_new);
                f.copy_from_slice(&it.f_new);
                steps += 1;
            }
            h = it.next_size(h, a.err.min(1e10), !a.failed && a.err <= 1.0);
        }
        (x, steps)
    }

    #[test]
    fn the_esdirk_coefficients_meet_the_order_conditions_and_l_stability() {
        let m = esdirk();
        let b = m.a[3];
        let sum = |f: &dyn Fn(usize) -> f64| (0..4).map(f).sum::<f64>();
        assert!((sum(&|i| b[i]) - 1.0).abs() < 1e-15);
        assert!((sum(&|i| b[i] * m.c[i]) - 0.5).abs() < 1e-15);
        assert!((sum(&|i| b[i] * m.c[i] * m.c[i]) - 1.0 / 3.0).abs() < 1e-15);
        let ac = |i: usize| (0..4).map(|j| m.a[i][j] * m.c[j]).sum::<f64>();
        assert!((sum(&|i| b[i] * ac(i)) - 1.0 / 6.0).abs() < 1e-15);
        for i in 0..4 {
            assert!(((0..4).map(|j| m.a[i][j]).sum::<f64>() - m.c[i]).abs() < 1e-15, "row sums are the nodes");
        }
        assert!((sum(&|i| m.b_hat[i]) - 1.0).abs() < 1e-15 && (sum(&|i| m.b_hat[i] * m.c[i]) - 0.5).abs() < 1e-15);
        // stability function R(z) on y' = z y, one step of size 1, very stiff: R → 0
        for z in [-1e6, -1e9] {
            let mut y = [0.0; 4];
            y[0] = 1.0;
            let k0 = z;
            let mut k = [k0, 0.0, 0.0, 0.0];
            for s in 1..4 {
                let base = 1.0 + (0..s).map(|j| m.a[s][j] * k[j]).sum::<f64>();
                y[s] = base / (1.0 - GAMMA * z);
                k[s] = z * y[s];
            }
            assert!(y[3].abs() < 10.0 / -z, "R({z}) = {}", y[3]);
        }
    }

    #[test]
    fn dopri5_reaches_the_exact_solution_and_its_dense_output_is_fifth_order_accurate() {
        let mut rhs = F(|_t: f64, x: &[f64], dx: &mut [f64]| dx[0] = -x[0]);
        let (x, _) = integrate(Method::Dopri5, 1e-10, &mut rhs, &[1.0], 3.0);
        assert!((x[0] - (-3.0_f64).exp()).abs() < 1e-9, "{}", x[0]);
        // dense output inside one step of x' = cos t against sin t: error O(h⁵)
        let errors: Vec<f64> = [0.2, 0.1]
            .iter()
            .map(|&h| {
                let mut it = Integrator::new(Method::Dopri5, Tolerances { rtol: 1e-6, atol: 1e-6 }, 1);
                let mut rhs = F(|t: f64, _x: &[f64], dx: &mut [f64]| dx[0] = t.cos());
                it.attempt(&mut rhs, 0.3, h, &[0.3_f64.sin()], &[0.3_f64.cos()]).unwrap();
                let mut out = [0.0];
                (1..10)
                    .map(|j| {
                        let t = 0.3 + h * f64::from(j) / 10.0;
                        it.dense_at(t, &mut out);
                        (out[0] - t.sin()).abs()
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let order = (errors[0] / errors[1]).log2();
        assert!(order > 4.5 && errors[0] < 1e-7, "dense output errors {errors:?}, order {order}");
    }

    #[test]
    fn esdirk3_is_third_order_and_integrates_a_stiff_problem_in_few_steps() {
        let mut rhs = F(|_t: f64, x: &[f64], dx: &mut [f64]| dx[0] = -x[0]);
        let (x, _) = integrate(Method::Esdirk3, 1e-8, &mut rhs, &[1.0], 2.0);
        assert!((x[0] - (-2.0_f64).exp()).abs() < 1e-7, "{}", x[0]);
        // y' = −1e6 (y − cos t): the solution follows cos t; an explicit method would need
        // ~1e6 steps for stability alone
        let mut stiff = F(|t: f64, x: &[f64], dx: &mut [f64]| dx[0] = -1e6 * (x[0] - t.cos()));
        let (x, steps) = integrate(Method::Esdirk3, 1e-6, &mut stiff, &[1.0], 2.0);
        let exact = 2.0_f64.cos() - 2.0_f64.sin() / 1e6; // to first order in 1/1e6
        assert!((x[0] - exact).abs() < 1e-5, "{} vs {exact}", x[0]);
        assert!(steps < 2000, "{steps} steps");
    }
}
