//! Irvine's elastic catenary: the exact shape of a continuous, extensible cable hanging between
//! two points under its own weight. It is the independent reference the finite-element chain
//! converges to.
//!
//! With the Lagrangian coordinate `s ∈ [0, L0]` along the unstretched cable from end A, the
//! tension vector is `T(s) = (H, V0 + w s)` in the vertical plane through both ends (horizontal
//! component H constant, w the weight per unstretched length), and
//!
//! ```text
//! x(s) = H s / EA + (H / w) [asinh((V0 + w s)/H) − asinh(V0/H)]
//! z(s) = (V0 s + w s²/2) / EA + (1/w) [√(H² + (V0 + w s)²) − √(H² + V0²)]
//! ```

use feedcore::Vec3;

/// A solved elastic catenary between two points.
#[derive(Clone, Copy, Debug)]
pub struct ElasticCatenary {
    pub start: Vec3,
    /// Unit horizontal vector from the start towards the end.
    pub horizontal_dir: Vec3,
    pub unstretched_length: f64,
    pub ea: f64,
    /// Weight per unstretched length (N/m).
    pub w: f64,
    /// Horizontal tension component (N).
    pub h: f64,
    /// Vertical component of the tension at the start, along increasing s (N).
    pub v0: f64,
}

impl ElasticCatenary {
    /// Solves for the end forces of a cable from `start` to `end` (gravity along −Z).
    /// Panics if the ends are vertically aligned (no catenary) — a test-only reference.
    pub fn solve(start: Vec3, end: Vec3, unstretched_length: f64, ea: f64, w: f64) -> ElasticCatenary {
        let d = end - start;
        let l = (d.x * d.x + d.y * d.y).sqrt();
        assert!(l > 0.0, "the elastic catenary needs a horizontal span");
        let horizontal_dir = Vec3::new(d.x / l, d.y / l, 0.0);
        let mut c = ElasticCatenary {
            start,
            horizontal_dir,
            unstretched_length,
            ea,
            w,
            h: w * l,
            v0: -0.5 * w * unstretched_length,
        };
        // Newton on (H, V0) for the end point (l, d.z) with the analytic Jacobian.
        for _ in 0..100 {
            let (x, z) = c.xz(unstretched_length);
            let r = [x - l, z - d.z];
            if r[0].abs().max(r[1].abs()) < 1e-12 * (1.0 + l) {
                return c;
            }
            let j = c.jacobian(unstretched_length);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            let dh = -(j[1][1] * r[0] - j[0][1] * r[1]) / det;
            let dv = -(-j[1][0] * r[0] + j[0][0] * r[1]) / det;
            // backtrack until H stays positive and the miss distance shrinks
            let miss = r[0].hypot(r[1]);
            let mut step = 1.0;
            loop {
                let trial = ElasticCatenary { h: c.h + step * dh, v0: c.v0 + step * dv, ..c };
                if trial.h > 0.0 {
                    let (x, z) = trial.xz(unstretched_length);
                    if (x - l).hypot(z - d.z) < miss || step < 1e-6 {
                        c = trial;
                        break;
                    }
                }
                step *= 0.5;
            }
        }
        panic!("elastic catenary did not converge");
    }

    /// Horizontal and vertical position at Lagrangian coordinate `s`, relative to the start.
    pub(crate) fn xz(&self, s: f64) -> (f64, f64) {
        let (h, v0, w, ea) = (self.h, self.v0, self.w, self.ea);
        let x = h * s / ea + (h / w) * (((v0 + w * s) / h).asinh() - (v0 / h).asinh());
        let z =
            (v0 * s + 0.5 * w * s * s) / ea + ((h * h + (v0 + w * s).powi(2)).sqrt() - (h * h + v0 * v0).sqrt()) / w;
        (x, z)
    }

    /// ∂(x, z)/∂(H, V0) at `s`.
    fn jacobian(&self, s: f64) -> [[f64; 2]; 2] {
        let (h, v0, w, ea) = (self.h, self.v0, self.w, self.ea);
        let (a, b) = (v0 / h, (v0 + w * s) / h);
        let (ra, rb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
        let (ta, tb) = (h * ra, h * rb);
        [
            [s / ea + (b.asinh() - a.asinh()) / w - (b / rb - a / ra) / w, (1.0 / rb - 1.0 / ra) / w],
            [(h / tb - h / ta) / w, s / ea + ((v0 + w * s) / tb - v0 / ta) / w],
        ]
    }

    pub fn point(&self, s: f64) -> Vec3 {
        let (x, z) = self.xz(s);
        self.start + self.horizontal_dir * x + Vec3::z() * z
    }

    /// Tension magnitude at Lagrangian coordinate `s`.
    pub fn tension(&self, s: f64) -> f64 {
        (self.h * self.h + (self.v0 + self.w * s).powi(2)).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reaches_the_end_point_and_reduces_to_the_rigid_catenary_for_large_ea() {
        let (a, b) = (Vec3::new(0.0, 0.0, 30.0), Vec3::new(20.0, 21.0, 9.55));
        let c = ElasticCatenary::solve(a, b, 36.5, 1.0e7, 7.97);
        assert!((c.point(36.5) - b).norm() < 1e-9);
        // inextensible limit: arc length of the curve equals the unstretched length
        let stiff = ElasticCatenary::solve(a, b, 36.5, 1.0e15, 7.97);
        let n = 20000;
        let len: f64 = (0..n)
            .map(|i| (stiff.point(36.5 * (i + 1) as f64 / n as f64) - stiff.point(36.5 * i as f64 / n as f64)).norm())
            .sum();
        assert!((len - 36.5).abs() < 1e-6, "{len}");
    }
}
