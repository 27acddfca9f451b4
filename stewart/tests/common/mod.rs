//! Shared helpers of the Stewart tests: the reference scenes and a smooth cabin motion.
#![allow(dead_code)]

use feedcore::rigid::exp_so3;
use feedcore::scene::{Scene, ValidScene};
use feedcore::{Quat, Vec3};
use stewart::{CabinMotion, Stewart};

pub(crate) fn scene(name: &str) -> ValidScene {
    let path = format!("{}/../scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

pub(crate) fn stewart(name: &str) -> Stewart {
    Stewart::from_scene(&scene(name)).unwrap()
}

/// Scene `name` with its platform circling at `speed` (m/s), its Stewart platform, and a lively
/// cabin path about the scene's target pose.
pub(crate) fn moving(name: &str, speed: f64) -> (ValidScene, Stewart, CabinPath) {
    let scene = scene(name)
        .edited(|scene| {
            scene.motion.speed_m_s = speed;
        })
        .unwrap();
    let st = Stewart::from_scene(&scene).unwrap();
    let path = CabinPath::lively(scene.target_position(), scene.target_orientation());
    (scene, st, path)
}

/// The cabin at the scene's target pose, at rest.
pub(crate) fn cabin_at_target(scene: &ValidScene) -> CabinMotion {
    CabinMotion::at_rest(scene.target_position(), scene.target_orientation())
}

/// A smooth cabin motion with translation and a rotation about a moving axis:
/// R(t) = exp(ψ₁ n₁) exp(ψ₂ n₂) R₀, each term with closed-form derivatives.
pub(crate) struct CabinPath {
    pub x0: Vec3,
    pub r0: Quat,
    pub amplitude: Vec3,
    pub frequency: Vec3,
    pub n1: Vec3,
    pub n2: Vec3,
    /// ψ_i = a_i sin(f_i t + p_i)
    pub psi: [(f64, f64, f64); 2],
}

impl CabinPath {
    pub(crate) fn lively(x0: Vec3, r0: Quat) -> Self {
        Self {
            x0,
            r0,
            amplitude: Vec3::new(0.4, 0.3, 0.2),
            frequency: Vec3::new(1.7, 2.3, 3.1),
            n1: Vec3::new(0.3, -0.5, 0.8).normalize(),
            n2: Vec3::new(0.9, 0.2, -0.1).normalize(),
            psi: [(0.3, 1.3, 0.2), (0.25, 0.9, -0.7)],
        }
    }

    fn angle(&self, i: usize, t: f64) -> (f64, f64, f64) {
        let (a, f, p) = self.psi[i];
        let (s, c) = (f * t + p).sin_cos();
        (a * s, a * f * c, -a * f * f * s)
    }

    pub(crate) fn at(&self, t: f64) -> CabinMotion {
        let (a, f) = (self.amplitude, self.frequency);
        let mut position = self.x0;
        let mut velocity = Vec3::zeros();
        let mut acceleration = Vec3::zeros();
        for k in 0..3 {
            let phase = f[k] * t + 0.3 * k as f64;
            position[k] += a[k] * phase.sin();
            velocity[k] = a[k] * f[k] * phase.cos();
            acceleration[k] = -a[k] * f[k] * f[k] * phase.sin();
        }
        let (p1, d1, dd1) = self.angle(0, t);
        let (p2, d2, dd2) = self.angle(1, t);
        let r1 = exp_so3(&(self.n1 * p1));
        let m2 = r1 * self.n2; // second axis as seen in the world
        let w1 = self.n1 * d1;
        let angular_velocity = w1 + m2 * d2;
        let angular_acceleration = self.n1 * dd1 + m2 * dd2 + w1.cross(&m2) * d2;
        CabinMotion {
            position,
            orientation: r1 * exp_so3(&(self.n2 * p2)) * self.r0,
            velocity,
            angular_velocity,
            acceleration,
            angular_acceleration,
        }
    }
}

/// Eighth-order central difference of a vector function of time.
pub(crate) fn derivative<const N: usize>(
    f: impl Fn(f64) -> nalgebra::SVector<f64, N>,
    t: f64,
    h: f64,
) -> nalgebra::SVector<f64, N> {
    let c = [4.0 / 5.0, -1.0 / 5.0, 4.0 / 105.0, -1.0 / 280.0];
    let mut d = nalgebra::SVector::<f64, N>::zeros();
    for (i, ci) in c.iter().enumerate() {
        let s = (i + 1) as f64 * h;
        d += (f(t + s) - f(t - s)) * *ci;
    }
    d / h
}

/// World-frame rotation vector taking orientation `a` to `b`: b = exp([θ]×) a.
pub(crate) fn rotation_between(a: &Quat, b: &Quat) -> Vec3 {
    (b * a.inverse()).scaled_axis()
}
