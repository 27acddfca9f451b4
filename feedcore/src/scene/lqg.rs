//! The second level's model-based controller (`[control] law = "lqg"`): the linear design model
//! of the coupled system that `master design` writes into `[control.lqg]`, and the weights of
//! its cost. The controller itself (the sampled-data LQG of this model with the scene's
//! instruments) is made from it when a model is built (`design::plant`, `stewart::compensation`).
//!
//! Every quantity is a deviation from the static equilibrium at the scene's pose, world frame for
//! the cabin (its centre point's displacement and its rotation vector) and the cabin frame for the
//! platform's relative pose `r` (its centre, m, and its z-y-x angles, rad: the commands' form).

use serde::{Deserialize, Serialize};

use super::{Check, SceneError, show};

/// How the second level makes its commands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Law {
    /// From the measured (or fused) pose, through the command filter and its notch.
    #[default]
    Filter,
    /// The LQG controller of `[control.lqg]`: the command filter's stages are the actuators' servo.
    Lqg,
}

/// `[control.lqg]`: the design model and the cost's weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LqgDesign {
    /// The fixes' delay the controller assumes, s (the instrument's may differ).
    pub delay_s: f64,
    /// The cable–cabin modes kept (platform locked): natural frequencies, Hz; damping ratios.
    pub modes_hz: Vec<f64>,
    pub damping_ratios: Vec<f64>,
    /// Each mode's cabin part (mass-normalized shape: displacement m, rotation rad, per √kg).
    pub cabin_shapes: Vec<Vec<f64>>,
    /// The platform's wrench on the cabin (force N, moment N·m about the centre point) per unit
    /// of its relative pose and of its relative acceleration: 6 × 6, rows the wrench.
    pub reaction_pose: Vec<Vec<f64>>,
    pub reaction_acceleration: Vec<Vec<f64>>,
    /// The legs' lengths per unit relative pose, 6 × 6.
    pub leg_jacobian: Vec<Vec<f64>>,
    /// The actuator forces (N) per unit relative pose, relative acceleration (6 × 6 each), the
    /// cabin's acceleration (linear, angular; 6 × 6) and its rotation (6 × 3: gravity turns).
    pub force_pose: Vec<Vec<f64>>,
    pub force_acceleration: Vec<Vec<f64>>,
    pub force_cabin_acceleration: Vec<Vec<f64>>,
    pub force_cabin_rotation: Vec<Vec<f64>>,
    /// From the cabin centre point to the feed point at rest, world frame, m.
    pub feed_arm_m: [f64; 3],
    /// The wind load: its direction (unit, world), the force per m/s of turbulence (ρ C_d A U,
    /// the drag linearized about the mean), and the turbulence as white noise of unit intensity
    /// through `gain · s/(s + 2π f_h) · 1/(s + 2π p₀) · Π (s + 2π z_i)/(s + 2π p_i)` (Hz).
    pub wind_direction: [f64; 3],
    pub wind_force_n_per_m_s: f64,
    pub wind_gain: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind_high_pass_hz: Option<f64>,
    pub wind_poles_hz: Vec<f64>,
    pub wind_zeros_hz: Vec<f64>,
    /// The linear model's error against the nonlinear one, as a white wrench on the cabin: its
    /// one-sided densities, force N/√Hz (each component) and moment N·m/√Hz.
    pub model_error_force_n: f64,
    pub model_error_moment_nm: f64,
    /// The cost: E|feed error|² + (tilt_weight_m)² E|feed rotation|² + stroke_weight² Σ E[Δℓ²]
    /// + force_weight_m_per_n² Σ E[ΔF²] + command_weight² E|r_command|².
    pub tilt_weight_m: f64,
    pub stroke_weight: f64,
    pub force_weight_m_per_n: f64,
    pub command_weight: f64,
}

/// Most modes a design model may keep.
pub const MAX_DESIGN_MODES: usize = 400;
/// Most sections of the wind's filter.
const MAX_WIND_SECTIONS: usize = 40;

impl LqgDesign {
    pub(super) fn validate(&self, c: &Check) -> Result<(), SceneError> {
        let key = |k: &str| format!("control.lqg.{k}");
        c.finite_nonneg(&key("delay_s"), self.delay_s)?;
        let n = self.modes_hz.len();
        if !(1..=MAX_DESIGN_MODES).contains(&n) {
            return Err(c.err(
                &key("modes_hz"),
                &format!("{n} modes"),
                &format!("the design model keeps 1 to {MAX_DESIGN_MODES} modes (`master design` writes them)"),
            ));
        }
        for (i, f) in self.modes_hz.iter().enumerate() {
            c.positive(&format!("{}[{i}]", key("modes_hz")), *f)?;
        }
        let count = |k: &str, len: usize, want: usize| -> Result<(), SceneError> {
            if len == want {
                Ok(())
            } else {
                Err(c.err(&key(k), &format!("{len} values"), &format!("needs {want}, one per mode of modes_hz")))
            }
        };
        count("damping_ratios", self.damping_ratios.len(), n)?;
        for (i, z) in self.damping_ratios.iter().enumerate() {
            let k = format!("{}[{i}]", key("damping_ratios"));
            c.finite(&k, *z)?;
            if !(*z > 0.0 && *z < 1.0) {
                return Err(c.err(
                    &k,
                    &show(*z),
                    "must lie in (0, 1): an undamped mode the platform cannot reach has no stabilizing controller",
                ));
            }
        }
        count("cabin_shapes", self.cabin_shapes.len(), n)?;
        matrix(c, &key("cabin_shapes"), &self.cabin_shapes, n, 6)?;
        for (name, m, cols) in [
            ("reaction_pose", &self.reaction_pose, 6),
            ("reaction_acceleration", &self.reaction_acceleration, 6),
            ("leg_jacobian", &self.leg_jacobian, 6),
            ("force_pose", &self.force_pose, 6),
            ("force_acceleration", &self.force_acceleration, 6),
            ("force_cabin_acceleration", &self.force_cabin_acceleration, 6),
            ("force_cabin_rotation", &self.force_cabin_rotation, 3),
        ] {
            matrix(c, &key(name), m, 6, cols)?;
        }
        c.position(&key("feed_arm_m"), &self.feed_arm_m)?;
        c.vector(&key("wind_direction"), &self.wind_direction)?;
        let length = self.wind_direction.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (length - 1.0).abs() > 1e-9 {
            return Err(c.err(&key("wind_direction"), &format!("{:?}", self.wind_direction), "must be a unit vector"));
        }
        c.finite_nonneg(&key("wind_force_n_per_m_s"), self.wind_force_n_per_m_s)?;
        c.positive(&key("wind_gain"), self.wind_gain)?;
        if let Some(h) = self.wind_high_pass_hz {
            c.positive(&key("wind_high_pass_hz"), h)?;
        }
        let p = self.wind_poles_hz.len();
        if !(1..=MAX_WIND_SECTIONS).contains(&p) {
            return Err(c.err(
                &key("wind_poles_hz"),
                &format!("{p} poles"),
                &format!("the wind's filter has 1 to {MAX_WIND_SECTIONS} poles"),
            ));
        }
        if self.wind_zeros_hz.len() + 1 != p {
            return Err(c.err(
                &key("wind_zeros_hz"),
                &format!("{} zeros", self.wind_zeros_hz.len()),
                &format!("needs one zero fewer than wind_poles_hz ({p}): the filter rolls off"),
            ));
        }
        for (name, v) in [("wind_poles_hz", &self.wind_poles_hz), ("wind_zeros_hz", &self.wind_zeros_hz)] {
            for (i, x) in v.iter().enumerate() {
                c.positive(&format!("{}[{i}]", key(name)), *x)?;
            }
        }
        c.finite_nonneg(&key("model_error_force_n"), self.model_error_force_n)?;
        c.finite_nonneg(&key("model_error_moment_nm"), self.model_error_moment_nm)?;
        c.finite_nonneg(&key("tilt_weight_m"), self.tilt_weight_m)?;
        c.finite_nonneg(&key("stroke_weight"), self.stroke_weight)?;
        c.finite_nonneg(&key("force_weight_m_per_n"), self.force_weight_m_per_n)?;
        c.positive(&key("command_weight"), self.command_weight)?;
        Ok(())
    }
}

/// A `rows × cols` matrix of finite numbers, given as rows.
fn matrix(c: &Check, key: &str, m: &[Vec<f64>], rows: usize, cols: usize) -> Result<(), SceneError> {
    if m.len() != rows {
        return Err(c.err(key, &format!("{} rows", m.len()), &format!("needs {rows} rows of {cols} values")));
    }
    for (i, row) in m.iter().enumerate() {
        if row.len() != cols {
            return Err(c.err(&format!("{key}[{i}]"), &format!("{} values", row.len()), &format!("needs {cols}")));
        }
        c.vector(&format!("{key}[{i}]"), row)?;
    }
    Ok(())
}
