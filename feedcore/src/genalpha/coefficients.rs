//! Coefficients of the generalized-α method (Chung & Hulbert 1993) in the form of
//! Arnold & Brüls (2007), which enforces the equations of motion at the time points and
//! carries a separate "pseudo-acceleration" `a`:
//!
//! ```text
//! (1−α_m) a_{n+1} + α_m a_n = (1−α_f) v̇_{n+1} + α_f v̇_n
//! v_{n+1} = v_n + h (1−γ) a_n + h γ a_{n+1}
//! q_{n+1} = q_n ∘ exp(h v_n + h² (½−β) a_n + h² β a_{n+1})
//! ```
//!
//! For linear problems it is the Chung–Hulbert method; it is second-order accurate and its
//! high-frequency spectral radius is ρ∞. With ρ∞ = 1 it is the trapezoidal rule.

/// Integrator coefficients for one spectral radius ρ∞ ∈ [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GenAlpha {
    pub rho_inf: f64,
    pub alpha_m: f64,
    pub alpha_f: f64,
    pub beta: f64,
    pub gamma: f64,
}

impl GenAlpha {
    /// Panics unless `rho_inf` lies in [0, 1]; [`super::Integrator::new`] checks it first.
    pub fn new(rho_inf: f64) -> Self {
        assert!((0.0..=1.0).contains(&rho_inf), "rho_inf must lie in [0, 1], got {rho_inf}");
        let alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0);
        let alpha_f = rho_inf / (rho_inf + 1.0);
        let gamma = 0.5 + alpha_f - alpha_m;
        let beta = 0.25 * (gamma + 0.5).powi(2);
        Self { rho_inf, alpha_m, alpha_f, beta, gamma }
    }

    /// ∂v̇_{n+1}/∂(h Δq): scales the mass matrix in the Newton iteration matrix.
    pub fn beta_prime(&self, h: f64) -> f64 {
        (1.0 - self.alpha_m) / (h * h * self.beta * (1.0 - self.alpha_f))
    }

    /// ∂v_{n+1}/∂(h Δq): scales the damping matrix in the Newton iteration matrix.
    pub fn gamma_prime(&self, h: f64) -> f64 {
        self.gamma / (h * self.beta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One step of the scheme on ẍ = −ω² x, as the linear map of (x, h·v, h²·v̇, h²·a).
    fn amplification(ga: &GenAlpha, omega_h: f64) -> nalgebra::Matrix4<f64> {
        let w2 = omega_h * omega_h;
        let mut m = nalgebra::Matrix4::zeros();
        for k in 0..4 {
            let mut s = nalgebra::Vector4::zeros();
            s[k] = 1.0;
            let (x, v, acc, a) = (s[0], s[1], s[2], s[3]); // scaled by h as above
            // x1 = x + v + (½−β) a + β a1, a1 = ((1−αf) acc1 + αf acc − αm a)/(1−αm), acc1 = −ω²h² x1
            let c = ga.beta / (1.0 - ga.alpha_m);
            let rhs = x + v + (0.5 - ga.beta) * a + c * (ga.alpha_f * acc - ga.alpha_m * a);
            let x1 = rhs / (1.0 + c * (1.0 - ga.alpha_f) * w2);
            let acc1 = -w2 * x1;
            let a1 = ((1.0 - ga.alpha_f) * acc1 + ga.alpha_f * acc - ga.alpha_m * a) / (1.0 - ga.alpha_m);
            let v1 = v + (1.0 - ga.gamma) * a + ga.gamma * a1;
            m.set_column(k, &nalgebra::Vector4::new(x1, v1, acc1, a1));
        }
        m
    }

    fn spectral_radius(m: &nalgebra::Matrix4<f64>) -> f64 {
        m.complex_eigenvalues().iter().map(|l| l.norm()).fold(0.0, f64::max)
    }

    #[test]
    fn high_frequency_spectral_radius_is_rho_inf() {
        for rho in [0.2, 0.5, 0.9, 1.0] {
            let ga = GenAlpha::new(rho);
            let r = spectral_radius(&amplification(&ga, 1e5));
            assert!((r - rho).abs() < 1e-3, "rho_inf {rho}: spectral radius {r}");
        }
    }

    #[test]
    fn low_frequencies_are_undamped_to_second_order() {
        // At ωh = 0.01 the numerical damping per step is O((ωh)^3) or smaller.
        let ga = GenAlpha::new(0.9);
        let r = spectral_radius(&amplification(&ga, 0.01));
        assert!((1.0 - r).abs() < 1e-6, "spectral radius {r}");
    }
}
