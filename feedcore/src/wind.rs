//! The wind load on the cabin (scene `[wind]`): a mean speed plus longitudinal turbulence, and the
//! drag it exerts.
//!
//! Turbulence: the Kaimal spectrum in the form of IEC 61400-1 (ed. 3, annex B),
//!
//! ```text
//! S(f) = σ² · (4 L / U) / (1 + 6 f L / U)^(5/3),   σ = I · U,   L = 8.1 · 0.7 · min(z, 60 m)
//! ```
//!
//! (one-sided, m²/s² per Hz; over all frequencies it integrates to σ²). It is generated once, at
//! set-up, as a sum of harmonics: the band [f₁, f₂] is split into N equal widths Δf, harmonic k at
//! the centre f_k with amplitude √(2 S(f_k) Δf) and a phase drawn uniformly from the seed, so the
//! record's variance is Σ S(f_k) Δf, the midpoint rule of the spectrum's integral over the band.
//!
//! Load: the drag `F = ½ ρ C_d A |V| V` along the mean direction (horizontal), `V = U + u(t)`,
//! at the cabin centre point (no moment). The cabin's own velocity (mm/s against m/s) is left out
//! of V, so the load is a function of time only, evaluated at each step's end like the rest of
//! the external wrench. With `ramp_s` it rises from zero along a smooth step (C², quintic).

use crate::Vec3;
use crate::random::SplitMix64;
use crate::scene::Wind;

/// The wind of a scene, its harmonics drawn (immutable).
#[derive(Clone, Debug, PartialEq)]
pub struct WindLoad {
    /// Unit vector the wind blows towards (horizontal).
    direction: Vec3,
    /// ½ ρ C_d A, kg/m.
    half_rho_cda: f64,
    mean: f64,
    /// Per harmonic: amplitude (m/s), angular frequency (rad/s), phase (rad).
    amplitude: Vec<f64>,
    omega: Vec<f64>,
    phase: Vec<f64>,
    ramp: f64,
}

/// Turbulence length scale of the IEC Kaimal spectrum at height `z`, m.
fn length_scale(z: f64) -> f64 {
    8.1 * 0.7 * z.min(60.0)
}

/// The Kaimal spectral density of the longitudinal turbulence at `f` (Hz), m²/s² per Hz; zero in
/// still air.
pub fn kaimal(w: &Wind, f: f64) -> f64 {
    let u = w.mean_speed_m_s;
    if u == 0.0 {
        return 0.0;
    }
    let sigma = w.turbulence_intensity * u;
    let lu = length_scale(w.reference_height_m) / u;
    sigma * sigma * 4.0 * lu / (1.0 + 6.0 * f * lu).powf(5.0 / 3.0)
}

/// The Kaimal spectrum's integral over the band, exactly: σ² [(1 + 6 f₁ L/U)^(−2/3) − (1 + 6 f₂ L/U)^(−2/3)].
pub fn band_variance(w: &Wind) -> f64 {
    let u = w.mean_speed_m_s;
    if u == 0.0 {
        return 0.0;
    }
    let sigma = w.turbulence_intensity * u;
    let lu = length_scale(w.reference_height_m) / u;
    let g = |f: f64| (1.0 + 6.0 * f * lu).powf(-2.0 / 3.0);
    sigma * sigma * (g(w.band_hz[0]) - g(w.band_hz[1]))
}

impl WindLoad {
    /// Draws the harmonics of a (validated) `[wind]`.
    pub fn new(w: &Wind) -> WindLoad {
        let n = w.harmonics;
        let df = (w.band_hz[1] - w.band_hz[0]) / n as f64;
        let mut rng = SplitMix64::new(w.seed);
        let mut load = WindLoad {
            direction: {
                let a = w.direction_deg.to_radians();
                Vec3::new(a.cos(), a.sin(), 0.0)
            },
            half_rho_cda: 0.5 * w.air_density_kg_m3 * w.drag_area_m2,
            mean: w.mean_speed_m_s,
            amplitude: Vec::with_capacity(n),
            omega: Vec::with_capacity(n),
            phase: Vec::with_capacity(n),
            ramp: w.ramp_s,
        };
        for k in 0..n {
            let f = w.band_hz[0] + (k as f64 + 0.5) * df;
            load.amplitude.push((2.0 * kaimal(w, f) * df).sqrt());
            load.omega.push(std::f64::consts::TAU * f);
            load.phase.push(std::f64::consts::TAU * rng.uniform());
        }
        load
    }

    /// The record's variance, Σ a_k² / 2, m²/s².
    pub fn variance(&self) -> f64 {
        self.amplitude.iter().map(|a| 0.5 * a * a).sum()
    }

    /// The turbulent part of the speed at time `t`, m/s.
    pub fn turbulence(&self, t: f64) -> f64 {
        let mut u = 0.0;
        for k in 0..self.amplitude.len() {
            u += self.amplitude[k] * (self.omega[k] * t + self.phase[k]).cos();
        }
        u
    }

    /// The drag force on the cabin at time `t`, world frame, N.
    pub fn force(&self, t: f64) -> Vec3 {
        let v = self.mean + self.turbulence(t);
        let rise = if self.ramp > 0.0 {
            let x = (t / self.ramp).clamp(0.0, 1.0);
            x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
        } else {
            1.0
        };
        self.direction * (rise * self.half_rho_cda * v.abs() * v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wind(harmonics: usize, seed: u64) -> Wind {
        Wind {
            mean_speed_m_s: 10.0,
            direction_deg: 30.0,
            turbulence_intensity: 0.15,
            reference_height_m: 10.0,
            drag_area_m2: 1.9,
            air_density_kg_m3: 1.225,
            band_hz: [0.01, 5.0],
            harmonics,
            seed,
            ramp_s: 0.0,
        }
    }

    /// The harmonics' variance is the midpoint rule of the spectrum over the band: it converges
    /// to the exact integral as Δf², and the time record has that variance.
    #[test]
    fn the_harmonics_carry_the_spectrum_over_the_band() {
        let exact = band_variance(&wind(1, 0));
        // σ² = 2.25 m²/s²; the band holds most of it
        assert!(exact > 0.5 * 2.25 && exact < 2.25, "{exact}");
        let gap = |n| (WindLoad::new(&wind(n, 0)).variance() - exact).abs() / exact;
        let (coarse, fine) = (gap(500), gap(2000));
        assert!(fine < 2e-3, "{fine:e}");
        // second order: 4x the harmonics, ~16x closer
        assert!(coarse / fine > 12.0 && coarse / fine < 20.0, "{coarse:e} {fine:e}");
        // the record: with the band from 0, every harmonic and every sum and difference of two
        // makes a whole number of cycles in 2/Δf, so the record's mean is zero and its variance
        // Σ a²/2 exactly (uniform samples of a trigonometric polynomial, enough of them)
        let mut w = wind(200, 3);
        w.band_hz = [0.0, 5.0];
        let load = WindLoad::new(&w);
        let (window, n) = (2.0 / 0.025, 20_000);
        let dt = window / n as f64;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let u = load.turbulence(i as f64 * dt);
            s += u;
            s2 += u * u;
        }
        let (mean, var) = (s / n as f64, s2 / n as f64);
        assert!(mean.abs() < 1e-10, "{mean}");
        assert!((var - load.variance()).abs() < 1e-10 * load.variance(), "{var} vs {}", load.variance());
    }

    #[test]
    fn same_seed_bit_identical_other_seed_different() {
        let f = |seed| (0..200).map(|i| WindLoad::new(&wind(300, seed)).force(0.05 * i as f64)).collect::<Vec<_>>();
        assert_eq!(f(7), f(7));
        assert_ne!(f(7), f(8));
    }

    /// The drag along the mean direction, ½ ρ C_d A U² for still turbulence, rising smoothly.
    #[test]
    fn drag_of_the_mean_wind_and_the_ramp() {
        let mut w = wind(10, 0);
        w.turbulence_intensity = 0.0;
        w.ramp_s = 4.0;
        let load = WindLoad::new(&w);
        let full = 0.5 * 1.225 * 1.9 * 100.0;
        let f = load.force(10.0);
        let d = Vec3::new(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0);
        assert!((f - d * full).norm() < 1e-12 * full, "{f:?}");
        assert_eq!(load.force(0.0), Vec3::zeros());
        assert!((load.force(2.0) - d * (0.5 * full)).norm() < 1e-12 * full);
    }

    /// `[wind]` is validated like every section: the error names the file, the key and the value.
    #[test]
    fn bad_wind_keys_are_refused_by_name() {
        let base = crate::shipped::embedded("lt50m_C_compensated.toml").unwrap().to_string();
        for (key, bad) in [
            ("mean_speed_m_s = 10.0", "mean_speed_m_s = -1.0"),
            ("turbulence_intensity = 0.15", "turbulence_intensity = 1.5"),
            ("drag_area_m2 = 1.92", "drag_area_m2 = 0.0"),
            ("band_hz = [0.01, 10.0]", "band_hz = [10.0, 0.01]"),
            ("harmonics = 1000", "harmonics = 0"),
            ("ramp_s = 5.0", "ramp_s = nan"),
        ] {
            assert!(base.contains(key), "{key}");
            let e = crate::scene::Scene::from_toml(&base.replace(key, bad), "w.toml").unwrap_err().to_string();
            let name = key.split(' ').next().unwrap();
            assert!(e.contains("w.toml") && e.contains(&format!("wind.{name}")), "{bad}: {e}");
        }
        let e = crate::scene::Scene::from_toml(&base.replace("ramp_s = 5.0", "gust = 1.0"), "w.toml").unwrap_err();
        assert!(e.to_string().contains("gust"), "{e}");
    }
}
