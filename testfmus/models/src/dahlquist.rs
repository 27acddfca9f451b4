//! Dahlquist's test equation with a forcing input: `ẋ = −k x + u`.

/// The equation: its rate constant `k` (1/s; negative k grows).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dahlquist {
    pub k: f64,
}

impl Dahlquist {
    /// `ẋ` at state `x` under input `u`.
    pub fn rate(&self, x: f64, u: f64) -> f64 {
        -self.k * x + u
    }

    /// The state after `h` with `u` held: exact, `x(h) = e^{−kh} x + (1 − e^{−kh}) u / k`
    /// (`x + u h` for k = 0). `expm1` keeps `1 − e^{−kh}` accurate when `kh` is small.
    pub fn advance(&self, x: f64, u: f64, h: f64) -> f64 {
        if self.k == 0.0 {
            return x + u * h;
        }
        let gain = -(-self.k * h).exp_m1(); // 1 − e^{−kh}
        x - gain * x + gain * u / self.k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_decay_is_exact_whatever_the_step() {
        let d = Dahlquist { k: 1.5 };
        for n in [1, 7, 100] {
            let h = 2.0 / n as f64;
            let x = (0..n).fold(1.0, |x, _| d.advance(x, 0.0, h));
            assert!((x - (-3.0_f64).exp()).abs() < 1e-14, "n = {n}: {x}");
        }
    }

    #[test]
    fn a_held_input_approaches_its_equilibrium_exactly() {
        // x(t) = u/k + (x0 − u/k) e^{−kt}
        let d = Dahlquist { k: 2.0 };
        let x = d.advance(0.5, 3.0, 0.7);
        let exact = 1.5 + (0.5 - 1.5) * (-1.4_f64).exp();
        assert!((x - exact).abs() < 1e-15, "{x} vs {exact}");
        assert_eq!(d.rate(1.5, 3.0), 0.0);
        // k = 0: a ramp; and a growing solution for k < 0
        assert_eq!(Dahlquist { k: 0.0 }.advance(1.0, 2.0, 0.25), 1.5);
        let g = Dahlquist { k: -1.0 }.advance(1.0, 0.0, 1.0);
        assert!((g - std::f64::consts::E).abs() < 1e-15);
    }

    #[test]
    fn a_tiny_rate_constant_loses_no_digits() {
        // (1 − e^{−kh})/k → h as k → 0: the step must stay accurate, not cancel
        let x = Dahlquist { k: 1e-12 }.advance(0.0, 1.0, 1.0);
        assert!((x - 1.0).abs() < 1e-12, "{x}");
    }
}
