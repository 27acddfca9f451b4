//! An inertial unit on the cabin (scene `[control.imu]`): what its accelerometers and gyros
//! read, from the cabin's true motion.
//!
//! Like a strapdown unit, it reports its increments since the last reading (velocity and
//! angle), as means over that interval, in the cabin frame: the specific force
//! `f = R_½ᵀ (Δv/Δt − g) + b_a + n_a` (`R_½` the attitude half way) and the angular rate
//! `ω = log(R₀ᵀR₁)/Δt + b_g + n_g`, so that motion faster than its rate is averaged, not aliased;
//! its first reading is of the instant. The noises are white with the given densities N; a
//! reading, a mean over `1/rate`, carries `σ = N·√rate`. The biases start at the given values and walk: each reading moves them by
//! `K·√Δt` times a standard normal number (K the walk's density, Δt the time since the last).

use feedcore::random::SplitMix64;
use feedcore::scene::Imu as ImuSpec;
use feedcore::{Quat, Vec3};
use nalgebra::Quaternion;
use serde::{Deserialize, Serialize};

use crate::wrench::CabinMotion;

/// One reading, cabin frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImuReading {
    pub time: f64,
    /// Specific force (acceleration less gravity), m/s².
    pub specific_force: [f64; 3],
    /// Angular rate, rad/s.
    pub angular_rate: [f64; 3],
}

/// The instrument (immutable).
#[derive(Clone, Debug, PartialEq)]
pub struct Imu {
    /// Sample period, s.
    pub period: f64,
    /// Noise densities: accelerometer m/s²/√Hz, gyro rad/s/√Hz.
    pub accel_noise: f64,
    pub gyro_noise: f64,
    /// Bias random walks: accelerometer m/s²/√s, gyro rad/s/√s.
    pub accel_walk: f64,
    pub gyro_walk: f64,
    accel_bias: Vec3,
    gyro_bias: Vec3,
    seed: u64,
    gravity: Vec3,
}

/// What the instrument carries from reading to reading: its biases, the motion it last read
/// and its noise generator.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImuState {
    accel_bias: [f64; 3],
    gyro_bias: [f64; 3],
    /// The last reading's time, the cabin's velocity and attitude (w, x, y, z) then (None
    /// before the first).
    last: Option<(f64, [f64; 3], [f64; 4])>,
    rng: SplitMix64,
}

impl ImuState {
    /// The biases now: accelerometer, gyro (cabin frame).
    pub fn biases(&self) -> (Vec3, Vec3) {
        (Vec3::from(self.accel_bias), Vec3::from(self.gyro_bias))
    }
}

impl Imu {
    /// The instrument of a validated `[control.imu]` on a cabin under `gravity` (world frame).
    pub fn new(spec: &ImuSpec, gravity: Vec3) -> Imu {
        Imu {
            period: 1.0 / spec.rate_hz,
            accel_noise: spec.accel_noise_density,
            gyro_noise: spec.gyro_noise_density,
            accel_walk: spec.accel_bias_walk,
            gyro_walk: spec.gyro_bias_walk,
            accel_bias: Vec3::from(spec.accel_bias_m_s2),
            gyro_bias: Vec3::from(spec.gyro_bias_rad_s),
            seed: spec.seed.unwrap_or(0),
            gravity,
        }
    }

    /// Standard deviations of one reading's noise: accelerometer (m/s²), gyro (rad/s).
    pub fn sample_sigma(&self) -> (f64, f64) {
        let root_rate = (1.0 / self.period).sqrt();
        (self.accel_noise * root_rate, self.gyro_noise * root_rate)
    }

    pub fn start(&self) -> ImuState {
        ImuState {
            accel_bias: self.accel_bias.into(),
            gyro_bias: self.gyro_bias.into(),
            last: None,
            rng: SplitMix64::new(self.seed),
        }
    }

    /// The reading at time `t` of a cabin moving as `cabin`.
    pub fn read(&self, state: &mut ImuState, cabin: &CabinMotion, t: f64) -> ImuReading {
        let mut normal = || Vec3::new(state.rng.normal(), state.rng.normal(), state.rng.normal());
        let elapsed = state.last.map_or(0.0, |(last, _, _)| (t - last).max(0.0)).sqrt();
        let (walk_a, walk_g) = (normal() * (self.accel_walk * elapsed), normal() * (self.gyro_walk * elapsed));
        let (sigma_a, sigma_g) = self.sample_sigma();
        let (noise_a, noise_g) = (normal() * sigma_a, normal() * sigma_g);
        let accel_bias = Vec3::from(state.accel_bias) + walk_a;
        let gyro_bias = Vec3::from(state.gyro_bias) + walk_g;
        state.accel_bias = accel_bias.into();
        state.gyro_bias = gyro_bias.into();
        let r = cabin.orientation;
        let (specific_force, angular_rate) = match state.last {
            Some((last, velocity, attitude)) if t > last => {
                let dt = t - last;
                let before = Quat::from_quaternion(Quaternion::new(attitude[0], attitude[1], attitude[2], attitude[3]));
                let turn = (before.inverse() * r).scaled_axis();
                let halfway = before * Quat::from_scaled_axis(turn * 0.5);
                let mean_acceleration = (cabin.velocity - Vec3::from(velocity)) / dt;
                (halfway.inverse_transform_vector(&(mean_acceleration - self.gravity)), turn / dt)
            }
            _ => (
                r.inverse_transform_vector(&(cabin.acceleration - self.gravity)),
                r.inverse_transform_vector(&cabin.angular_velocity),
            ),
        };
        let q = r.into_inner();
        state.last = Some((t, cabin.velocity.into(), [q.w, q.i, q.j, q.k]));
        ImuReading {
            time: t,
            specific_force: (specific_force + accel_bias + noise_a).into(),
            angular_rate: (angular_rate + gyro_bias + noise_g).into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ImuSpec {
        ImuSpec {
            rate_hz: 200.0,
            accel_noise_density: 2e-3,
            gyro_noise_density: 3e-5,
            accel_bias_m_s2: [0.0; 3],
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_walk: 0.0,
            gyro_bias_walk: 0.0,
            seed: None,
            filter: None,
        }
    }

    const G: Vec3 = Vec3::new(0.0, 0.0, -9.81);

    /// Mean and standard deviation of each component of the readings' deviations.
    fn moments(xs: &[Vec3]) -> (Vec3, Vec3) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<Vec3>() / n;
        let var = xs.iter().map(|x| (x - mean).component_mul(&(x - mean))).sum::<Vec3>() / (n - 1.0);
        (mean, var.map(f64::sqrt))
    }

    /// A cabin turning uniformly about a tilted axis while accelerating uniformly: the gyro reads
    /// the body-frame rate, the accelerometer the body-frame specific force (at the attitude half
    /// way through each interval), each plus its bias, with the spread the density gives
    /// (N·√rate), over 20 000 readings (mean to 4σ/√n, spread to 3 %).
    #[test]
    fn readings_of_uniform_rotation_and_constant_acceleration() {
        let imu = Imu::new(
            &ImuSpec {
                accel_bias_m_s2: [0.02, -0.01, 0.005],
                gyro_bias_rad_s: [1e-4, 0.0, -2e-4],
                seed: Some(5),
                ..spec()
            },
            G,
        );
        let (sigma_a, sigma_g) = imu.sample_sigma();
        assert!((sigma_a - 2e-3 * 200f64.sqrt()).abs() < 1e-15 && (sigma_g - 3e-5 * 200f64.sqrt()).abs() < 1e-18);
        let n = 20_000;
        let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
        let (w, a) = (0.7, Vec3::new(0.3, -0.2, 0.1));
        let tilt = Quat::from_scaled_axis(Vec3::new(0.1, 0.05, 0.0));
        let mut state = imu.start();
        let (mut gyro, mut accel) = (Vec::new(), Vec::new());
        for k in 0..n {
            let t = k as f64 * imu.period;
            let cabin = CabinMotion {
                position: a * (0.5 * t * t),
                velocity: a * t,
                acceleration: a,
                orientation: Quat::from_scaled_axis(axis * (w * t)) * tilt,
                angular_velocity: axis * w,
                angular_acceleration: Vec3::zeros(),
            };
            let r = imu.read(&mut state, &cabin, t);
            if k == 0 {
                continue;
            }
            // the means over the interval: the rate is uniform, the attitude half way turns the
            // constant world acceleration
            let halfway = Quat::from_scaled_axis(axis * (w * (t - 0.5 * imu.period))) * tilt;
            gyro.push(Vec3::from(r.angular_rate) - halfway.inverse_transform_vector(&cabin.angular_velocity));
            accel.push(Vec3::from(r.specific_force) - halfway.inverse_transform_vector(&(a - G)));
        }
        let root_n = (n as f64).sqrt();
        for (what, xs, bias, sigma) in [
            ("gyro", &gyro, Vec3::new(1e-4, 0.0, -2e-4), sigma_g),
            ("accelerometer", &accel, Vec3::new(0.02, -0.01, 0.005), sigma_a),
        ] {
            let (mean, spread) = moments(xs);
            assert!((mean - bias).amax() < 4.0 * sigma / root_n, "{what}: mean {mean:?} against bias {bias:?}");
            assert!(spread.iter().all(|s| (s / sigma - 1.0).abs() < 0.03), "{what}: spread {spread:?} against {sigma}");
        }
    }

    /// Bias walks spread as K·√t: over 400 units (seeds) after 10 s, the spread of the bias is
    /// K·√10 to 15 % (the spread of 400 samples' standard deviation is 3.5 %), the mean zero.
    #[test]
    fn biases_walk_as_their_density_says() {
        let (k_a, k_g) = (1e-3, 2e-5);
        let mut finals = (Vec::new(), Vec::new());
        for seed in 0..400 {
            let imu = Imu::new(&ImuSpec { accel_bias_walk: k_a, gyro_bias_walk: k_g, seed: Some(seed), ..spec() }, G);
            let mut state = imu.start();
            let rest = CabinMotion::at_rest(Vec3::zeros(), Quat::identity());
            for k in 0..=2000 {
                imu.read(&mut state, &rest, k as f64 * imu.period);
            }
            let (a, g) = state.biases();
            finals.0.push(a);
            finals.1.push(g);
        }
        for (what, xs, k) in [("accelerometer", &finals.0, k_a), ("gyro", &finals.1, k_g)] {
            let (mean, spread) = moments(xs);
            let expected = k * 10f64.sqrt();
            assert!(mean.amax() < 4.0 * expected / 20.0, "{what}: mean {mean:?}");
            assert!(spread.iter().all(|s| (s / expected - 1.0).abs() < 0.15), "{what}: {spread:?} vs {expected}");
        }
    }

    #[test]
    fn the_same_seed_reads_the_same_numbers() {
        let imu = Imu::new(&ImuSpec { seed: Some(3), ..spec() }, G);
        let cabin = CabinMotion::at_rest(Vec3::zeros(), Quat::identity());
        let (mut a, mut b) = (imu.start(), imu.start());
        for k in 0..10 {
            let t = k as f64 * imu.period;
            assert_eq!(imu.read(&mut a, &cabin, t), imu.read(&mut b, &cabin, t));
        }
        let other = Imu::new(&ImuSpec { seed: Some(4), ..spec() }, G);
        assert_ne!(imu.read(&mut imu.start(), &cabin, 0.0), other.read(&mut other.start(), &cabin, 0.0));
    }
}
