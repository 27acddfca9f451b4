//! The scene file: every number of a simulation, read from TOML and validated.
//!
//! A scene is parsed into plain structs (unknown keys and missing keys are errors), then
//! [`Scene::validated`] rejects non-physical values with an error that names the file, the key
//! and the value, and freezes the scene into a [`ValidScene`], what models are built from.
//! Geometry comes out through accessors ([`Scene::anchors`], ...) so that the models never
//! re-derive it differently.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::files::{ReadError, read_limited};
use crate::rigid::MassProperties;
use crate::{Mat3, Quat, Vec3};

mod lqg;
mod valid;
pub use lqg::{Law, LqgDesign, MAX_DESIGN_MODES};
pub use valid::{ControlTarget, DampingFit, ValidScene};

/// A rejected scene: which file, which key, which value, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}", self.render())]
pub struct SceneError {
    pub file: String,
    pub key: String,
    pub value: String,
    pub reason: String,
    /// Why the file could not be read as a scene at all (before any key was looked at).
    pub kind: SceneErrorKind,
}

/// What kind of problem a [`SceneError`] is, for callers that react differently (e.g. the CLI
/// names its override flag for a file that is too large).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneErrorKind {
    /// The file could not be opened or read, or is not a regular file.
    Unreadable,
    /// The file is larger than the limit it was read with.
    TooLarge { limit: u64 },
    /// Not TOML, or not the scene's layout (unknown, missing, mistyped or mis-sized keys).
    Syntax,
    /// A value outside its physical or numerical range.
    Invalid,
}

impl SceneError {
    fn render(&self) -> String {
        if self.key.is_empty() {
            format!("{}: {}", self.file, self.reason)
        } else if self.value.is_empty() {
            format!("{}: `{}`: {}", self.file, self.key, self.reason)
        } else {
            format!("{}: `{}` = {}: {}", self.file, self.key, self.value, self.reason)
        }
    }

    fn unreadable(file: &str, kind: SceneErrorKind, reason: String) -> SceneError {
        SceneError { file: file.to_string(), key: String::new(), value: String::new(), reason, kind }
    }
}

/// Points on a horizontal circle: `(r cos φ, r sin φ, z)` for each angle φ (degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ring {
    pub radius_m: f64,
    pub z_m: f64,
    pub angle_deg: Vec<f64>,
}

impl Ring {
    pub fn points(&self) -> Vec<Vec3> {
        self.angle_deg
            .iter()
            .map(|a| {
                let (s, c) = a.to_radians().sin_cos();
                Vec3::new(self.radius_m * c, self.radius_m * s, self.z_m)
            })
            .collect()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cables {
    pub area_m2: f64,
    pub density_kg_m3: f64,
    pub youngs_modulus_pa: f64,
    /// Two-node bar elements per cable (the paper's k − 1).
    pub elements: usize,
    /// The rope's minimum breaking load, N (optional): statics, run and sweep report each
    /// cable's utilisation (tension over it) and flag overload.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub breaking_load_n: Option<f64>,
}

/// Axial strain beyond which a steel rope has left its elastic range (steel yields near 1 %):
/// the linear-elastic cables of the models no longer describe it.
pub const ELASTIC_STRAIN_LIMIT: f64 = 0.01;

impl Cables {
    /// The axial strain a tension gives.
    pub fn strain(&self, tension_n: f64) -> f64 {
        tension_n / self.axial_stiffness()
    }

    /// A tension over the breaking load (1: at it), if the scene gives one.
    pub fn utilisation(&self, tension_n: f64) -> Option<f64> {
        self.breaking_load_n.map(|b| tension_n / b)
    }

    pub fn mass_per_length(&self) -> f64 {
        self.area_m2 * self.density_kg_m3
    }
    pub fn axial_stiffness(&self) -> f64 {
        self.area_m2 * self.youngs_modulus_pa
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cabin {
    pub mass_kg: f64,
    /// Centre of mass in the body frame (from the cabin centre point).
    #[serde(deserialize_with = "exact::array")]
    pub center_of_mass_m: [f64; 3],
    /// Inertia about the centre of mass, body frame (rows).
    #[serde(deserialize_with = "exact::matrix")]
    pub inertia_kg_m2: [[f64; 3]; 3],
    /// Cable attachment points in the body frame; cable i ends at attachment i.
    pub attachments: Ring,
}

/// Pose of the cabin centre point: position, and orientation (body to world) given either as a
/// unit quaternion or as a unit axis and an angle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    #[serde(deserialize_with = "exact::array")]
    pub position_m: [f64; 3],
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub orientation_wxyz: Option<[f64; 4]>,
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub rotation_axis: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation_angle_deg: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegPart {
    pub mass_kg: f64,
    pub length_m: f64,
    /// Distance of the centre of mass from this part's own joint centre (Hooke joint for the
    /// upper part, spherical joint for the lower part), along the leg axis.
    pub com_from_joint_m: f64,
    pub inertia_transverse_kg_m2: f64,
    pub inertia_axial_kg_m2: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Platform {
    pub mass_kg: f64,
    /// Inertia about the centre of mass, platform frame (rows).
    #[serde(deserialize_with = "exact::matrix")]
    pub inertia_kg_m2: [[f64; 3]; 3],
    /// Centre of the circle motion, in the cabin frame. The platform frame is parallel to the
    /// cabin frame and its origin is the platform's centre of mass.
    #[serde(deserialize_with = "exact::array")]
    pub nominal_center_m: [f64; 3],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stewart {
    /// Hooke joint centres on the cabin, cabin frame; leg k starts at base joint k.
    pub base_joints: Ring,
    /// Spherical joint centres on the moving platform, platform frame; leg k ends at platform joint k.
    pub platform_joints: Ring,
    pub platform: Platform,
    pub upper_leg: LegPart,
    pub lower_leg: LegPart,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// Full speed at t = 0 (the paper).
    Abrupt,
    /// Speed ramped smoothly from 0 over `ramp_time_s`.
    Ramp,
    /// Full speed at t = 0, and the cabin given the velocity that keeps the momentum of cabin
    /// and platform at zero (the platform pushes off the cabin; docs/reproduction.md).
    Consistent,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// The platform centre moves on this circle (cabin frame, plane parallel to the base).
    pub radius_m: f64,
    pub speed_m_s: f64,
    pub start: Start,
    /// Used when `start = "ramp"`.
    pub ramp_time_s: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Damping {
    /// Modal damping ratio reached at the two fit frequencies (Rayleigh damping).
    pub ratio: f64,
    /// Natural modes (1-based) of the cable–cabin system at the static equilibrium whose
    /// frequencies the Rayleigh coefficients are fitted at. Give this or `fit_frequencies_hz`.
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub fit_modes: Option<[usize; 2]>,
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub fit_frequencies_hz: Option<[f64; 2]>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Solver {
    pub dt_s: f64,
    pub t_end_s: f64,
    /// Spectral radius at infinite frequency of the generalized-α integrator, in [0, 1].
    pub rho_inf: f64,
    /// Newton converged when the correction is below this, relative to the step's displacement scale.
    pub newton_tol: f64,
    pub newton_max_iter: usize,
}

/// How the Stewart platform takes part.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StewartMode {
    /// A moving multibody system coupled to the cabin.
    Coupled,
    /// A rigid mass attached to the cabin at the platform's starting pose.
    Locked,
    /// No Stewart platform at all.
    Absent,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Analyses {
    pub stewart: StewartMode,
    /// Number of natural modes computed and reported (0: no eigen solve).
    pub modes: usize,
    /// The platform's wrench on the cabin: the physics (`full`, the default), or without the
    /// shift of its weight as it moves (`inertial_only`: a hypothesis for the paper's
    /// amplitudes, docs/reproduction.md; the monolithic model only).
    #[serde(default, skip_serializing_if = "WrenchModel::is_full")]
    pub wrench: WrenchModel,
}

/// Which part of the platform's wrench reaches the cabin.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WrenchModel {
    /// The joint reactions: inertia, weight and its shift with the platform's position.
    #[default]
    Full,
    /// The joint reactions minus the moment of the weight shift, `(R (S(t) − S(0))) × g`
    /// (S the first moment of the platform and legs about the cabin centre point, cabin frame):
    /// the cabin carries the platform's weight as at the start, plus the inertial reactions.
    InertialOnly,
}

impl WrenchModel {
    pub fn is_full(&self) -> bool {
        *self == WrenchModel::Full
    }
}

/// Output quantities a scene may ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    CabinDisplacement,
    CabinRotation,
    CableTensions,
    Wrench,
    ActuatorForces,
    PlatformPose,
}

impl Quantity {
    /// The name a scene gives it.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::CabinDisplacement => "cabin_displacement",
            Quantity::CabinRotation => "cabin_rotation",
            Quantity::CableTensions => "cable_tensions",
            Quantity::Wrench => "wrench",
            Quantity::ActuatorForces => "actuator_forces",
            Quantity::PlatformPose => "platform_pose",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outputs {
    pub sample_interval_s: f64,
    pub quantities: Vec<Quantity>,
}

/// A prescribed wrench on the cabin, `W(t) = amplitude · sin(2π f t)` (force; moment about the
/// cabin centre point; world frame): the disturbance of a scene without a moving platform.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disturbance {
    #[serde(deserialize_with = "exact::array")]
    pub force_amplitude_n: [f64; 3],
    #[serde(deserialize_with = "exact::array")]
    pub moment_amplitude_nm: [f64; 3],
    pub frequency_hz: f64,
}

impl Disturbance {
    /// The wrench at time `t` as (force, moment).
    pub fn wrench(&self, t: f64) -> [f64; 6] {
        let s = (2.0 * std::f64::consts::PI * self.frequency_hz * t).sin();
        let (f, m) = (self.force_amplitude_n, self.moment_amplitude_nm);
        [f[0] * s, f[1] * s, f[2] * s, m[0] * s, m[1] * s, m[2] * s]
    }
}

/// A wind load on the cabin: mean speed plus longitudinal turbulence from the Kaimal spectrum,
/// drag `½ ρ C_d A |V| V` along the mean direction (see [`crate::wind`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wind {
    /// Mean speed at the cabin, m/s.
    pub mean_speed_m_s: f64,
    /// Direction the wind blows towards: azimuth from world x, counter-clockwise about Z, degrees.
    #[serde(default)]
    pub direction_deg: f64,
    /// Turbulence intensity σ_u / U.
    pub turbulence_intensity: f64,
    /// Height above the ground for the turbulence length scale (IEC 61400-1 Kaimal:
    /// L = 8.1 · 0.7 · min(z, 60 m)), m.
    pub reference_height_m: f64,
    /// Drag coefficient times the cabin's projected area, m².
    pub drag_area_m2: f64,
    #[serde(default = "standard_air_density")]
    pub air_density_kg_m3: f64,
    /// The turbulence's frequency band [lowest, highest], Hz.
    #[serde(deserialize_with = "exact::array")]
    pub band_hz: [f64; 2],
    /// Harmonics the band is split into (equal widths, one per band centre).
    pub harmonics: usize,
    /// Seed of the harmonics' phases.
    #[serde(default)]
    pub seed: u64,
    /// The load rises from zero along a smooth step over this time, s (0: from t = 0 at once).
    #[serde(default)]
    pub ramp_s: f64,
}

/// Air at 15 °C and sea level, kg/m³.
fn standard_air_density() -> f64 {
    1.225
}

/// Most harmonics of a wind load (each costs a cosine per step).
pub const MAX_WIND_HARMONICS: usize = 100_000;

/// What the feed point follows in the world frame (see [`Control`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    /// The feed point's start position, held still.
    Hold,
    /// A horizontal circle through the start position, centre `circle_center_offset_m` from it.
    Circle,
    /// Displacements from the start position at given times, interpolated linearly.
    Samples,
}

/// How the compensation measures the cabin's pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// No compensation: the platform holds its start pose relative to the cabin (the feed error
    /// is still reported: the uncompensated reference).
    Off,
    /// The true pose, continuously, with no delay or noise.
    Ideal,
    /// Sampled at `sample_rate_hz`, delayed by `delay_s`, with uniform noise.
    Sampled,
}

/// What the compensation commands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Compensate {
    /// The platform's whole pose: the feed point on its target, the platform's attitude (hence
    /// the feed's axis) held in the world.
    #[default]
    Pose,
    /// Its position only: the platform translates relative to the cabin and tilts with it.
    Position,
}

/// The feed's axis when a scene gives none: down the platform's z axis, towards the reflector.
pub const DEFAULT_FEED_AXIS: [f64; 3] = [0.0, 0.0, -1.0];

/// The second level: the Stewart platform puts a feed point on a target in the world frame,
/// from the measured cabin pose. Absent: the platform follows `[motion]` relative to the cabin.
/// How far from the platform's centre a feed point may lie, m.
const FEED_POINT_REACH_M: f64 = 100.0;

/// Positions a scene may hold, m: a radio telescope spans kilometres, so a farther one is a
/// mistyped number.
const FAR_M: f64 = 1e6;

/// Sample rates a sensor may have, Hz.
const SENSOR_RATES_HZ: (f64, f64) = (1e-6, 1e6);

/// The longest step against the shortest sample period of the second level's sensors.
pub const STEP_PER_PERIOD: f64 = 0.25;

/// The longest step a scene's sensors allow ([`Control::step_bound`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepBound {
    /// The longest step, s.
    pub most: f64,
    /// The shortest sample period, s, and the key of `[control]` that sets it.
    pub period: f64,
    pub key: &'static str,
}

impl StepBound {
    /// Whether a step of `h` s takes every sample (a relative 1e-9 over the bound is the
    /// rounding of a step computed from a rate).
    pub fn admits(&self, h: f64) -> bool {
        h <= self.most * (1.0 + 1e-9)
    }

    /// Why a step of `h` is refused: the sensor, its period and the longest step that works.
    pub fn refusal(&self, h: f64) -> String {
        format!(
            "a step of {h} s is longer than a quarter of the sensor's sample period {} s ([control] {}): a \
             sample is taken at the first step start after its instant; take steps of at most {} s or lower \
             control.{}",
            self.period, self.key, self.most, self.key
        )
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// The feed point, platform body frame (from the platform's centre of mass).
    #[serde(deserialize_with = "exact::array")]
    pub feed_point_m: [f64; 3],
    /// The feed's axis, a direction in the platform frame (normalized when used); absent:
    /// [`DEFAULT_FEED_AXIS`]. Its angle from its start direction is the feed's tilt error.
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub feed_axis: Option<[f64; 3]>,
    /// What the compensation commands (default: the whole pose).
    #[serde(default)]
    pub compensate: Compensate,
    pub target: TargetKind,
    /// `circle`: centre of the circle from the feed's start position (horizontal, world frame);
    /// the radius is its length, the target starts at the start position.
    #[serde(default, deserialize_with = "exact::option", skip_serializing_if = "Option::is_none")]
    pub circle_center_offset_m: Option<[f64; 3]>,
    /// `circle`: speed along the circle (counter-clockwise about world Z), m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub circle_speed_m_s: Option<f64>,
    /// `samples`: ascending times, s, and the target's displacement from the start position at
    /// them (world frame, m); held before the first and after the last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_time_s: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_x_m: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_y_m: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_z_m: Option<Vec<f64>>,
    pub sensor: SensorKind,
    /// `sampled`: measurement rate, Hz; delay from measurement to command, s; amplitudes of the
    /// uniform noise on each position component (m) and rotation-vector component (rad); seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_rate_hz: Option<f64>,
    #[serde(default)]
    pub delay_s: f64,
    #[serde(default)]
    pub noise_m: f64,
    #[serde(default)]
    pub noise_rad: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Bandwidth of the command filter (`filter_stages` first-order stages, critically damped), Hz; absent:
    /// each new command is reached along a smooth step in half a sample period.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bandwidth_hz: Option<f64>,
    /// Stages of the command filter, each first order of `bandwidth_hz`: 2 (the default) keeps
    /// the platform's position and velocity continuous at a new command, 3 its acceleration too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter_stages: Option<u32>,
    /// A notch in the commands at this frequency, Hz (e.g. a cable–cabin mode the loop would
    /// pump), of quality `notch_q` (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub notch_hz: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub notch_q: Option<f64>,
    /// Leg length limits (joint centre to joint centre), m: absolute, or a stroke around each
    /// leg's length at the start pose. Reaching one is reported, not clipped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_leg_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_leg_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stroke_m: Option<f64>,
    /// Largest actuator force in magnitude, N; reaching it is reported, not clipped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_limit_n: Option<f64>,
    /// With `imu`: how far ahead of the estimate the command is computed, s (the lag of the
    /// command filter and actuators it makes up for); default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prediction_s: Option<f64>,
    /// How the commands are made: the filter (default) or the LQG controller of `lqg`.
    #[serde(default, skip_serializing_if = "is_filter")]
    pub law: Law,
    /// An inertial unit on the cabin, fused with the sampled sensor's fixes (a table).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imu: Option<Imu>,
    /// With `law = "lqg"`: the design model and the cost's weights (last: a table).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lqg: Option<LqgDesign>,
}

fn is_filter(law: &Law) -> bool {
    *law == Law::Filter
}

/// An inertial unit on the cabin (`[control.imu]`): its readings are fused with the sampled
/// sensor's (the total station's) delayed fixes into the cabin pose the command is made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Imu {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// White-noise densities: accelerometer, m/s²/√Hz; gyro, rad/s/√Hz.
    pub accel_noise_density: f64,
    pub gyro_noise_density: f64,
    /// Biases at the start, cabin frame: accelerometer, m/s²; gyro, rad/s (default zero).
    #[serde(default, deserialize_with = "exact::array")]
    pub accel_bias_m_s2: [f64; 3],
    #[serde(default, deserialize_with = "exact::array")]
    pub gyro_bias_rad_s: [f64; 3],
    /// Bias random walks: accelerometer, m/s²/√s; gyro, rad/s/√s (default zero).
    #[serde(default)]
    pub accel_bias_walk: f64,
    #[serde(default)]
    pub gyro_bias_walk: f64,
    /// Seed of the unit's noise (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// What the fusion's Kalman filter assumes (`[control.imu.filter]`); by default the
    /// instruments' own figures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter: Option<ImuFilter>,
}

/// The noise model of the fusion's Kalman filter (`[control.imu.filter]`), where it is not the
/// instruments' own: each key left out takes the instrument's figure (the unit's densities and
/// walks, the size of its largest start bias, the sampled sensor's noise).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuFilter {
    /// White-noise densities: accelerometer, m/s²/√Hz; gyro, rad/s/√Hz.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_noise_density: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_noise_density: Option<f64>,
    /// Bias random walks: accelerometer, m/s²/√s; gyro, rad/s/√s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_bias_walk: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_bias_walk: Option<f64>,
    /// The size of the start biases (standard deviation per component): m/s², rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_bias_m_s2: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro_bias_rad_s: Option<f64>,
    /// The fixes' noise: within ±fix_noise_m per position and ±fix_noise_rad per rotation
    /// component (uniform).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fix_noise_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fix_noise_rad: Option<f64>,
}

/// The fusion filter's noise model, every figure resolved (see [`ImuFilter`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusionModel {
    pub accel_noise_density: f64,
    pub gyro_noise_density: f64,
    pub accel_bias_walk: f64,
    pub gyro_bias_walk: f64,
    pub accel_bias_m_s2: f64,
    pub gyro_bias_rad_s: f64,
    pub fix_noise_m: f64,
    pub fix_noise_rad: f64,
}

impl FusionModel {
    /// The same model written out as `[control.imu.filter]` (every key given).
    pub fn as_filter(&self) -> ImuFilter {
        ImuFilter {
            accel_noise_density: Some(self.accel_noise_density),
            gyro_noise_density: Some(self.gyro_noise_density),
            accel_bias_walk: Some(self.accel_bias_walk),
            gyro_bias_walk: Some(self.gyro_bias_walk),
            accel_bias_m_s2: Some(self.accel_bias_m_s2),
            gyro_bias_rad_s: Some(self.gyro_bias_rad_s),
            fix_noise_m: Some(self.fix_noise_m),
            fix_noise_rad: Some(self.fix_noise_rad),
        }
    }
}

/// Largest biases an inertial unit may have: m/s², rad/s (a larger one is a unit mistake).
const IMU_BIAS_LIMITS: (f64, f64) = (100.0, 10.0);
/// Longest prediction horizon, s.
const PREDICTION_LIMIT_S: f64 = 10.0;

/// The numbers of first-order stages the command filter has (`filter_stages`).
pub const FILTER_STAGES: std::ops::RangeInclusive<u32> = 2..=3;

impl Imu {
    fn validate(&self, c: &Check) -> Result<(), SceneError> {
        c.positive("control.imu.rate_hz", self.rate_hz)?;
        c.within(
            "control.imu.rate_hz",
            self.rate_hz,
            SENSOR_RATES_HZ,
            "a sensor's rate: one sample in 11.6 days to 1 MHz",
        )?;
        c.finite_nonneg("control.imu.accel_noise_density", self.accel_noise_density)?;
        c.finite_nonneg("control.imu.gyro_noise_density", self.gyro_noise_density)?;
        c.finite_nonneg("control.imu.accel_bias_walk", self.accel_bias_walk)?;
        c.finite_nonneg("control.imu.gyro_bias_walk", self.gyro_bias_walk)?;
        for (key, bias, limit, unit) in [
            ("control.imu.accel_bias_m_s2", &self.accel_bias_m_s2, IMU_BIAS_LIMITS.0, "m/s²"),
            ("control.imu.gyro_bias_rad_s", &self.gyro_bias_rad_s, IMU_BIAS_LIMITS.1, "rad/s"),
        ] {
            for (i, b) in bias.iter().enumerate() {
                c.within(&format!("{key}[{i}]"), *b, (-limit, limit), &format!("a bias within ±{limit} {unit}"))?;
            }
        }
        let Some(f) = &self.filter else { return Ok(()) };
        for (key, value) in [
            ("accel_noise_density", f.accel_noise_density),
            ("gyro_noise_density", f.gyro_noise_density),
            ("accel_bias_walk", f.accel_bias_walk),
            ("gyro_bias_walk", f.gyro_bias_walk),
            ("fix_noise_m", f.fix_noise_m),
            ("fix_noise_rad", f.fix_noise_rad),
        ] {
            if let Some(v) = value {
                c.finite_nonneg(&format!("control.imu.filter.{key}"), v)?;
            }
        }
        for (key, value, limit, unit) in [
            ("accel_bias_m_s2", f.accel_bias_m_s2, IMU_BIAS_LIMITS.0, "m/s²"),
            ("gyro_bias_rad_s", f.gyro_bias_rad_s, IMU_BIAS_LIMITS.1, "rad/s"),
        ] {
            if let Some(v) = value {
                c.within(
                    &format!("control.imu.filter.{key}"),
                    v,
                    (0.0, limit),
                    &format!("a bias size within 0…{limit} {unit}"),
                )?;
            }
        }
        Ok(())
    }
}

impl Control {
    /// The fusion filter's noise model: `[control.imu.filter]`, its keys left out taken from the
    /// instruments (`None` without an inertial unit).
    pub fn fusion_model(&self) -> Option<FusionModel> {
        let imu = self.imu.as_ref()?;
        let f = imu.filter.clone().unwrap_or_default();
        let largest = |b: &[f64; 3]| b.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        Some(FusionModel {
            accel_noise_density: f.accel_noise_density.unwrap_or(imu.accel_noise_density),
            gyro_noise_density: f.gyro_noise_density.unwrap_or(imu.gyro_noise_density),
            accel_bias_walk: f.accel_bias_walk.unwrap_or(imu.accel_bias_walk),
            gyro_bias_walk: f.gyro_bias_walk.unwrap_or(imu.gyro_bias_walk),
            accel_bias_m_s2: f.accel_bias_m_s2.unwrap_or(largest(&imu.accel_bias_m_s2)),
            gyro_bias_rad_s: f.gyro_bias_rad_s.unwrap_or(largest(&imu.gyro_bias_rad_s)),
            fix_noise_m: f.fix_noise_m.unwrap_or(self.noise_m),
            fix_noise_rad: f.fix_noise_rad.unwrap_or(self.noise_rad),
        })
    }

    /// Switches the compensation off (the uncompensated reference): the platform holds its start
    /// pose relative to the cabin, the feed error is still reported; the sensor's keys go with it.
    pub fn switch_off(&mut self) {
        self.sensor = SensorKind::Off;
        (self.sample_rate_hz, self.delay_s, self.noise_m, self.noise_rad, self.bandwidth_hz, self.seed) =
            (None, 0.0, 0.0, 0.0, None, None);
        (self.imu, self.prediction_s, self.notch_hz, self.notch_q) = (None, None, None, None);
        self.filter_stages = None;
        (self.law, self.lqg) = (Law::Filter, None);
    }

    /// With `law = "lqg"`: the fixes come every this many readings of the inertial unit (the
    /// controller's period), and the design model.
    pub fn lqg_design(&self) -> Option<(usize, &LqgDesign)> {
        let (design, imu, period) = (self.lqg.as_ref()?, self.imu.as_ref()?, self.sample_period()?);
        (self.law == Law::Lqg).then(|| ((period * imu.rate_hz).round() as usize, design))
    }

    /// The feed's axis as given ([`DEFAULT_FEED_AXIS`] if not), platform frame.
    pub fn feed_axis(&self) -> [f64; 3] {
        self.feed_axis.unwrap_or(DEFAULT_FEED_AXIS)
    }

    /// The longest step the sampled sensor and its inertial unit allow (None without them): a
    /// sample or reading is taken at the first step start at or after its instant, so a step of
    /// at most a quarter of the shortest period keeps that jitter below a quarter period and
    /// every smooth step complete before the next command.
    pub fn step_bound(&self) -> Option<StepBound> {
        self.shortest_period().map(|(period, key)| StepBound { most: STEP_PER_PERIOD * period, period, key })
    }

    /// The shortest period a sampled sensor or its inertial unit samples at, s, and its key
    /// (what bounds a step: a step must not skip a sample).
    pub fn shortest_period(&self) -> Option<(f64, &'static str)> {
        let station = self.sample_period().map(|t| (t, "sample_rate_hz"));
        match (&self.imu, station) {
            (Some(imu), Some((t, _))) if 1.0 / imu.rate_hz < t => Some((1.0 / imu.rate_hz, "imu.rate_hz")),
            _ => station,
        }
    }

    /// Sample period of a sampled sensor, s.
    pub fn sample_period(&self) -> Option<f64> {
        match self.sensor {
            SensorKind::Sampled => self.sample_rate_hz.map(|f| 1.0 / f),
            _ => None,
        }
    }

    /// Checks the section and returns its target path.
    fn validate(&self, c: &Check) -> Result<ControlTarget, SceneError> {
        c.vector("control.feed_point_m", &self.feed_point_m)?;
        // a point on the platform (a metre across): a point kilometres away is a unit mistake,
        // and its squared error would overflow the RMS
        let reach = self.feed_point_m.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(reach <= FEED_POINT_REACH_M) {
            return Err(c.err(
                "control.feed_point_m",
                &format!("{:?}", self.feed_point_m),
                &format!("the feed point must lie within {FEED_POINT_REACH_M} m of the platform's centre (metres, platform frame)"),
            ));
        }
        if let Some(axis) = self.feed_axis {
            c.vector("control.feed_axis", &axis)?;
            let length = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(1e-9..=1e9).contains(&length) {
                return Err(c.err(
                    "control.feed_axis",
                    &format!("{axis:?}"),
                    "the feed's axis is a direction: give a unit vector, e.g. [0.0, 0.0, -1.0]",
                ));
            }
        }
        let unused = |key: &str, given: bool, what: &str| -> Result<(), SceneError> {
            if given {
                Err(c.err(&format!("control.{key}"), "", &format!("only used with {what}; remove it")))
            } else {
                Ok(())
            }
        };
        let circle = self.target == TargetKind::Circle;
        let samples = self.target == TargetKind::Samples;
        unused("circle_center_offset_m", !circle && self.circle_center_offset_m.is_some(), "target = \"circle\"")?;
        unused("circle_speed_m_s", !circle && self.circle_speed_m_s.is_some(), "target = \"circle\"")?;
        for (key, v) in [
            ("samples_time_s", &self.samples_time_s),
            ("samples_x_m", &self.samples_x_m),
            ("samples_y_m", &self.samples_y_m),
            ("samples_z_m", &self.samples_z_m),
        ] {
            unused(key, !samples && v.is_some(), "target = \"samples\"")?;
            if samples {
                let v =
                    v.as_ref().ok_or_else(|| c.err(&format!("control.{key}"), "", "target = \"samples\" needs it"))?;
                c.vector(&format!("control.{key}"), v)?;
            }
        }
        let mut target = ControlTarget::Hold;
        if circle {
            let offset = self.circle_center_offset_m.ok_or_else(|| {
                c.err("control.circle_center_offset_m", "", "target = \"circle\" needs the circle's centre")
            })?;
            c.vector("control.circle_center_offset_m", &offset)?;
            if offset[2] != 0.0 || offset[0].hypot(offset[1]) == 0.0 {
                return Err(c.err(
                    "control.circle_center_offset_m",
                    &format!("{offset:?}"),
                    "the circle is horizontal: give a non-zero horizontal offset with z = 0",
                ));
            }
            let speed = self
                .circle_speed_m_s
                .ok_or_else(|| c.err("control.circle_speed_m_s", "", "target = \"circle\" needs a speed"))?;
            c.finite_nonneg("control.circle_speed_m_s", speed)?;
            target = ControlTarget::Circle { center_offset: Vec3::from(offset), speed };
        }
        if let (true, Some(t), Some(x), Some(y), Some(z)) =
            (samples, &self.samples_time_s, &self.samples_x_m, &self.samples_y_m, &self.samples_z_m)
        {
            let n = t.len();
            if n == 0 {
                return Err(c.err("control.samples_time_s", "[]", "at least one sample is needed"));
            }
            if let Some(i) = (1..n).find(|&i| t[i] <= t[i - 1]) {
                return Err(c.err(&format!("control.samples_time_s[{i}]"), &show(t[i]), "times must ascend strictly"));
            }
            for (key, v) in [("samples_x_m", x), ("samples_y_m", y), ("samples_z_m", z)] {
                let len = v.len();
                if len != n {
                    return Err(c.err(
                        &format!("control.{key}"),
                        &format!("{len} values"),
                        &format!("needs one value per time of control.samples_time_s ({n})"),
                    ));
                }
            }
            let displacements = (0..n).map(|i| Vec3::new(x[i], y[i], z[i])).collect();
            target = ControlTarget::Samples { times: t.clone(), displacements };
        }
        let sampled = self.sensor == SensorKind::Sampled;
        let what = "sensor = \"sampled\"";
        unused("sample_rate_hz", !sampled && self.sample_rate_hz.is_some(), what)?;
        unused("delay_s", !sampled && self.delay_s != 0.0, what)?;
        unused("noise_m", !sampled && self.noise_m != 0.0, what)?;
        unused("noise_rad", !sampled && self.noise_rad != 0.0, what)?;
        unused("seed", !sampled && self.seed.is_some(), what)?;
        unused("bandwidth_hz", !sampled && self.bandwidth_hz.is_some(), what)?;
        unused("notch_hz", !sampled && self.notch_hz.is_some(), what)?;
        unused("filter_stages", !sampled && self.filter_stages.is_some(), what)?;
        if sampled {
            let rate = self
                .sample_rate_hz
                .ok_or_else(|| c.err("control.sample_rate_hz", "", "sensor = \"sampled\" needs a sample rate"))?;
            c.positive("control.sample_rate_hz", rate)?;
            c.within(
                "control.sample_rate_hz",
                rate,
                SENSOR_RATES_HZ,
                "a sensor's rate: one sample in 11.6 days to 1 MHz",
            )?;
            c.finite_nonneg("control.delay_s", self.delay_s)?;
            c.finite_nonneg("control.noise_m", self.noise_m)?;
            c.finite_nonneg("control.noise_rad", self.noise_rad)?;
            if let Some(b) = self.bandwidth_hz {
                c.positive("control.bandwidth_hz", b)?;
            }
            if let Some(n) = self.filter_stages {
                unused("filter_stages", self.bandwidth_hz.is_none(), "bandwidth_hz")?;
                if !FILTER_STAGES.contains(&n) {
                    return Err(c.err("control.filter_stages", &n.to_string(), "must be 2 or 3"));
                }
            }
            if let Some(q) = self.notch_q {
                unused("notch_q", self.notch_hz.is_none(), "notch_hz")?;
                c.positive("control.notch_q", q)?;
            }
            if let Some(f) = self.notch_hz {
                c.positive("control.notch_hz", f)?;
                // the commands come at the unit's readings with one, else at the samples
                let rate = self.imu.as_ref().map(|imu| imu.rate_hz).or(self.sample_rate_hz).unwrap_or(f64::INFINITY);
                if f >= 0.5 * rate {
                    return Err(c.err(
                        "control.notch_hz",
                        &show(f),
                        &format!("must lie below half the command rate ({} Hz)", 0.5 * rate),
                    ));
                }
            }
        }
        if let Some(imu) = &self.imu {
            if !sampled {
                return Err(c.err(
                    "control.imu",
                    "",
                    "the inertial unit drifts without the sampled sensor's fixes: use sensor = \"sampled\"",
                ));
            }
            imu.validate(c)?;
            if self.bandwidth_hz.is_none() {
                return Err(c.err(
                    "control.bandwidth_hz",
                    "",
                    "with [control.imu] a command comes at every reading: give the filter's bandwidth (a smooth step over half a reading pumps the cables' fast modes), e.g. 2.0",
                ));
            }
        }
        self.validate_law(c)?;
        if let Some(p) = self.prediction_s {
            unused("prediction_s", self.imu.is_none(), "[control.imu] (the estimate it extrapolates)")?;
            c.within("control.prediction_s", p, (0.0, PREDICTION_LIMIT_S), "a horizon of 0 to 10 s")?;
        }
        if self.stroke_m.is_some() && (self.min_leg_m.is_some() || self.max_leg_m.is_some()) {
            return Err(c.err("control.stroke_m", "", "give either `stroke_m` or `min_leg_m`/`max_leg_m`, not both"));
        }
        if let Some(s) = self.stroke_m {
            c.positive("control.stroke_m", s)?;
        }
        if let Some(x) = self.min_leg_m {
            c.positive("control.min_leg_m", x)?;
        }
        if let Some(x) = self.max_leg_m {
            c.positive("control.max_leg_m", x)?;
            if let Some(lo) = self.min_leg_m
                && x <= lo
            {
                return Err(c.err("control.max_leg_m", &show(x), &format!("must exceed control.min_leg_m = {lo}")));
            }
        }
        if let Some(f) = self.force_limit_n {
            c.positive("control.force_limit_n", f)?;
        }
        Ok(target)
    }
}

impl Control {
    /// `law = "lqg"`: its design model, the inertial unit it reads, the fixes at a whole number
    /// of the unit's periods; none of the filter's own keys.
    fn validate_law(&self, c: &Check) -> Result<(), SceneError> {
        let Some(design) = &self.lqg else {
            if self.law == Law::Lqg {
                return Err(c.err(
                    "control.lqg",
                    "",
                    "law = \"lqg\" needs its design model: `master design --scene F --out DIR` writes the scene with it",
                ));
            }
            return Ok(());
        };
        if self.law != Law::Lqg {
            return Err(c.err("control.lqg", "", "only used with law = \"lqg\"; remove it or set the law"));
        }
        let Some(imu) = &self.imu else {
            return Err(c.err(
                "control.imu",
                "",
                "law = \"lqg\" runs at the inertial unit's readings: give [control.imu] (and the sampled sensor's fixes)",
            ));
        };
        for (key, given) in [("notch_hz", self.notch_hz.is_some()), ("prediction_s", self.prediction_s.is_some())] {
            if given {
                return Err(c.err(
                    &format!("control.{key}"),
                    "",
                    "not used with law = \"lqg\" (the controller's model takes its place); remove it",
                ));
            }
        }
        let period = self.sample_period().unwrap_or(f64::NAN);
        let ratio = period * imu.rate_hz;
        if !((ratio - ratio.round()).abs() <= 1e-9 * ratio && ratio.round() >= 1.0) {
            return Err(c.err(
                "control.sample_rate_hz",
                &show(1.0 / period),
                &format!(
                    "with law = \"lqg\" a fix comes every whole number of the unit's readings (control.imu.rate_hz = {}): {ratio} is not whole",
                    imu.rate_hz
                ),
            ));
        }
        design.validate(c)
    }
}

/// One FMU of a co-simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FmuRef {
    /// Name used in connections and parameters (`name.variable`).
    pub name: String,
    /// The `.fmu` archive, relative to the scene file.
    pub path: String,
}

/// Every output of FMU `from`'s named prefix feeds the input of `to` with the same suffix:
/// `{ from = "cable.cabin", to = "stewart.cabin" }` connects `cabin.r[1]` to `cabin.r[1]`, ...
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Connection {
    pub from: String,
    pub to: String,
}

/// The co-simulated system: FMUs, connections, and parameters set on them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemDescription {
    pub fmus: Vec<FmuRef>,
    pub connections: Vec<Connection>,
    /// `"fmu.variable" = "value"`, converted to the variable's type; `"@scene"` stands for the
    /// absolute path of this scene file.
    #[serde(default)]
    pub parameters: std::collections::BTreeMap<String, String>,
}

/// A whole scene. Field names are the TOML keys.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Magnitude of gravity, acting along −Z of the world frame.
    pub gravity_m_s2: f64,
    /// Tower tops (fixed cable ends), world frame; cable i starts at anchor i.
    pub anchors: Ring,
    pub cables: Cables,
    pub cabin: Cabin,
    /// Target pose of the cabin centre point for the form-finding statics.
    pub pose: Pose,
    pub stewart: Stewart,
    pub motion: Motion,
    pub damping: Damping,
    pub solver: Solver,
    pub analyses: Analyses,
    pub outputs: Outputs,
    /// The co-simulation (optional: the monolithic model and the analyses do without).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub system: Option<SystemDescription>,
    /// A prescribed wrench on the cabin, for runs of the cable–cabin model alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disturbance: Option<Disturbance>,
    /// The platform compensates the cabin's motion (optional: absent, it follows `[motion]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub control: Option<Control>,
    /// A wind load on the cabin (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind: Option<Wind>,
}

/// Largest scene file read by default (the reference scenes have about 5 kB).
pub const MAX_SCENE_BYTES: u64 = 1 << 20;
/// Longest excerpt of the scene text quoted in an error, in characters.
const EXCERPT_CHARS: usize = 40;
/// Longest parser message quoted in an error, in characters (a message may quote a value).
const MESSAGE_CHARS: usize = 160;
/// Range of `solver.newton_tol` (a correction relative to the step's displacement scale). Below
/// 1e-14 Newton stalls on round-off (the residual of the cable net carries ~1e-16 relative
/// error times its condition); above 1e-6 the converged motion moves by more than the agreement
/// of the coupling schemes the tool compares (at C over 10 s: 1e-6 moves the peak by 3e-5 mm,
/// 1e-5 by 6e-4 mm, 1e-3 stops the run).
pub(crate) const NEWTON_TOL_RANGE: (f64, f64) = (1e-14, 1e-6);
/// Largest `solver.newton_max_iter`: Newton converges in 2–4 iterations here; a step that needs
/// hundreds will not converge, and a huge limit only delays the error.
pub(crate) const NEWTON_MAX_ITER: usize = 1000;

/// Tolerance on the norm of a unit quaternion or a unit axis given in a scene.
const UNIT_TOLERANCE: f64 = 1e-6;
/// Number of legs of a Stewart platform.
pub const LEGS: usize = 6;

impl Scene {
    /// Reads and validates a scene file of at most [`MAX_SCENE_BYTES`].
    pub fn load(path: impl AsRef<Path>) -> Result<ValidScene, SceneError> {
        Scene::load_limited(path, MAX_SCENE_BYTES)
    }

    /// Reads and validates a scene file of at most `max_bytes`. Only regular files are read (a
    /// FIFO would block, a device never end), and never more than `max_bytes + 1` bytes of them.
    pub fn load_limited(path: impl AsRef<Path>, max_bytes: u64) -> Result<ValidScene, SceneError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let unreadable = |reason: String| SceneError::unreadable(&file, SceneErrorKind::Unreadable, reason);
        let too_large = |size: Option<u64>| {
            SceneError::unreadable(
                &file,
                SceneErrorKind::TooLarge { limit: max_bytes },
                format!(
                    "the file has {} bytes, more than the limit of {max_bytes} bytes for a scene file",
                    ReadError::size_text(size, max_bytes)
                ),
            )
        };
        let bytes = read_limited(path, max_bytes).map_err(|e| match e {
            ReadError::Io(e) => unreadable(format!("cannot read the scene file: {e}")),
            ReadError::NotRegular => unreadable(
                "not a regular file (a directory, device or pipe); give the path of a scene file (TOML)".into(),
            ),
            ReadError::TooLarge { size, .. } => too_large(size),
        })?;
        let text = String::from_utf8(bytes).map_err(|e| {
            SceneError::unreadable(
                &file,
                SceneErrorKind::Syntax,
                format!(
                    "not UTF-8 text (invalid byte at offset {}); a scene is a TOML file",
                    e.utf8_error().valid_up_to()
                ),
            )
        })?;
        Scene::from_toml(&text, &file)
    }

    /// Parses and validates scene text; `file` names the source in error messages. Errors quote
    /// at most a short, escaped excerpt of the text, never a whole line.
    pub fn from_toml(text: &str, file: &str) -> Result<ValidScene, SceneError> {
        let syntax = |e: &toml::de::Error, key: String| SceneError {
            file: file.to_string(),
            key,
            value: String::new(),
            reason: describe_toml_error(text, e),
            kind: SceneErrorKind::Syntax,
        };
        let de = toml::Deserializer::parse(text).map_err(|e| syntax(&e, String::new()))?;
        let scene: Scene = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e.path().to_string();
            syntax(e.inner(), if key == "." { String::new() } else { key })
        })?;
        scene.validated(file)
    }

    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scene always serializes")
    }

    /// Rejects non-physical values (`file` names the source in error messages); returns what
    /// the check established: the target orientation and the compensation's target.
    fn check(&self, file: &str) -> Result<Checked, SceneError> {
        let c = Check { file };
        c.finite_nonneg("gravity_m_s2", self.gravity_m_s2)?;

        c.ring("anchors", &self.anchors, None)?;
        let n = self.anchors.angle_deg.len();
        if n == 0 {
            return Err(c.err("anchors.angle_deg", "[]", "at least one cable is needed"));
        }
        c.positive("cables.area_m2", self.cables.area_m2)?;
        c.positive("cables.density_kg_m3", self.cables.density_kg_m3)?;
        c.positive("cables.youngs_modulus_pa", self.cables.youngs_modulus_pa)?;
        if let Some(b) = self.cables.breaking_load_n {
            c.positive("cables.breaking_load_n", b)?;
        }
        if self.cables.elements < 1 {
            return Err(c.err(
                "cables.elements",
                &self.cables.elements.to_string(),
                "a cable needs at least one element",
            ));
        }

        c.positive("cabin.mass_kg", self.cabin.mass_kg)?;
        c.position("cabin.center_of_mass_m", &self.cabin.center_of_mass_m)?;
        c.inertia("cabin.inertia_kg_m2", &self.cabin.inertia_kg_m2)?;
        c.ring("cabin.attachments", &self.cabin.attachments, Some(n))?;

        c.position("pose.position_m", &self.pose.position_m)?;
        let orientation = self.pose_orientation_checked(&c)?;
        let (p, r) = (self.target_position(), orientation);
        for (i, (a, b)) in self.anchors().iter().zip(self.attachments_body()).enumerate() {
            let attach = p + r * b;
            if (a - attach).norm() < 1e-6 {
                return Err(c.err(
                    &format!("anchors.angle_deg[{i}]"),
                    &show(self.anchors.angle_deg[i]),
                    &format!(
                        "anchor {} coincides with its attachment point at the target pose {:?}",
                        i + 1,
                        attach.as_slice()
                    ),
                ));
            }
        }

        let s = &self.stewart;
        c.ring("stewart.base_joints", &s.base_joints, Some(LEGS))?;
        c.ring("stewart.platform_joints", &s.platform_joints, Some(LEGS))?;
        c.positive("stewart.platform.mass_kg", s.platform.mass_kg)?;
        c.inertia("stewart.platform.inertia_kg_m2", &s.platform.inertia_kg_m2)?;
        c.position("stewart.platform.nominal_center_m", &s.platform.nominal_center_m)?;
        for (name, part) in [("stewart.upper_leg", &s.upper_leg), ("stewart.lower_leg", &s.lower_leg)] {
            c.positive(&format!("{name}.mass_kg"), part.mass_kg)?;
            c.positive(&format!("{name}.length_m"), part.length_m)?;
            c.finite_nonneg(&format!("{name}.com_from_joint_m"), part.com_from_joint_m)?;
            if part.com_from_joint_m > part.length_m {
                return Err(c.err(
                    &format!("{name}.com_from_joint_m"),
                    &show(part.com_from_joint_m),
                    &format!(
                        "the centre of mass lies beyond the end of the part ({name}.length_m = {})",
                        part.length_m
                    ),
                ));
            }
            c.positive(&format!("{name}.inertia_transverse_kg_m2"), part.inertia_transverse_kg_m2)?;
            c.positive(&format!("{name}.inertia_axial_kg_m2"), part.inertia_axial_kg_m2)?;
        }

        c.finite_nonneg("motion.radius_m", self.motion.radius_m)?;
        c.finite_nonneg("motion.speed_m_s", self.motion.speed_m_s)?;
        if self.motion.start == Start::Ramp {
            c.positive("motion.ramp_time_s", self.motion.ramp_time_s)?;
        } else {
            c.finite_nonneg("motion.ramp_time_s", self.motion.ramp_time_s)?;
        }

        c.finite_nonneg("damping.ratio", self.damping.ratio)?;
        if self.damping.ratio >= 1.0 {
            return Err(c.err("damping.ratio", &show(self.damping.ratio), "a damping ratio must be below 1"));
        }
        let damping_fit = match (self.damping.fit_modes, self.damping.fit_frequencies_hz) {
            (Some(m), None) => {
                if m[0] < 1 || m[1] <= m[0] {
                    return Err(c.err(
                        "damping.fit_modes",
                        &format!("{m:?}"),
                        "two ascending 1-based mode numbers are needed, e.g. [1, 6]",
                    ));
                }
                DampingFit::Modes(m)
            }
            (None, Some(f)) => {
                c.positive("damping.fit_frequencies_hz[0]", f[0])?;
                c.positive("damping.fit_frequencies_hz[1]", f[1])?;
                if f[1] <= f[0] {
                    return Err(c.err(
                        "damping.fit_frequencies_hz",
                        &format!("{f:?}"),
                        "two ascending frequencies are needed",
                    ));
                }
                DampingFit::Frequencies(f)
            }
            _ => return Err(c.err("damping", "", "give exactly one of `fit_modes` and `fit_frequencies_hz`")),
        };

        c.positive("solver.dt_s", self.solver.dt_s)?;
        c.positive("solver.t_end_s", self.solver.t_end_s)?;
        if !(0.0..=1.0).contains(&self.solver.rho_inf) {
            return Err(c.err("solver.rho_inf", &show(self.solver.rho_inf), "must lie in [0, 1]"));
        }
        c.positive("solver.newton_tol", self.solver.newton_tol)?;
        let (lo, hi) = NEWTON_TOL_RANGE;
        if !(lo..=hi).contains(&self.solver.newton_tol) {
            return Err(c.err(
                "solver.newton_tol",
                &show(self.solver.newton_tol),
                &format!(
                    "must lie in [{lo:e}, {hi:e}]: below, Newton stalls on round-off; above, the result drifts by \
                     more than the coupling schemes differ (1e-10 is the reference scenes' value)"
                ),
            ));
        }
        if !(1..=NEWTON_MAX_ITER).contains(&self.solver.newton_max_iter) {
            return Err(c.err(
                "solver.newton_max_iter",
                &self.solver.newton_max_iter.to_string(),
                &format!("must lie in [1, {NEWTON_MAX_ITER}] (Newton converges in 2–4 iterations here)"),
            ));
        }
        c.positive("outputs.sample_interval_s", self.outputs.sample_interval_s)?;
        for q in &self.outputs.quantities {
            let unwritten = match q {
                Quantity::CableTensions | Quantity::PlatformPose => Some("no command writes its time history"),
                Quantity::ActuatorForces if self.control.is_none() => {
                    Some("written with the feed's columns, in scenes with [control] only")
                }
                _ => None,
            };
            if let Some(why) = unwritten {
                return Err(c.err(
                    "outputs.quantities",
                    &format!("\"{}\"", q.name()),
                    &format!(
                        "{why}; written: cabin_displacement, cabin_rotation, wrench (and with [control] actuator_forces); \
                         remove it"
                    ),
                ));
            }
        }
        if let Some(d) = &self.disturbance {
            c.vector("disturbance.force_amplitude_n", &d.force_amplitude_n)?;
            c.vector("disturbance.moment_amplitude_nm", &d.moment_amplitude_nm)?;
            c.finite_nonneg("disturbance.frequency_hz", d.frequency_hz)?;
        }
        let target = self.control.as_ref().map(|control| control.validate(&c)).transpose()?;
        if let Some(bound) = self.control.as_ref().and_then(Control::step_bound)
            && !bound.admits(self.solver.dt_s)
        {
            return Err(c.err("solver.dt_s", &show(self.solver.dt_s), &bound.refusal(self.solver.dt_s)));
        }
        if let Some(w) = &self.wind {
            c.finite_nonneg("wind.mean_speed_m_s", w.mean_speed_m_s)?;
            c.finite("wind.direction_deg", w.direction_deg)?;
            c.finite_nonneg("wind.turbulence_intensity", w.turbulence_intensity)?;
            if w.turbulence_intensity >= 1.0 {
                return Err(c.err(
                    "wind.turbulence_intensity",
                    &show(w.turbulence_intensity),
                    "must be below 1 (a fraction: 0.15 is 15 %)",
                ));
            }
            c.positive("wind.reference_height_m", w.reference_height_m)?;
            c.positive("wind.drag_area_m2", w.drag_area_m2)?;
            c.positive("wind.air_density_kg_m3", w.air_density_kg_m3)?;
            c.vector("wind.band_hz", &w.band_hz)?;
            if !(w.band_hz[0] >= 0.0 && w.band_hz[0] < w.band_hz[1]) {
                return Err(c.err(
                    "wind.band_hz",
                    &format!("{:?}", w.band_hz),
                    "must be [lowest, highest] with 0 ≤ lowest < highest (Hz)",
                ));
            }
            if !(1..=MAX_WIND_HARMONICS).contains(&w.harmonics) {
                return Err(c.err(
                    "wind.harmonics",
                    &w.harmonics.to_string(),
                    &format!("must lie in [1, {MAX_WIND_HARMONICS}]"),
                ));
            }
            c.finite_nonneg("wind.ramp_s", w.ramp_s)?;
        }
        if let Some(sys) = &self.system {
            let names: Vec<&str> = sys.fmus.iter().map(|f| f.name.as_str()).collect();
            for (i, f) in sys.fmus.iter().enumerate() {
                if f.name.is_empty() || f.name.contains('.') || names[..i].contains(&f.name.as_str()) {
                    return Err(c.err(
                        &format!("system.fmus[{i}].name"),
                        &f.name,
                        "FMU names must be unique, non-empty and without dots",
                    ));
                }
                if f.path.is_empty() {
                    return Err(c.err(
                        &format!("system.fmus[{i}].path"),
                        "\"\"",
                        "the path of the .fmu archive is missing",
                    ));
                }
            }
            let known = |key: &str, text: &str| -> Result<(), SceneError> {
                match text.split_once('.') {
                    Some((fmu, rest)) if names.contains(&fmu) && !rest.is_empty() => Ok(()),
                    _ => Err(c.err(key, text, &format!("must be `fmu.name` with fmu one of system.fmus {names:?}"))),
                }
            };
            for (i, k) in sys.connections.iter().enumerate() {
                known(&format!("system.connections[{i}].from"), &k.from)?;
                known(&format!("system.connections[{i}].to"), &k.to)?;
            }
            for key in sys.parameters.keys() {
                known(&format!("system.parameters.{key}"), key)?;
            }
        }
        Ok(Checked { orientation, target, damping_fit })
    }

    fn pose_orientation_checked(&self, c: &Check) -> Result<Quat, SceneError> {
        match (&self.pose.orientation_wxyz, &self.pose.rotation_axis, &self.pose.rotation_angle_deg) {
            (Some(q), None, None) => {
                c.vector("pose.orientation_wxyz", q)?;
                let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (norm - 1.0).abs() > UNIT_TOLERANCE {
                    return Err(c.err(
                        "pose.orientation_wxyz",
                        &format!("{q:?}"),
                        &format!("not a unit quaternion (norm {norm})"),
                    ));
                }
                Ok(Quat::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3])))
            }
            (None, Some(axis), Some(angle)) => {
                c.vector("pose.rotation_axis", axis)?;
                if !angle.is_finite() {
                    return Err(c.err("pose.rotation_angle_deg", &show(*angle), "must be finite"));
                }
                let a = Vec3::from(*axis);
                let norm = a.norm();
                if (norm - 1.0).abs() > UNIT_TOLERANCE {
                    return Err(c.err(
                        "pose.rotation_axis",
                        &format!("{axis:?}"),
                        &format!("not a unit axis (norm {norm})"),
                    ));
                }
                Ok(Quat::from_axis_angle(&nalgebra::Unit::new_normalize(a), angle.to_radians()))
            }
            _ => Err(c.err(
                "pose",
                "",
                "give the orientation either as `orientation_wxyz` or as `rotation_axis` with `rotation_angle_deg`",
            )),
        }
    }

    // --- Derived geometry -------------------------------------------------------------------

    pub fn gravity(&self) -> Vec3 {
        Vec3::new(0.0, 0.0, -self.gravity_m_s2)
    }

    pub fn cable_count(&self) -> usize {
        self.anchors.angle_deg.len()
    }

    /// Cable anchors (tower tops), world frame.
    pub fn anchors(&self) -> Vec<Vec3> {
        self.anchors.points()
    }

    /// Cable attachment points, cabin body frame.
    pub fn attachments_body(&self) -> Vec<Vec3> {
        self.cabin.attachments.points()
    }

    pub fn target_position(&self) -> Vec3 {
        Vec3::from(self.pose.position_m)
    }

    /// Mass properties of the cabin alone, body frame.
    pub fn cabin_mass_properties(&self) -> MassProperties {
        MassProperties {
            mass: self.cabin.mass_kg,
            com: Vec3::from(self.cabin.center_of_mass_m),
            inertia_com: Mat3::from_row_slice(self.cabin.inertia_kg_m2.as_flattened()),
        }
    }
}

/// What validation established about a scene, kept by [`ValidScene`].
struct Checked {
    orientation: Quat,
    target: Option<ControlTarget>,
    damping_fit: DampingFit,
}

/// Validation helpers that know the file name.
struct Check<'a> {
    file: &'a str,
}

impl Check<'_> {
    fn err(&self, key: &str, value: &str, reason: &str) -> SceneError {
        SceneError {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.to_string(),
            kind: SceneErrorKind::Invalid,
        }
    }

    fn finite(&self, key: &str, x: f64) -> Result<(), SceneError> {
        if x.is_finite() { Ok(()) } else { Err(self.err(key, &show(x), "must be a finite number")) }
    }

    fn positive(&self, key: &str, x: f64) -> Result<(), SceneError> {
        self.finite(key, x)?;
        if x > 0.0 { Ok(()) } else { Err(self.err(key, &show(x), "must be positive")) }
    }

    fn finite_nonneg(&self, key: &str, x: f64) -> Result<(), SceneError> {
        self.finite(key, x)?;
        if x >= 0.0 { Ok(()) } else { Err(self.err(key, &show(x), "must not be negative")) }
    }

    fn vector(&self, key: &str, v: &[f64]) -> Result<(), SceneError> {
        for (i, x) in v.iter().enumerate() {
            self.finite(&format!("{key}[{i}]"), *x)?;
        }
        Ok(())
    }

    /// `x` within `range`, else an error saying what the range is (`what`).
    fn within(&self, key: &str, x: f64, range: (f64, f64), what: &str) -> Result<(), SceneError> {
        self.finite(key, x)?;
        if (range.0..=range.1).contains(&x) {
            Ok(())
        } else {
            Err(self.err(key, &show(x), &format!("must lie in [{:e}, {:e}] ({what})", range.0, range.1)))
        }
    }

    /// A position, m: finite and within [`FAR_M`] of the origin.
    fn position(&self, key: &str, v: &[f64]) -> Result<(), SceneError> {
        for (i, x) in v.iter().enumerate() {
            self.within(&format!("{key}[{i}]"), *x, (-FAR_M, FAR_M), "positions within 1000 km")?;
        }
        Ok(())
    }

    fn ring(&self, key: &str, ring: &Ring, count: Option<usize>) -> Result<(), SceneError> {
        self.positive(&format!("{key}.radius_m"), ring.radius_m)?;
        self.within(&format!("{key}.radius_m"), ring.radius_m, (0.0, FAR_M), "positions within 1000 km")?;
        self.within(&format!("{key}.z_m"), ring.z_m, (-FAR_M, FAR_M), "positions within 1000 km")?;
        for (i, a) in ring.angle_deg.iter().enumerate() {
            self.within(&format!("{key}.angle_deg[{i}]"), *a, (-360.0, 360.0), "an angle within one turn")?;
        }
        if let Some(n) = count
            && ring.angle_deg.len() != n
        {
            return Err(self.err(
                &format!("{key}.angle_deg"),
                &format!("{:?}", ring.angle_deg),
                &format!(
                    "{n} points are needed, one per {}",
                    if n == LEGS && key.starts_with("stewart") { "leg" } else { "cable" }
                ),
            ));
        }
        Ok(())
    }

    /// A physical inertia tensor: finite, symmetric, positive definite, triangle inequality.
    fn inertia(&self, key: &str, rows: &[[f64; 3]; 3]) -> Result<(), SceneError> {
        self.vector(key, rows.as_flattened())?;
        let m = Mat3::from_row_slice(rows.as_flattened());
        let shown = format!("{rows:?}");
        if (m - m.transpose()).abs().max() > 1e-9 * m.abs().max() {
            return Err(self.err(key, &shown, "an inertia tensor must be symmetric"));
        }
        let eig = m.symmetric_eigenvalues();
        if eig.iter().any(|&l| l <= 0.0) {
            return Err(self.err(
                key,
                &shown,
                "an inertia tensor must be positive definite (no zero or negative principal moment)",
            ));
        }
        let (a, b, c) = (eig[0], eig[1], eig[2]);
        let tol = 1e-12 * (a + b + c);
        if a + b < c - tol || b + c < a - tol || a + c < b - tol {
            return Err(self.err(
                key,
                &shown,
                "principal moments violate the triangle inequality (no real body has them)",
            ));
        }
        Ok(())
    }
}

/// A number as a message shows it: short, in exponent form when very large or small (1e300,
/// not three hundred digits).
fn show(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-5..1e9).contains(&x.abs()) { format!("{x:e}") } else { x.to_string() }
}

/// `text` cut to at most `max` characters and escaped (control characters, quotes), with an
/// ellipsis when cut: safe to print whatever the file holds.
fn excerpt(text: &str, max: usize) -> String {
    let mut out: String = text.chars().take(max).collect::<String>().escape_debug().collect();
    if text.chars().nth(max).is_some() {
        out.push('…');
    }
    out
}

/// A parser error as `line L, column C: message (at `excerpt`)`.
fn describe_toml_error(text: &str, e: &toml::de::Error) -> String {
    let message = excerpt(e.message().trim_end(), MESSAGE_CHARS);
    let Some(span) = e.span() else { return format!("not a valid scene: {message}") };
    let start = span.start.min(text.len());
    let start = (0..=start).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[..start].matches('\n').count() + 1;
    let column = text[line_start..start].chars().count() + 1;
    // from a little before the error to the end of its line, at most EXCERPT_CHARS characters
    let before = text[line_start..start]
        .char_indices()
        .rev()
        .nth(EXCERPT_CHARS / 2 - 1)
        .map_or(line_start, |(i, _)| line_start + i);
    let rest = &text[before..];
    let rest = &rest[..rest.find('\n').unwrap_or(rest.len())];
    format!("not a valid scene: line {line}, column {column}: {message} (at `{}`)", excerpt(rest, EXCERPT_CHARS))
}

/// Fixed-size arrays that refuse any other length (serde's own arrays ignore extra values).
mod exact {
    use serde::de::{Deserialize, Deserializer, Error};

    struct Expected(usize);

    impl serde::de::Expected for Expected {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "exactly {} values", self.0)
        }
    }

    pub(super) fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        let v: Vec<T> = Vec::deserialize(d)?;
        let len = v.len();
        v.try_into().map_err(|_| D::Error::invalid_length(len, &Expected(N)))
    }

    pub(super) fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        array(d).map(Some)
    }

    pub(super) fn matrix<'de, D: Deserializer<'de>>(d: D) -> Result<[[f64; 3]; 3], D::Error> {
        let rows: Vec<Vec<f64>> = Vec::deserialize(d)?;
        if rows.len() != 3 {
            return Err(D::Error::invalid_length(rows.len(), &"exactly 3 rows of 3 values"));
        }
        let mut m = [[0.0; 3]; 3];
        for (i, row) in rows.iter().enumerate() {
            if row.len() != 3 {
                return Err(D::Error::custom(format_args!(
                    "row {} has {} values, expected exactly 3",
                    i + 1,
                    row.len()
                )));
            }
            m[i].copy_from_slice(row);
        }
        Ok(m)
    }
}
