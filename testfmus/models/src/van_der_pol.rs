//! Van der Pol's oscillator with a forcing input: `ẍ = μ (1 − x²) ẋ − x + u`, as the
//! first-order system `x₀' = x₁`, `x₁' = μ (1 − x₀²) x₁ − x₀ + u`.

/// The equation and the integrator's largest substep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VanDerPol {
    /// Damping parameter μ (0: a harmonic oscillator).
    pub mu: f64,
    /// Largest step of the classical Runge–Kutta method inside a call of [`VanDerPol::advance`].
    pub max_substep: f64,
}

impl VanDerPol {
    /// `(x₀', x₁')` at state `x` under input `u`.
    pub fn rate(&self, x: [f64; 2], u: f64) -> [f64; 2] {
        [x[1], self.mu * (1.0 - x[0] * x[0]) * x[1] - x[0] + u]
    }

    /// The state after `h` with `u` held: classical RK4 in equal substeps no longer than
    /// `max_substep` (fourth order: the error of a run falls 16-fold when the substep halves).
    pub fn advance(&self, x: [f64; 2], u: f64, h: f64) -> [f64; 2] {
        let n = (h / self.max_substep).ceil().max(1.0);
        let dt = h / n;
        let mut x = x;
        let add = |x: [f64; 2], k: [f64; 2], s: f64| [x[0] + s * k[0], x[1] + s * k[1]];
        for _ in 0..n as u64 {
            let k1 = self.rate(x, u);
            let k2 = self.rate(add(x, k1, 0.5 * dt), u);
            let k3 = self.rate(add(x, k2, 0.5 * dt), u);
            let k4 = self.rate(add(x, k3, dt), u);
            for i in 0..2 {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mu_zero_is_the_harmonic_oscillator() {
        let m = VanDerPol { mu: 0.0, max_substep: 1e-3 };
        let x = m.advance([2.0, 0.0], 0.0, 3.0);
        assert!((x[0] - 2.0 * 3.0_f64.cos()).abs() < 1e-12, "{x:?}");
        assert!((x[1] + 2.0 * 3.0_f64.sin()).abs() < 1e-12, "{x:?}");
        // a constant force shifts the centre: x = u + (x0 − u) cos t
        let x = m.advance([0.0, 0.0], 0.5, 1.0);
        assert!((x[0] - (0.5 - 0.5 * 1.0_f64.cos())).abs() < 1e-13, "{x:?}");
    }

    #[test]
    fn fourth_order_convergence_on_the_limit_cycle() {
        let run = |dt: f64| VanDerPol { mu: 1.0, max_substep: dt }.advance([2.0, 0.0], 0.0, 5.0);
        let reference = run(1e-4);
        let e1 = (run(0.04)[0] - reference[0]).abs();
        let e2 = (run(0.02)[0] - reference[0]).abs();
        assert!((e1 / e2 - 16.0).abs() < 2.0, "order: {e1:e} / {e2:e}");
    }

    #[test]
    fn the_step_is_split_into_equal_substeps_no_longer_than_asked() {
        // two substeps of 0.25 against two calls of one: the same arithmetic, the same bits
        let m = VanDerPol { mu: 1.0, max_substep: 0.3 };
        let coarse = VanDerPol { mu: 1.0, max_substep: 1.0 };
        let x = coarse.advance(coarse.advance([2.0, 0.0], 0.0, 0.25), 0.0, 0.25);
        assert_eq!(m.advance([2.0, 0.0], 0.0, 0.5), x);
    }
}
