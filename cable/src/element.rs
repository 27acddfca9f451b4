//! The cable element: a two-node bar that carries tension only.
//!
//! The axial force follows from the current length (exact geometric nonlinearity):
//! `N = EA (L − L0) / L0` when the bar is longer than its unstretched length, and zero when it
//! is not (a slack bar carries neither force nor stiffness).

use feedcore::{Mat3, Vec3};

/// Axial state of one bar from its end-to-end vector `delta` (second node minus first node).
#[derive(Clone, Copy, Debug)]
pub struct Bar {
    /// Axial force, tension positive, zero when slack.
    pub force: f64,
    /// Current length.
    pub length: f64,
    /// Unit vector from the first node to the second.
    pub dir: Vec3,
}

impl Bar {
    pub fn new(delta: &Vec3, ea: f64, l0: f64) -> Bar {
        let length = delta.norm();
        let dir = delta / length;
        let force = if length > l0 { ea * (length - l0) / l0 } else { 0.0 };
        Bar { force, length, dir }
    }

    /// The force the bar exerts on its first node, `N·dir` (zero when slack), without forming
    /// the bar: one division instead of four, for residuals evaluated at every iteration.
    #[inline]
    pub fn pull(delta: &Vec3, ea: f64, l0: f64) -> Vec3 {
        let length = delta.norm();
        if length > l0 { delta * (ea * (length - l0) / (l0 * length)) } else { Vec3::zeros() }
    }

    pub(crate) fn is_slack(&self) -> bool {
        self.force == 0.0
    }

    /// Force the bar exerts on its second node (the first node gets the opposite).
    pub fn force_on_second(&self) -> Vec3 {
        -self.dir * self.force
    }

    /// Tangent stiffness `∂(N·dir)/∂delta`: elastic `EA/L0 · e eᵀ` plus geometric
    /// `N/L · (I − e eᵀ)`; zero when slack.
    pub fn stiffness(&self, ea: f64, l0: f64) -> Mat3 {
        if self.is_slack() {
            return Mat3::zeros();
        }
        let ee = self.dir * self.dir.transpose();
        ee * (ea / l0) + (Mat3::identity() - ee) * (self.force / self.length)
    }

    /// Strain energy `½ EA (L − L0)² / L0` (zero when slack).
    pub fn energy(&self, ea: f64, l0: f64) -> f64 {
        if self.is_slack() { 0.0 } else { 0.5 * ea * (self.length - l0).powi(2) / l0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiffness_is_the_derivative_of_the_force() {
        let (ea, l0) = (1.0e7, 1.5);
        let d = Vec3::new(1.2, -0.4, 0.9);
        let bar = Bar::new(&d, ea, l0);
        assert!(!bar.is_slack());
        let k = bar.stiffness(ea, l0);
        let eps = 1e-6;
        for c in 0..3 {
            let mut dp = d;
            dp[c] += eps;
            let mut dm = d;
            dm[c] -= eps;
            let fp = Bar::new(&dp, ea, l0);
            let fm = Bar::new(&dm, ea, l0);
            let col = (fp.dir * fp.force - fm.dir * fm.force) / (2.0 * eps);
            let rel = (col - k.column(c)).norm() / k.norm();
            assert!(rel < 1e-8, "column {c}: {rel}");
        }
        // the force without forming the bar is the same
        let pull = Bar::pull(&d, ea, l0);
        assert!((pull - bar.dir * bar.force).norm() <= 1e-12 * bar.force);
        assert_eq!(Bar::pull(&Vec3::new(0.0, 0.0, 0.99 * l0), ea, l0), Vec3::zeros());
        // force is the gradient of the energy
        let fd = (Bar::new(&(d * (1.0 + eps)), ea, l0).energy(ea, l0)
            - Bar::new(&(d * (1.0 - eps)), ea, l0).energy(ea, l0))
            / (2.0 * eps * d.norm());
        assert!((fd - bar.force).abs() < 1e-6 * bar.force);
    }

    #[test]
    fn a_short_bar_is_slack() {
        let bar = Bar::new(&Vec3::new(0.0, 0.0, 0.99), 1.0e7, 1.0);
        assert!(bar.is_slack());
        assert_eq!(bar.stiffness(1.0e7, 1.0), Mat3::zeros());
        assert_eq!(bar.energy(1.0e7, 1.0), 0.0);
    }
}
