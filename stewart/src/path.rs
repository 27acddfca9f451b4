//! The prescribed path of the platform centre relative to the cabin (cabin frame): a circle
//! parallel to the base, run counter-clockwise about the cabin z axis at constant speed, started
//! either abruptly (full speed at t = 0, the paper) or with a quintic smoothstep ramp of the speed.
//!
//! Before t = 0 the platform rests at the start point `center + r·x̂`.

use std::f64::consts::TAU;

use feedcore::scene::{Motion, Start};
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::Rotation3;

/// The platform's motion relative to the cabin at one instant, cabin frame: its centre's
/// position, velocity and acceleration, and its orientation (platform frame to cabin frame),
/// angular velocity and angular acceleration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathPoint {
    pub position: Vec3,
    pub velocity: Vec3,
    pub acceleration: Vec3,
    pub orientation: Mat3,
    pub angular_velocity: Vec3,
    pub angular_acceleration: Vec3,
}

impl PathPoint {
    /// A motion without rotation: the platform frame stays parallel to the cabin's.
    pub fn translating(position: Vec3, velocity: Vec3, acceleration: Vec3) -> PathPoint {
        PathPoint {
            position,
            velocity,
            acceleration,
            orientation: Mat3::identity(),
            angular_velocity: Vec3::zeros(),
            angular_acceleration: Vec3::zeros(),
        }
    }

    /// The orientation as a unit quaternion.
    pub fn rotation(&self) -> Quat {
        Quat::from_rotation_matrix(&Rotation3::from_matrix_unchecked(self.orientation))
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        finite(self.position.as_slice())
            && finite(self.velocity.as_slice())
            && finite(self.acceleration.as_slice())
            && finite(self.orientation.as_slice())
            && finite(self.angular_velocity.as_slice())
            && finite(self.angular_acceleration.as_slice())
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct CirclePath {
    center: Vec3,
    radius: f64,
    /// Angular speed after the start, rad/s (0: the platform stays at the start point).
    omega: f64,
    /// Ramp time of the speed; `None` for the abrupt start.
    ramp: Option<f64>,
}

impl CirclePath {
    /// The circle of `motion` about `center` (both from a validated scene).
    pub fn new(center: Vec3, motion: &Motion) -> Self {
        let omega = if motion.radius_m > 0.0 { motion.speed_m_s / motion.radius_m } else { 0.0 };
        let ramp = match motion.start {
            // the consistent start moves the platform as the abrupt one; the cabin's start
            // velocity is the cable model's (cable::model::CableCabin::start_twist)
            Start::Abrupt | Start::Consistent => None,
            Start::Ramp => Some(motion.ramp_time_s),
        };
        Self { center, radius: motion.radius_m, omega, ramp }
    }

    pub fn center(&self) -> Vec3 {
        self.center
    }

    /// Angular speed once at full speed, rad/s.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// Angle φ, angular speed φ̇ and angular acceleration φ̈ at time `t`.
    pub fn angle(&self, t: f64) -> (f64, f64, f64) {
        let w = self.omega;
        if t <= 0.0 || w == 0.0 {
            // The abrupt start jumps to full speed at t = 0 exactly.
            return if t == 0.0 && self.ramp.is_none() { (0.0, w, 0.0) } else { (0.0, 0.0, 0.0) };
        }
        match self.ramp {
            Some(ramp) if t < ramp => {
                let x = t / ramp;
                // speed ω·s(x), s = 10x³ − 15x⁴ + 6x⁵; angle ω·T·∫s = ω·T·(2.5x⁴ − 3x⁵ + x⁶)
                let x2 = x * x;
                let angle = w * ramp * x2 * x2 * (2.5 - 3.0 * x + x2);
                let speed = w * x2 * x * (10.0 - 15.0 * x + 6.0 * x2);
                let accel = w / ramp * 30.0 * x2 * (1.0 - x) * (1.0 - x);
                (angle, speed, accel)
            }
            Some(ramp) => (w * (t - 0.5 * ramp), w, 0.0),
            None => (w * t, w, 0.0),
        }
    }

    /// The platform centre at time `t`.
    pub fn at(&self, t: f64) -> PathPoint {
        self.point(self.angle(t))
    }

    /// The platform centre at rest at the start point.
    pub fn at_rest(&self) -> PathPoint {
        self.point((0.0, 0.0, 0.0))
    }

    fn point(&self, (phi, dphi, ddphi): (f64, f64, f64)) -> PathPoint {
        let (s, c) = phi.sin_cos();
        let r = self.radius;
        let radial = Vec3::new(c, s, 0.0);
        let tangent = Vec3::new(-s, c, 0.0);
        PathPoint::translating(
            self.center + radial * r,
            tangent * (r * dphi),
            tangent * (r * ddphi) - radial * (r * dphi * dphi),
        )
    }

    /// Time at which the platform completes its first revolution (`None` if it does not move).
    pub fn revolution_time(&self) -> Option<f64> {
        let w = self.omega;
        if w == 0.0 {
            return None;
        }
        Some(match self.ramp {
            None => TAU / w,
            Some(ramp) if 0.5 * w * ramp <= TAU => ramp + (TAU - 0.5 * w * ramp) / w,
            Some(ramp) => {
                // The revolution ends inside the ramp; φ is increasing there, so bisect.
                let (mut lo, mut hi) = (0.0, ramp);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if self.angle(mid).0 < TAU { lo = mid } else { hi = mid }
                }
                0.5 * (lo + hi)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(start: Start) -> CirclePath {
        let motion = Motion { radius_m: 0.1, speed_m_s: 0.02, start, ramp_time_s: 5.0 };
        CirclePath::new(Vec3::new(0.0, 0.0, -1.8), &motion)
    }

    /// Sixth-order central difference of a scalar function.
    fn derivative(f: impl Fn(f64) -> f64, t: f64, h: f64) -> f64 {
        (45.0 * (f(t + h) - f(t - h)) - 9.0 * (f(t + 2.0 * h) - f(t - 2.0 * h)) + (f(t + 3.0 * h) - f(t - 3.0 * h)))
            / (60.0 * h)
    }

    #[test]
    fn angle_derivatives_match_finite_differences() {
        for start in [Start::Abrupt, Start::Ramp] {
            let p = path(start);
            for t in [0.3, 1.7, 2.5, 4.4, 6.0, 31.0] {
                let (_, dphi, ddphi) = p.angle(t);
                let fd1 = derivative(|s| p.angle(s).0, t, 1e-3);
                let fd2 = derivative(|s| p.angle(s).1, t, 1e-3);
                assert!((dphi - fd1).abs() < 1e-12, "{start:?} t={t}: φ̇ {dphi} vs {fd1}");
                assert!((ddphi - fd2).abs() < 1e-11, "{start:?} t={t}: φ̈ {ddphi} vs {fd2}");
                let point = p.at(t);
                for k in 0..3 {
                    let fdv = derivative(|s| p.at(s).position[k], t, 1e-3);
                    let fda = derivative(|s| p.at(s).velocity[k], t, 1e-3);
                    assert!((point.velocity[k] - fdv).abs() < 1e-13);
                    assert!((point.acceleration[k] - fda).abs() < 1e-13);
                }
            }
        }
    }

    #[test]
    fn ramp_is_continuous_in_velocity_and_acceleration_at_both_ends() {
        let p = path(Start::Ramp);
        for t0 in [0.0, 5.0] {
            let (before, after) = (p.at(t0 - 1e-12), p.at(t0 + 1e-12));
            assert!((before.position - after.position).norm() < 1e-13);
            assert!((before.velocity - after.velocity).norm() < 1e-14, "velocity jumps at t = {t0}");
            assert!((before.acceleration - after.acceleration).norm() < 1e-12, "acceleration jumps at t = {t0}");
        }
        // Full speed and no tangential acceleration after the ramp; the ramp's angle at its end
        // is ω·T/2 (the smoothstep averages one half).
        let w = 0.02 / 0.1;
        assert_eq!(p.angle(5.0), (w * 5.0 * 0.5, w, 0.0));
        assert!((p.angle(5.0 - 1e-9).0 - 0.5).abs() < 1e-9);
    }

    #[test]
    fn abrupt_start_is_at_full_speed_at_zero_and_rests_before() {
        let p = path(Start::Abrupt);
        assert_eq!(p.angle(0.0), (0.0, 0.02 / 0.1, 0.0));
        assert_eq!(p.angle(-1.0), (0.0, 0.0, 0.0));
        assert!((p.at(0.0).velocity.norm() - 0.02).abs() < 1e-15);
        // centripetal acceleration v²/r
        assert!((p.at(3.0).acceleration.norm() - 0.02 * 0.02 / 0.1).abs() < 1e-15);
    }

    #[test]
    fn revolution_time_closes_the_circle() {
        for (start, expected) in [(Start::Abrupt, TAU / 0.2), (Start::Ramp, 5.0 + (TAU - 0.5) / 0.2)] {
            let p = path(start);
            let t = p.revolution_time().unwrap();
            assert!((t - expected).abs() < 1e-12);
            assert!((p.angle(t).0 - TAU).abs() < 1e-12);
        }
        // a revolution that ends inside a long ramp
        let motion = Motion { radius_m: 0.1, speed_m_s: 0.02, start: Start::Ramp, ramp_time_s: 200.0 };
        let p = CirclePath::new(Vec3::zeros(), &motion);
        let t = p.revolution_time().unwrap();
        assert!(t < 200.0 && (p.angle(t).0 - TAU).abs() < 1e-9);
        let still = Motion { radius_m: 0.1, speed_m_s: 0.0, start: Start::Abrupt, ramp_time_s: 0.0 };
        assert_eq!(CirclePath::new(Vec3::zeros(), &still).revolution_time(), None);
    }
}
