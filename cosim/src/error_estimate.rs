//! The local error of a step of a time stepper, estimated from the quantities it produces
//! alone: whatever makes those quantities — a coupled co-simulation step or the monolithic
//! model — the estimate is the same. Two kinds ([`Kind`]): predictor against corrector for a
//! second-order stepper (below), and step doubling, which assumes nothing of the order.
//!
//! The predictor: the quantities of the last three accepted time points, extrapolated by their parabola to the
//! end of the step, against the values the step produced. Their difference is the third divided
//! difference over the four points times `(t − t₀)(t − t₁)(t − t₂)`, so it gives `U'''` at no
//! extra cost (no step is taken twice), and with it the local error of a second-order
//! integrator, about `h³ |U'''| / 12` (the trapezoidal rule's constant; see `ERROR_CONSTANT`).
//!
//! Tolerance: local errors of an oscillating system add up (a phase error grows with every
//! step), so the estimate is held per unit of time — error per unit step over the run's
//! horizon T: `|est_i| · T / h ≤ atol · scale_i + rtol · range_i`, whose sum over the run stays
//! within the tolerance; the norm is the root mean square over the quantities. `scale_i` is the
//! scale of the quantity's group (e.g. the components of a force) and `range_i` the largest
//! departure of the group's quantities from their initial values so far — relative to how far
//! each quantity moves, so that positions metres from the origin are not judged by their
//! distance to it. The predictor's history starts after the first step (the start may be
//! abrupt, a kink no extrapolation may span), so the first three steps have nothing to be judged
//! by. The values are converged only so far: the part of a difference their noise (each
//! point's own) explains is not counted.

use crate::step_control::Tolerances;

/// The local error is taken as `h³ |U'''| / ERROR_CONSTANT`: 12 is the trapezoidal rule's
/// constant; 6 leaves room for the dips of `|U'''|` that the memory below does not fill and for
/// integrators with a larger constant (generalized-α with numerical damping). Measured on an
/// undamped two-mass oscillator with the trapezoidal rule (tests/linear_system.rs, 32 steps of
/// memory): with 12 the error exceeds the tolerance by 1.1× at rtol 1e-3, with 8 by 1.01× at
/// 1e-4; with 6 it stays at 0.45–0.8 of it from rtol 1e-2 to 1e-4.
const ERROR_CONSTANT: f64 = 6.0;

/// Accepted steps over which the largest `|U'''|` is kept.
const MEMORY: usize = 32;

/// The order in h of the error norm the step-size controller assumes: 2, error per unit step of
/// a second-order stepper. With doubling the norm is of order 1 for a first-order stepper and 2
/// for a second-order one; assuming 2 only slows the first kind's approach to its step size,
/// while assuming 1 overshoots the second kind into rejections (45 % of the tries on the two-mass
/// test system, 2 % with 2).
pub(crate) const ORDER: u32 = 2;

/// How the local error of a step is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The step's values against the parabola of the last three accepted points (no extra
    /// step; assumes a second-order stepper, as this module's header says).
    Predictor,
    /// The step taken again as two half steps: their difference from the one step is the local
    /// error of the whole step if the stepper is of first order, and three times it if of second
    /// order (three steps, one whole and two halves, per accepted step; assumes nothing of the
    /// stepper's order, so it never under-reads — for coupled FMUs whose order is unknown, e.g. holding their inputs
    /// over the step).
    Doubling,
}

/// Accepted values of the watched quantities, newest first, and what the estimate remembers.
#[derive(Clone, Debug)]
pub struct ErrorEstimate {
    kind: Kind,
    t: [f64; 3],
    u: [Vec<f64>; 3],
    /// How far each kept point's values are converged (absolute, per quantity).
    noise: [Vec<f64>; 3],
    /// The same for the step being judged.
    candidate_noise: Vec<f64>,
    count: usize,
    u0: Vec<f64>,
    started: bool,
    /// Group of every quantity (they share a scale and a range).
    group: Vec<usize>,
    scale: Vec<f64>,
    /// Per group: the largest departure of its quantities from their initial values (and with
    /// the step being judged, for doubling).
    range: Vec<f64>,
    range_now: Vec<f64>,
    /// The values of the step being judged (with doubling: after its two half steps).
    candidate: Vec<f64>,
    /// With doubling: the values after the whole step in one, and how far they are converged.
    whole: Vec<f64>,
    whole_noise: Vec<f64>,
    /// |U'''| of the step being judged, and of the last MEMORY accepted steps (ring, per quantity).
    third: Vec<f64>,
    recent: Vec<f64>,
    slot: usize,
}

impl ErrorEstimate {
    /// A predictor–corrector estimate for `n` quantities, not started.
    pub fn new(n: usize) -> ErrorEstimate {
        ErrorEstimate::of_kind(Kind::Predictor, n)
    }

    /// An estimate of `kind` for `n` quantities, not started.
    pub fn of_kind(kind: Kind, n: usize) -> ErrorEstimate {
        ErrorEstimate {
            kind,
            t: [0.0; 3],
            u: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            noise: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            candidate_noise: vec![0.0; n],
            count: 0,
            u0: vec![0.0; n],
            started: false,
            group: vec![0; n],
            scale: vec![1.0; n],
            range: vec![0.0; n],
            range_now: vec![0.0; n],
            candidate: vec![0.0; n],
            whole: vec![0.0; n],
            whole_noise: vec![0.0; n],
            third: vec![0.0; n],
            recent: vec![0.0; n * MEMORY],
            slot: 0,
        }
    }

    pub(crate) fn is_started(&self) -> bool {
        self.started
    }

    /// Starts at the initial values `u0`: the origin of the ranges, not a history point (the
    /// start may be a discontinuity, which no smooth extrapolation across it may see). `group`:
    /// the group of every quantity (numbered from 0); `scale`: its positive scale.
    pub fn start(&mut self, u0: &[f64], group: &[usize], scale: &[f64]) {
        self.u0.copy_from_slice(u0);
        self.group.copy_from_slice(group);
        self.scale.copy_from_slice(scale);
        self.started = true;
    }

    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// Whether there is history enough to judge a step (the predictor: three accepted points).
    pub(crate) fn can_judge(&self) -> bool {
        self.kind == Kind::Doubling || self.count >= 3
    }

    /// Where the values after the whole step in one go, and their noise (doubling).
    pub(crate) fn whole_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        (&mut self.whole, &mut self.whole_noise)
    }

    /// Where the values of the step being judged go.
    pub(crate) fn candidate_mut(&mut self) -> &mut [f64] {
        &mut self.candidate
    }

    /// Where how far those values are converged goes (absolute, per quantity; zero if exact).
    pub(crate) fn candidate_noise_mut(&mut self) -> &mut [f64] {
        &mut self.candidate_noise
    }

    /// Takes the step being judged, which ended at `t`, into the history.
    pub fn accept(&mut self, t: f64) {
        self.t.rotate_right(1);
        self.u.rotate_right(1);
        self.noise.rotate_right(1);
        self.noise[0].copy_from_slice(&self.candidate_noise);
        self.t[0] = t;
        self.u[0].copy_from_slice(&self.candidate);
        self.count = (self.count + 1).min(3);
        for i in 0..self.candidate.len() {
            let moved = (self.candidate[i] - self.u0[i]).abs();
            let g = self.group[i];
            self.range[g] = self.range[g].max(moved);
            self.recent[i * MEMORY + self.slot] = self.third[i];
        }
        self.slot = (self.slot + 1) % MEMORY;
    }

    /// The Lagrange weight of history point `a` for extrapolating to `t`.
    fn weight(&self, a: usize, t: f64) -> f64 {
        let mut l = 1.0;
        for b in 0..self.count {
            if a != b {
                l *= (t - self.t[b]) / (self.t[a] - self.t[b]);
            }
        }
        l
    }

    /// The error norm (≤ 1 meets `tol`) of the step of size `h` that ended at `t1`, its values
    /// in `candidate_mut`, over a run to `horizon`; of order
    /// `ORDER` in h. Needs `can_judge`. The predictor:
    /// `|U'''|` is taken as its largest value over this and
    /// the last few accepted steps: for an oscillation it passes through zero twice a period while
    /// the phase error it stands for keeps growing. The values are only converged so far (an
    /// iteration's last residual, `candidate_noise_mut`; every kept point has
    /// its own): the part of the predictor–corrector difference that the noise of the four
    /// points can explain (weighted by the extrapolation weights) is not counted as error.
    pub fn norm(&mut self, t1: f64, h: f64, horizon: f64, tol: Tolerances) -> f64 {
        match self.kind {
            Kind::Predictor => self.predictor_norm(t1, h, horizon, tol),
            Kind::Doubling => self.doubling_norm(h, horizon, tol),
        }
    }

    /// The error norm of a step of `h` from the two half steps (`candidate`) against the whole
    /// step (`whole`), each converged so far: `|U_half − U_whole|`, less the noise of both, is
    /// the local error of a first-order stepper, measured per unit step as in
    /// [`ErrorEstimate::norm`].
    fn doubling_norm(&mut self, h: f64, horizon: f64, tol: Tolerances) -> f64 {
        let n = self.candidate.len();
        // the ranges so far, this step included: the first step is judged too (there is no
        // history to wait for), by how far it moved
        self.range_now.copy_from_slice(&self.range);
        for i in 0..n {
            let g = self.group[i];
            self.range_now[g] = self.range_now[g].max((self.candidate[i] - self.u0[i]).abs());
        }
        let mut sum = 0.0;
        for i in 0..n {
            let floor = self.candidate_noise[i] + self.whole_noise[i];
            let local = ((self.candidate[i] - self.whole[i]).abs() - floor).max(0.0);
            let e = local * horizon / (h * (tol.atol * self.scale[i] + tol.rtol * self.range_now[self.group[i]]));
            sum += e * e / n as f64;
        }
        sum.sqrt()
    }

    fn predictor_norm(&mut self, t1: f64, h: f64, horizon: f64, tol: Tolerances) -> f64 {
        // U''' ≈ 6 (U − P(t1)) / ((t1 − t0)(t1 − t1')(t1 − t2)), P the parabola of the history
        let spread = (t1 - self.t[0]) * (t1 - self.t[1]) * (t1 - self.t[2]);
        // the extrapolation's weights, once for all quantities (three kept points: can_judge)
        let weight = [self.weight(0, t1), self.weight(1, t1), self.weight(2, t1)];
        let n = self.candidate.len();
        // root mean square over the quantities (one quantity at its limit does not force the
        // step down alone)
        let mut sum = 0.0;
        for i in 0..n {
            let floor = self.candidate_noise[i] + (0..3).map(|k| weight[k].abs() * self.noise[k][i]).sum::<f64>();
            let prediction = (0..3).map(|k| weight[k] * self.u[k][i]).sum::<f64>();
            let difference = ((self.candidate[i] - prediction).abs() - floor).max(0.0);
            let third = 6.0 * difference / spread.abs();
            self.third[i] = third;
            let recent = self.recent[i * MEMORY..(i + 1) * MEMORY].iter().fold(third, |m, x| m.max(*x));
            let local = h * h * h * recent / ERROR_CONSTANT;
            let e = local * horizon / (h * (tol.atol * self.scale[i] + tol.rtol * self.range[self.group[i]]));
            sum += e * e / n as f64;
        }
        sum.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a cubic the parabola of three points misses by exactly its third derivative: the
    /// estimate reads U''' = 6 from U = t³ whatever the steps, and the norm follows
    /// h³ · 6 / 6 · T / h / (rtol · range).
    #[test]
    fn reads_the_third_derivative_of_a_cubic() {
        let mut e = ErrorEstimate::new(1);
        e.start(&[0.0], &[0], &[1.0]);
        for t in [0.1, 0.25, 0.3] {
            e.candidate_mut()[0] = t * t * t;
            e.accept(t);
        }
        assert!(e.can_judge());
        let (t1, h) = (0.42, 0.12);
        e.candidate_mut()[0] = t1 * t1 * t1;
        let tol = Tolerances { rtol: 1e-3, atol: 0.0 };
        let range = 0.3f64.powi(3);
        let expected = h * h * h * 6.0 / ERROR_CONSTANT * 10.0 / h / (tol.rtol * range);
        let got = e.norm(t1, h, 10.0, tol);
        assert!((got - expected).abs() <= 1e-9 * expected, "{got} against {expected}");
        // a quadratic is extrapolated exactly: no error (beyond the memory of the cubic)
        let mut q = ErrorEstimate::new(1);
        q.start(&[0.0], &[0], &[1.0]);
        for t in [0.1, 0.25, 0.3] {
            q.candidate_mut()[0] = 2.0 * t * t - t;
            q.accept(t);
        }
        q.candidate_mut()[0] = 2.0 * t1 * t1 - t1;
        assert!(q.norm(t1, h, 10.0, tol) < 1e-9);
    }

    /// The part of the predictor–corrector difference that the points' noise explains is not
    /// error: each point's noise weighs by its extrapolation weight, the new point's by one.
    #[test]
    fn noise_explains_part_of_the_difference() {
        let (t1, h, d) = (0.42, 0.12, 1e-6);
        let tol = Tolerances { rtol: 1e-3, atol: 0.0 };
        let norm = |history_noise: f64, candidate_noise: f64| {
            let mut q = ErrorEstimate::new(1);
            q.start(&[0.0], &[0], &[1.0]);
            for t in [0.1, 0.25, 0.3] {
                q.candidate_mut()[0] = 2.0 * t * t - t;
                q.candidate_noise_mut()[0] = history_noise;
                q.accept(t);
            }
            // a parabola is extrapolated exactly: the whole difference is the offset d
            q.candidate_mut()[0] = 2.0 * t1 * t1 - t1 + d;
            q.candidate_noise_mut()[0] = candidate_noise;
            (q.norm(t1, h, 10.0, tol), [0, 1, 2].map(|k| q.weight(k, t1).abs()).iter().sum::<f64>())
        };
        let (clean, weights) = norm(0.0, 0.0);
        assert!(clean > 0.0);
        assert_eq!(norm(0.0, d).0, 0.0);
        assert!((norm(0.0, 0.5 * d).0 - 0.5 * clean).abs() <= 1e-9 * clean);
        // noise of the history, amplified by the weights of the extrapolation
        assert_eq!(norm(d / weights, 0.0).0, 0.0);
        let quarter = norm(0.25 * d / weights, 0.0).0;
        assert!((quarter - 0.75 * clean).abs() <= 1e-9 * clean, "{quarter} against {clean}");
    }
}
