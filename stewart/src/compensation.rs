//! The second level: the platform puts a feed point on a target in the world frame, from the
//! measured cabin pose (scene `[control]`).
//!
//! The platform's pose relative to the cabin (centre `c`, orientation `Q`, cabin frame) is
//! commanded so that the feed `p + R (c + Q f)` lies on the target `x(t)` and the platform keeps
//! its start attitude `R₀` in the world (`compensate = "pose"`, the default):
//!
//! ```text
//! Q = Rᵀ R₀,   c = Rᵀ (x(t) − p − R₀ f)
//! ```
//!
//! (`p, R` the measured cabin pose, `f` the feed point in the platform frame), so the feed's axis
//! stays on its start direction. With `compensate = "position"` the platform only translates
//! (`Q = I`, `c = Rᵀ (x − p) − f`) and the feed tilts with the cabin. The tilt reported is the
//! angle of the feed axis (scene `feed_axis`) from its start direction.
//!
//! A sampled command is a pose: the centre and the orientation's angles (z-y-x: `Q = R_z(ψ)
//! R_y(θ) R_x(φ)`), filtered component by component; the platform's angular velocity and
//! acceleration follow exactly from the angles' derivatives.
//!
//! Sensors: `ideal` (the true pose, continuously: `c` and its first two derivatives follow from
//! the cabin's motion, exactly), `off` (the platform holds its start pose: the uncompensated
//! reference) and `sampled`: at the first communication point at or after each instant k·T the
//! cabin pose is measured (uniform noise, seeded), the command computed for the target at the
//! time it will apply, and applied `delay` later. With an inertial unit (`[control.imu]`) the
//! measured poses are fixes that reach a Kalman filter `delay` after they are taken
//! ([`crate::fusion`]); at each of the unit's readings the command is made from the filter's
//! estimate, extrapolated `prediction_s` ahead, and applied at once. A new command is reached smoothly, with
//! continuous position and velocity (the bodies' accelerations, hence forces, stay finite):
//! with `bandwidth_hz`, through two (or `filter_stages`) first-order stages of that bandwidth (critically damped);
//! without, along a quintic smooth step over half a sample period. Between samples the relative
//! motion is thus a known function of time: it depends on the cabin inputs of earlier steps only
//! (kept in [`CommandState`], part of the FMU state), not on those of the step being taken.

use std::collections::VecDeque;

use feedcore::random::SplitMix64;
use feedcore::scene::{Compensate, Control, ControlTarget, LEGS, STEP_PER_PERIOD, SensorKind, TargetKind, ValidScene};
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Rotation3, Vector6};
use serde::{Deserialize, Serialize};

use crate::fusion::{Estimate, Fix, Fusion, FusionState};
use crate::imu::{Imu, ImuState};
use crate::lqg::{LqgLaw, LqgState};
use crate::path::PathPoint;
use crate::wrench::CabinMotion;

/// Two instants closer than this are the same instant, s (communication points are sums of steps).
const SAME_INSTANT: f64 = 1e-9;

/// The target of the feed point, world frame.
#[derive(Clone, Debug, PartialEq)]
enum Target {
    Hold,
    /// Centre, radius, start angle, angular speed.
    Circle {
        center: Vec3,
        radius: f64,
        phase: f64,
        omega: f64,
    },
    /// Times and displacements from the start position.
    Samples {
        times: Vec<f64>,
        displacements: Vec<Vec3>,
    },
}

/// Position, velocity and acceleration of the target, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetPoint {
    pub position: Vec3,
    pub velocity: Vec3,
    pub acceleration: Vec3,
}

/// A platform pose relative to the cabin as the sampled sensor commands it: the centre (cabin
/// frame, m) and the z-y-x angles (φ, θ, ψ) of its orientation, rad.
type Pose = Vector6<f64>;

/// The compensation of one scene (immutable).
#[derive(Clone, Debug, PartialEq)]
pub struct Compensation {
    /// Feed point, platform frame.
    feed_point: Vec3,
    /// The feed's axis, platform frame (unit).
    feed_axis: Vec3,
    /// Whether the platform's attitude is commanded too (else it only translates).
    holds_attitude: bool,
    /// The platform centre at rest, cabin frame.
    rest: Vec3,
    /// The cabin's reference (static) pose: the platform's start attitude and the feed's start.
    reference: (Vec3, Quat),
    feed_start: Vec3,
    target: Target,
    sensor: SensorKind,
    period: f64,
    delay: f64,
    noise_m: f64,
    noise_rad: f64,
    seed: u64,
    /// Time constant of each filter stage, s; `None`: the smooth step.
    tau: Option<f64>,
    /// Three stages (the acceleration continuous) instead of two.
    third_stage: bool,
    /// The inertial unit and the filter that fuses it with the fixes (`[control.imu]`).
    fused: Option<(Imu, Fusion)>,
    /// How far ahead of the estimate a fused command is made, s.
    prediction: f64,
    /// The LQG law (`law = "lqg"`): its commands come from its controller at the unit's readings.
    lqg: Option<LqgLaw>,
    /// Time between commands: the unit's period when fused, else the sensor's.
    command_period: f64,
    /// A notch on the commands (`notch_hz`).
    notch: Option<Notch>,
    leg_limits: Option<[(f64, f64); LEGS]>,
    force_limit: Option<f64>,
}

impl Compensation {
    /// The compensation of the scene's `[control]` (without one: [`Compensation::uncontrolled`])
    /// for the platform resting at `rest` (cabin frame), with `rest_legs` the leg lengths there;
    /// the reference pose is the scene's target pose. Fails where the scene's LQG controller
    /// cannot be made (its Riccati equations have no stabilizing solution).
    pub fn new(scene: &ValidScene, rest: Vec3, rest_legs: [f64; LEGS]) -> Result<Compensation, String> {
        let uncontrolled = Compensation::uncontrolled();
        let control = scene.control.as_ref().unwrap_or(&uncontrolled);
        let reference = (scene.target_position(), scene.target_orientation());
        let feed_point = Vec3::from(control.feed_point_m);
        let feed_axis = Vec3::from(control.feed_axis()).normalize();
        let feed_start = reference.0 + reference.1 * (rest + feed_point);
        let target = match scene.control_target() {
            None | Some(ControlTarget::Hold) => Target::Hold,
            Some(&ControlTarget::Circle { center_offset, speed }) => {
                let radius = center_offset.norm();
                Target::Circle {
                    center: feed_start + center_offset,
                    radius,
                    phase: (-center_offset.y).atan2(-center_offset.x),
                    omega: speed / radius,
                }
            }
            Some(ControlTarget::Samples { times, displacements }) => {
                Target::Samples { times: times.clone(), displacements: displacements.clone() }
            }
        };
        let period = control.sample_period().unwrap_or(f64::INFINITY);
        let lqg = LqgLaw::of_scene(scene)?;
        let fused = control.imu.as_ref().zip(control.fusion_model()).filter(|_| lqg.is_none()).map(|(spec, model)| {
            let imu = Imu::new(spec, scene.gravity());
            let fusion = Fusion::new(&model, scene.gravity(), control.delay_s, reference);
            (imu, fusion)
        });
        let command_period = match (&fused, &lqg) {
            (Some((imu, _)), _) => imu.period,
            (None, Some(law)) => law.imu.period,
            (None, None) => period,
        };
        let leg_limits = match (control.stroke_m, control.min_leg_m, control.max_leg_m) {
            (Some(s), _, _) => Some(rest_legs.map(|l| (l - s, l + s))),
            (None, None, None) => None,
            (None, lo, hi) => Some([(lo.unwrap_or(0.0), hi.unwrap_or(f64::INFINITY)); LEGS]),
        };
        Ok(Compensation {
            feed_point,
            feed_axis,
            holds_attitude: control.compensate == Compensate::Pose,
            rest,
            reference,
            feed_start,
            target,
            sensor: control.sensor,
            period,
            delay: control.delay_s,
            noise_m: control.noise_m,
            noise_rad: control.noise_rad,
            seed: control.seed.unwrap_or(0),
            tau: control.bandwidth_hz.map(|b| 1.0 / (std::f64::consts::TAU * b)),
            third_stage: control.filter_stages == Some(3),
            fused,
            prediction: control.prediction_s.unwrap_or(0.0),
            lqg,
            command_period,
            notch: control.notch_hz.map(|f| Notch::new(f, control.notch_q.unwrap_or(2.0), 1.0 / command_period)),
            leg_limits,
            force_limit: control.force_limit_n,
        })
    }

    /// What a scene without `[control]` reports: no compensation, the feed point at the platform
    /// centre, held at its start position.
    pub(crate) fn uncontrolled() -> Control {
        Control {
            feed_point_m: [0.0; 3],
            feed_axis: None,
            compensate: Compensate::Pose,
            target: TargetKind::Hold,
            circle_center_offset_m: None,
            circle_speed_m_s: None,
            samples_time_s: None,
            samples_x_m: None,
            samples_y_m: None,
            samples_z_m: None,
            sensor: SensorKind::Off,
            sample_rate_hz: None,
            delay_s: 0.0,
            noise_m: 0.0,
            noise_rad: 0.0,
            seed: None,
            bandwidth_hz: None,
            min_leg_m: None,
            max_leg_m: None,
            stroke_m: None,
            force_limit_n: None,
            prediction_s: None,
            imu: None,
            notch_hz: None,
            notch_q: None,
            filter_stages: None,
            law: feedcore::scene::Law::Filter,
            lqg: None,
        }
    }

    pub fn sensor(&self) -> SensorKind {
        self.sensor
    }

    /// The shortest period of a sampled sensor or its inertial unit (infinite without), s, and
    /// its scene key.
    pub fn step_period(&self) -> (f64, &'static str) {
        if self.command_period < self.period {
            (self.command_period, "imu.rate_hz")
        } else {
            (self.period, "sample_rate_hz")
        }
    }

    /// Largest macro step a sampled sensor allows (the scene's rule, [`Control::step_bound`]).
    pub fn max_step(&self) -> f64 {
        STEP_PER_PERIOD * self.step_period().0
    }

    /// The inertial unit and its filter, with `[control.imu]` (and the filter's law).
    pub fn fused(&self) -> Option<&(Imu, Fusion)> {
        self.fused.as_ref()
    }

    /// The LQG law, with `law = "lqg"`.
    pub fn lqg(&self) -> Option<&LqgLaw> {
        self.lqg.as_ref()
    }

    /// Whether the commands come from an estimate of the cabin's pose (the fusion's or the LQG
    /// controller's), which [`CommandState::estimate`] gives.
    pub fn estimates(&self) -> bool {
        self.fused.is_some() || self.lqg.is_some()
    }

    /// Leg length limits (shortest, longest) per leg, m.
    pub fn leg_limits(&self) -> Option<[(f64, f64); LEGS]> {
        self.leg_limits
    }

    pub fn force_limit(&self) -> Option<f64> {
        self.force_limit
    }

    /// The cabin's reference (static) pose: position, orientation (world).
    pub fn reference(&self) -> (Vec3, Quat) {
        self.reference
    }

    /// The feed's start position, world frame.
    pub fn feed_start(&self) -> Vec3 {
        self.feed_start
    }

    /// The feed point in the platform frame, m.
    pub fn feed_point(&self) -> Vec3 {
        self.feed_point
    }

    /// The target at time `t` (before t = 0: at its start).
    pub fn target(&self, t: f64) -> TargetPoint {
        let still = |p: Vec3| TargetPoint { position: p, velocity: Vec3::zeros(), acceleration: Vec3::zeros() };
        match &self.target {
            Target::Hold => still(self.feed_start),
            Target::Circle { center, radius, phase, omega } => {
                let w = if t > 0.0 { *omega } else { 0.0 };
                let (s, c) = (phase + w * t.max(0.0)).sin_cos();
                let (radial, tangent) = (Vec3::new(c, s, 0.0), Vec3::new(-s, c, 0.0));
                TargetPoint {
                    position: center + radial * *radius,
                    velocity: tangent * (radius * w),
                    acceleration: -radial * (radius * w * w),
                }
            }
            Target::Samples { times, displacements } => {
                let n = times.len();
                let j = times.partition_point(|&s| s <= t);
                if j == 0 || j == n {
                    return still(self.feed_start + displacements[if j == 0 { 0 } else { n - 1 }]);
                }
                let (t0, t1) = (times[j - 1], times[j]);
                let slope = (displacements[j] - displacements[j - 1]) / (t1 - t0);
                TargetPoint {
                    position: self.feed_start + displacements[j - 1] + slope * (t - t0),
                    velocity: slope,
                    acceleration: Vec3::zeros(),
                }
            }
        }
    }

    /// The feed point's offset from the platform centre that the command's position accounts
    /// for: in the world at the start attitude when the attitude is held, else in the platform
    /// (= cabin) frame.
    fn held_offset(&self) -> Vec3 {
        if self.holds_attitude { self.reference.1 * self.feed_point } else { Vec3::zeros() }
    }

    /// The pose that puts the feed on the target at time `t` for a cabin at (p, R).
    fn command(&self, position: &Vec3, orientation: &Quat, t: f64) -> Pose {
        let centre = orientation.inverse_transform_vector(&(self.target(t).position - position - self.held_offset()));
        if self.holds_attitude {
            let angles = zyx_angles(&(orientation.inverse() * self.reference.1).to_rotation_matrix().into_inner());
            Pose::new(centre.x, centre.y, centre.z, angles.x, angles.y, angles.z)
        } else {
            let c = centre - self.feed_point;
            Pose::new(c.x, c.y, c.z, 0.0, 0.0, 0.0)
        }
    }

    /// [`Compensation::command`]'s first order about the reference pose, as a deviation from
    /// the rest pose (what the LQG law's linear model holds).
    fn linear_command(&self, position: &Vec3, orientation: &Quat) -> Pose {
        let (p0, r0) = self.reference;
        let (dp, dtheta) = (position - p0, (orientation * r0.inverse()).scaled_axis());
        // the platform turns back the cabin's turn; its centre keeps the feed point in place
        let dphi = -r0.inverse_transform_vector(&dtheta);
        let arm = r0 * (self.rest + self.feed_point);
        let dc = r0.inverse_transform_vector(&(-dp - dtheta.cross(&arm))) + self.feed_point.cross(&dphi);
        Pose::new(dc.x, dc.y, dc.z, dphi.x, dphi.y, dphi.z)
    }

    /// The ideal sensor's command: the platform's pose relative to the cabin with its
    /// derivatives, for the true cabin motion.
    pub fn ideal(&self, cabin: &CabinMotion, t: f64) -> PathPoint {
        let x = self.target(t);
        let r = &cabin.orientation;
        let (d, dd, ddd) = (
            x.position - cabin.position - self.held_offset(),
            x.velocity - cabin.velocity,
            x.acceleration - cabin.acceleration,
        );
        let (w, al) = (
            r.inverse_transform_vector(&cabin.angular_velocity),
            r.inverse_transform_vector(&cabin.angular_acceleration),
        );
        let e = r.inverse_transform_vector(&d);
        let de = r.inverse_transform_vector(&dd);
        // e = Rᵀd: ė = Rᵀḋ − ω×e, ë = Rᵀd̈ − 2ω×Rᵀḋ − α×e + ω×(ω×e) (body-frame ω, α)
        let velocity = de - w.cross(&e);
        let acceleration = r.inverse_transform_vector(&ddd) - w.cross(&de) * 2.0 - al.cross(&e) + w.cross(&w.cross(&e));
        if self.holds_attitude {
            // Q = RᵀR₀ is still in the world: its angular velocity relative to the cabin is the
            // cabin's reversed, and so is its angular acceleration (body frame)
            PathPoint {
                position: e,
                velocity,
                acceleration,
                orientation: (r.inverse() * self.reference.1).to_rotation_matrix().into_inner(),
                angular_velocity: -w,
                angular_acceleration: -al,
            }
        } else {
            PathPoint::translating(e - self.feed_point, velocity, acceleration)
        }
    }

    /// The platform at rest, cabin frame.
    pub fn rest(&self) -> PathPoint {
        PathPoint::translating(self.rest, Vec3::zeros(), Vec3::zeros())
    }

    /// The rest pose as a command.
    fn rest_pose(&self) -> Pose {
        Pose::new(self.rest.x, self.rest.y, self.rest.z, 0.0, 0.0, 0.0)
    }

    /// The feed's position error (world frame, m) and its rotation from the start attitude
    /// (world rotation vector, rad; its length is the tilt error) at time `t` for the platform
    /// (centre) at this world pose.
    pub fn feed_error(&self, platform_position: &Vec3, platform_orientation: &Quat, t: f64) -> (Vec3, Vec3) {
        let feed = platform_position + platform_orientation * self.feed_point;
        (feed - self.target(t).position, (platform_orientation * self.reference.1.inverse()).scaled_axis())
    }

    /// The angle of the feed's axis from its start direction (the platform at this world
    /// orientation), rad: the feed's tilt error.
    pub fn feed_tilt(&self, platform_orientation: &Quat) -> f64 {
        let (now, start) = (platform_orientation * self.feed_axis, self.reference.1 * self.feed_axis);
        now.cross(&start).norm().atan2(now.dot(&start))
    }

    /// The state of a sampled sensor and its command at the start.
    pub fn start_state(&self) -> CommandState {
        let rest = self.rest_pose().into();
        CommandState {
            segment: Segment { start: 0.0, from: rest, velocity: [0.0; 6], acceleration: [0.0; 6], to: rest },
            pending: VecDeque::new(),
            next_sample: 0,
            rng: SplitMix64::new(self.seed),
            notch: NotchState::default(),
            fused: self.fused.as_ref().map(|(imu, fusion)| Fused {
                imu: imu.start(),
                filter: fusion.start_state(),
                next_reading: 0,
            }),
            lqg: self.lqg.as_ref().map(LqgLaw::start),
        }
    }
}

/// The motion from one command to the next: starts at `start` at `from` with `velocity` and
/// `acceleration` (which only a third filter stage keeps).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Segment {
    start: f64,
    from: [f64; 6],
    velocity: [f64; 6],
    acceleration: [f64; 6],
    to: [f64; 6],
}

impl Segment {
    /// The commanded pose and its first two derivatives at `t`.
    fn pose_at(&self, c: &Compensation, t: f64) -> [Pose; 3] {
        let (from, v0, to) = (Pose::from(self.from), Pose::from(self.velocity), Pose::from(self.to));
        let s = (t - self.start).max(0.0);
        match c.tau {
            Some(tau) => {
                // critically damped: c = u + P(s) e^{−s/τ}, P = A + B s + C s², A = c₀ − u,
                // B = ċ₀ + A/τ, and with three stages C = (c̈₀ + 2B/τ − A/τ²)/2 (else 0), so
                // that c, ċ (and c̈) start where the last segment left them
                let a = from - to;
                let b = v0 + a / tau;
                let cc = if c.third_stage {
                    (Pose::from(self.acceleration) + b * (2.0 / tau) - a / (tau * tau)) * 0.5
                } else {
                    Pose::zeros()
                };
                let e = (-s / tau).exp();
                let p = a + (b + cc * s) * s;
                let dp = b + cc * (2.0 * s);
                [to + p * e, (dp - p / tau) * e, (cc * 2.0 - dp * (2.0 / tau) + p / (tau * tau)) * e]
            }
            None => {
                let d = 0.5 * c.command_period;
                let x = (s / d).min(1.0);
                let x2 = x * x;
                let step = x2 * x * (10.0 - 15.0 * x + 6.0 * x2);
                let rate = 30.0 * x2 * (1.0 - x) * (1.0 - x) / d;
                let curve = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (d * d);
                let jump = to - from;
                [from + jump * step, jump * rate, jump * curve]
            }
        }
    }

    fn at(&self, c: &Compensation, t: f64) -> PathPoint {
        let [q, dq, ddq] = self.pose_at(c, t);
        pose_motion(&q, &dq, &ddq)
    }
}

/// The platform's motion relative to the cabin for a commanded pose (centre, cabin frame, m;
/// z-y-x angles φ, θ, ψ, rad) and its first two time derivatives.
pub fn commanded_point(pose: &[f64; 6], rate: &[f64; 6], acceleration: &[f64; 6]) -> PathPoint {
    pose_motion(&Pose::from(*pose), &Pose::from(*rate), &Pose::from(*acceleration))
}

/// The platform's motion for a pose (centre, z-y-x angles) and its first two derivatives.
fn pose_motion(q: &Pose, dq: &Pose, ddq: &Pose) -> PathPoint {
    let three = |v: &Pose, i: usize| Vec3::new(v[i], v[i + 1], v[i + 2]);
    let (roll, pitch, yaw) = (q[3], q[4], q[5]);
    let (droll, dpitch, dyaw) = (dq[3], dq[4], dq[5]);
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let orientation = *(Rotation3::from_axis_angle(&Vec3::z_axis(), yaw)
        * Rotation3::from_axis_angle(&Vec3::y_axis(), pitch)
        * Rotation3::from_axis_angle(&Vec3::x_axis(), roll))
    .matrix();
    // ω = ψ̇ z + θ̇ R_z y + φ̇ R_z R_y x; each axis turns with the rotations before it
    let (z, y1, x2) = (Vec3::z(), Vec3::new(-sy, cy, 0.0), Vec3::new(cy * cp, sy * cp, -sp));
    let w_yaw = z * dyaw;
    let w_pitch = w_yaw + y1 * dpitch;
    let angular_velocity = w_pitch + x2 * droll;
    let angular_acceleration =
        z * ddq[5] + y1 * ddq[4] + w_yaw.cross(&y1) * dpitch + x2 * ddq[3] + w_pitch.cross(&x2) * droll;
    PathPoint {
        position: three(q, 0),
        velocity: three(dq, 0),
        acceleration: three(ddq, 0),
        orientation,
        angular_velocity,
        angular_acceleration,
    }
}

/// A notch on the commands, a biquad at the command rate (the bilinear transform of
/// `(s² + ω₀²)/(s² + s ω₀/Q + ω₀²)`, frequency prewarped): `y = b₀u + b₁u₁ + b₂u₂ − a₁y₁ − a₂y₂`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Notch {
    b: [f64; 3],
    a: [f64; 2],
}

impl Notch {
    fn new(frequency: f64, q: f64, rate: f64) -> Notch {
        let w = std::f64::consts::TAU * frequency / rate;
        let (sin, cos) = w.sin_cos();
        let alpha = sin / (2.0 * q);
        let a0 = 1.0 + alpha;
        Notch { b: [1.0 / a0, -2.0 * cos / a0, 1.0 / a0], a: [-2.0 * cos / a0, (1.0 - alpha) / a0] }
    }
}

/// The notch's memory: the last two inputs and outputs of each pose component, as deviations
/// from the rest pose.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct NotchState {
    inputs: [[f64; 6]; 2],
    outputs: [[f64; 6]; 2],
}

impl NotchState {
    /// The command through the notch (unchanged without one).
    fn filter(&mut self, c: &Compensation, command: Pose) -> Pose {
        let Some(n) = &c.notch else { return command };
        let rest = c.rest_pose();
        let u = command - rest;
        let (u1, u2, y1, y2) = (
            Pose::from(self.inputs[0]),
            Pose::from(self.inputs[1]),
            Pose::from(self.outputs[0]),
            Pose::from(self.outputs[1]),
        );
        let y = u * n.b[0] + u1 * n.b[1] + u2 * n.b[2] - y1 * n.a[0] - y2 * n.a[1];
        self.inputs = [u.into(), u1.into()];
        self.outputs = [y.into(), y1.into()];
        rest + y
    }
}

/// The z-y-x angles (φ, θ, ψ) of a rotation `R_z(ψ) R_y(θ) R_x(φ)`, |θ| < π/2.
fn zyx_angles(m: &Mat3) -> Vec3 {
    Vec3::new(m[(2, 1)].atan2(m[(2, 2)]), (-m[(2, 0)]).atan2(m[(2, 1)].hypot(m[(2, 2)])), m[(1, 0)].atan2(m[(0, 0)]))
}

/// What a sampled sensor carries from step to step: the command being followed, the commands
/// measured but not yet applied (the delay), the next sample and the noise generator.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct CommandState {
    segment: Segment,
    /// (time it applies, command), in time order.
    pending: VecDeque<(f64, [f64; 6])>,
    /// Index k of the next sample, taken at the first communication point ≥ k·T.
    next_sample: u64,
    rng: SplitMix64,
    /// The notch's memory (with `notch_hz`).
    notch: NotchState,
    /// With `[control.imu]`: the unit, the filter and the index of the next reading.
    fused: Option<Fused>,
    /// With `law = "lqg"`: the unit, the controller, the fixes on their way.
    lqg: Option<LqgState>,
}

/// The inertial unit's and the filter's state.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Fused {
    imu: ImuState,
    filter: FusionState,
    /// Index k of the next reading, taken at the first communication point ≥ k·T_imu.
    next_reading: u64,
}

impl Clone for Fused {
    fn clone(&self) -> Self {
        Fused { imu: self.imu, filter: self.filter.clone(), next_reading: self.next_reading }
    }

    fn clone_from(&mut self, source: &Self) {
        self.imu = source.imu;
        self.filter.clone_from(&source.filter);
        self.next_reading = source.next_reading;
    }
}

impl Clone for CommandState {
    fn clone(&self) -> Self {
        CommandState {
            segment: self.segment,
            pending: self.pending.clone(),
            next_sample: self.next_sample,
            rng: self.rng,
            notch: self.notch,
            fused: self.fused.clone(),
            lqg: self.lqg.clone(),
        }
    }

    /// Reuses the queues' storage (snapshots taken every step allocate nothing).
    fn clone_from(&mut self, source: &Self) {
        self.segment = source.segment;
        self.pending.clone_from(&source.pending);
        self.next_sample = source.next_sample;
        self.rng = source.rng;
        self.notch = source.notch;
        self.fused.clone_from(&source.fused);
        self.lqg.clone_from(&source.lqg);
    }
}

impl CommandState {
    /// Starts a new segment at `time` for every pending command applying before `until`.
    fn apply(segment: &mut Segment, pending: impl Iterator<Item = (f64, [f64; 6])>, c: &Compensation) {
        for (time, to) in pending {
            let [now, rate, acceleration] = segment.pose_at(c, time);
            *segment =
                Segment { start: time, from: now.into(), velocity: rate.into(), acceleration: acceleration.into(), to };
        }
    }

    fn due(pending: &VecDeque<(f64, [f64; 6])>, until: f64) -> usize {
        pending.iter().take_while(|(time, _)| *time < until - SAME_INSTANT).count()
    }

    /// The commanded platform motion (cabin frame) at time `t`, for `t` after the last sample.
    pub fn at(&self, c: &Compensation, t: f64) -> PathPoint {
        let mut segment = self.segment;
        Self::apply(&mut segment, self.pending.iter().take(Self::due(&self.pending, t)).copied(), c);
        segment.at(c, t)
    }

    /// At communication point `t` with the cabin moving as `cabin`: applies the commands due,
    /// takes a sample if one is due (a command `delay` later, or a fix for the filter), and with
    /// an inertial unit a reading if one is due (and a command from the estimate, at once).
    pub fn sample(&mut self, c: &Compensation, t: f64, cabin: &CabinMotion) {
        let due = Self::due(&self.pending, t);
        Self::apply(&mut self.segment, self.pending.drain(..due), c);
        if (self.next_sample as f64) * c.period <= t + SAME_INSTANT {
            let mut noise = || Vec3::new(self.rng.symmetric(), self.rng.symmetric(), self.rng.symmetric());
            let measured_p = cabin.position + noise() * c.noise_m;
            let measured_q = Quat::from_scaled_axis(noise() * c.noise_rad) * cabin.orientation;
            self.next_sample = ((t + SAME_INSTANT) / c.period).floor() as u64 + 1;
            match (&mut self.fused, &c.fused, &mut self.lqg, &c.lqg) {
                (Some(state), Some((_, fusion)), _, _) => {
                    let q = measured_q.into_inner();
                    let fix = Fix { measured_at: t, position: measured_p.into(), attitude: [q.w, q.i, q.j, q.k] };
                    fusion.add_fix(&mut state.filter, fix);
                }
                (_, _, Some(state), Some(law)) => law.add_fix(state, t, law.fix(&measured_p, &measured_q)),
                _ => {
                    let apply = t + c.delay;
                    let command = self.notch.filter(c, c.command(&measured_p, &measured_q, apply));
                    self.pending.push_back((apply, command.into()));
                }
            }
        }
        if let (Some(state), Some((imu, fusion))) = (&mut self.fused, &c.fused)
            && (state.next_reading as f64) * imu.period <= t + SAME_INSTANT
        {
            let reading = imu.read(&mut state.imu, cabin, t);
            fusion.add_reading(&mut state.filter, reading);
            fusion.absorb(&mut state.filter, t);
            let (position, attitude) = fusion.estimate(&state.filter, t).predicted(c.prediction, &fusion.gravity());
            let command = self.notch.filter(c, c.command(&position, &attitude, t + c.prediction));
            self.pending.push_back((t, command.into()));
            state.next_reading = ((t + SAME_INSTANT) / imu.period).floor() as u64 + 1;
        }
        if let (Some(state), Some(law)) = (&mut self.lqg, &c.lqg)
            && law.reading_due(state, t)
        {
            let u = law.read(state, cabin, t, c.delay);
            // what holding the feed takes beyond the first order the controller's model holds,
            // at the estimated cabin pose
            let (p, r) = law.estimate(state);
            let beyond = c.command(&p, &r, t) - c.rest_pose() - c.linear_command(&p, &r);
            let command = c.rest_pose() + Pose::from(u) + beyond;
            self.pending.push_back((t, command.into()));
        }
    }

    /// The estimate of the cabin's pose at `t` (after the last reading): the fusion's, or the
    /// LQG controller's at its last reading.
    pub fn estimate(&self, c: &Compensation, t: f64) -> Option<(Vec3, Quat)> {
        match (&self.fused, &c.fused, &self.lqg, &c.lqg) {
            (Some(state), Some((_, fusion)), _, _) => {
                let e: Estimate = fusion.estimate(&state.filter, t);
                Some((Vec3::from(e.position), e.attitude()))
            }
            (_, _, Some(state), Some(law)) => Some(law.estimate(state)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(extra: &str) -> ValidScene {
        let text = feedcore::shipped::embedded("lt50m_C.toml").unwrap().to_string() + extra;
        feedcore::scene::Scene::from_toml(&text, "test.toml").unwrap()
    }

    fn compensation(extra: &str) -> Compensation {
        Compensation::new(&scene(extra), Vec3::new(0.1, 0.0, -1.8), [1.5; LEGS]).unwrap()
    }

    const SAMPLED: &str = "\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"hold\"\nsensor = \"sampled\"\nsample_rate_hz = 20.0\n";

    /// Fourth-order central difference.
    fn derivative(f: impl Fn(f64) -> Vec3, t: f64, h: f64) -> Vec3 {
        (f(t - 2.0 * h) - f(t - h) * 8.0 + f(t + h) * 8.0 - f(t + 2.0 * h)) / (12.0 * h)
    }

    #[test]
    fn ideal_command_derivatives_match_finite_differences_of_a_moving_cabin() {
        let c = compensation(
            "\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"circle\"\ncircle_center_offset_m = [-0.1, 0.05, 0.0]\ncircle_speed_m_s = 0.02\nsensor = \"ideal\"\n",
        );
        // a cabin on a smooth path with a varying attitude
        let cabin = |t: f64| {
            let p = Vec3::new(0.01 * t.sin(), 0.02 * (0.7 * t).cos(), 9.8 + 0.003 * t * t);
            let v = Vec3::new(0.01 * t.cos(), -0.014 * (0.7 * t).sin(), 0.006 * t);
            let a = Vec3::new(-0.01 * t.sin(), -0.0098 * (0.7 * t).cos(), 0.006);
            (p, v, a, Quat::from_scaled_axis(Vec3::new(0.02 * t, 0.01 * t * t, 0.0)))
        };
        let motion = |t: f64| {
            let (p, v, a, q) = cabin(t);
            let h = 1e-5;
            let rot = |s: f64| cabin(s).3;
            // world angular velocity and acceleration by differences of the attitude
            let w_at = |s: f64| ((rot(s + h) * rot(s - h).inverse()).scaled_axis()) / (2.0 * h);
            let w = w_at(t);
            let al = (w_at(t + 1e-3) - w_at(t - 1e-3)) / 2e-3;
            CabinMotion {
                position: p,
                orientation: q,
                velocity: v,
                angular_velocity: w,
                acceleration: a,
                angular_acceleration: al,
            }
        };
        for t in [0.5, 1.3, 2.0] {
            let at = c.ideal(&motion(t), t);
            let fd_v = derivative(|s| c.ideal(&motion(s), s).position, t, 1e-3);
            let fd_a = derivative(|s| c.ideal(&motion(s), s).velocity, t, 1e-3);
            assert!((at.velocity - fd_v).norm() < 1e-8, "t {t}: velocity {at:?} vs {fd_v:?}");
            assert!((at.acceleration - fd_a).norm() < 1e-6, "t {t}: acceleration {at:?} vs {fd_a:?}");
            let fd_w = angular_rate(|s| c.ideal(&motion(s), s).orientation, t, 1e-5);
            let fd_al = derivative(|s| c.ideal(&motion(s), s).angular_velocity, t, 1e-3);
            assert!((at.angular_velocity - fd_w).norm() < 1e-8, "t {t}: ω {:?} vs {fd_w:?}", at.angular_velocity);
            assert!((at.angular_acceleration - fd_al).norm() < 1e-6, "t {t}: α {:?}", at.angular_acceleration);
            // the feed is on the target and its attitude (hence its axis) is the start one
            let m = motion(t);
            let attitude = m.orientation * at.rotation();
            let platform = m.position + m.orientation * at.position;
            let (err, rot) = c.feed_error(&platform, &attitude, t);
            assert!(err.norm() < 1e-14 && rot.norm() < 1e-15, "{err:?} {rot:?}");
            assert!(c.feed_tilt(&attitude) < 1e-15);
        }
    }

    #[test]
    fn sampled_command_is_smooth_and_reaches_the_measured_command() {
        for filter in ["", "bandwidth_hz = 2.0\n", "bandwidth_hz = 2.0\nfilter_stages = 3\n"] {
            let c = compensation(&format!("{SAMPLED}delay_s = 0.03\n{filter}"));
            let mut s = c.start_state();
            let (p0, q0) = (Vec3::new(0.0, 0.0, 9.8), Quat::identity());
            let moved = p0 + Vec3::new(0.004, -0.002, 0.001);
            let h = 0.0125;
            for n in 0..400 {
                let t = n as f64 * h;
                let before = s.at(&c, t);
                s.sample(&c, t, &CabinMotion::at_rest(if t < 0.1 { p0 } else { moved }, q0));
                assert_eq!(before, s.at(&c, t), "{filter}: sampling at t {t} moves the command");
                // position and velocity continuous where a command applies (t + delay)
                let (a, b) = (s.at(&c, t + 0.03 - 1e-7), s.at(&c, t + 0.03 + 1e-7));
                assert!((a.position - b.position).norm() < 1e-6, "{filter} t {t}");
                assert!((a.velocity - b.velocity).norm() < 1e-4, "{filter} t {t}");
                if c.third_stage {
                    assert!((a.acceleration - b.acceleration).norm() < 1e-4, "{filter} t {t}");
                }
            }
            // the commands reach the pose that puts the feed on the target for the moved cabin
            let expected = c.command(&moved, &q0, 0.0);
            let reached = s.at(&c, 5.0);
            assert!((reached.position - expected.fixed_rows::<3>(0)).norm() < 1e-9, "{filter}");
            assert!((zyx_angles(&reached.orientation) - expected.fixed_rows::<3>(3)).norm() < 1e-9, "{filter}");
            // the motion is exactly the commanded one: velocity is the derivative of position
            let mut s = c.start_state();
            s.sample(&c, 0.0, &CabinMotion::at_rest(moved, q0));
            for t in [0.031, 0.04, 0.05, 0.07] {
                let fd = derivative(|x| s.at(&c, x).position, t, 1e-5);
                assert!((s.at(&c, t).velocity - fd).norm() < 1e-7, "{filter} t {t}");
                let fd = derivative(|x| s.at(&c, x).velocity, t, 1e-5);
                assert!((s.at(&c, t).acceleration - fd).norm() < 1e-5, "{filter} t {t}");
            }
            // nothing moves before the delay has passed
            assert_eq!(s.at(&c, 0.03).position, c.rest().position);
        }
    }

    /// A step in the command (a moved cabin, sampled once) is followed as n first-order stages of
    /// time constant τ follow it: the share covered after x = s/τ is 1 − e^{−x}(1 + x) with two
    /// stages, 1 − e^{−x}(1 + x + x²/2) with three, whose acceleration starts at zero, not at a jump.
    #[test]
    fn the_filter_stages_follow_a_step_as_their_transfer_function_says() {
        let (delay, bandwidth) = (0.03, 2.0);
        let tau = 1.0 / (std::f64::consts::TAU * bandwidth);
        for (stages, share) in [
            (2, (|x: f64| 1.0 - (-x).exp() * (1.0 + x)) as fn(f64) -> f64),
            (3, |x: f64| 1.0 - (-x).exp() * (1.0 + x + 0.5 * x * x)),
        ] {
            let c = compensation(&format!(
                "{SAMPLED}delay_s = {delay}\nbandwidth_hz = {bandwidth}\nfilter_stages = {stages}\n"
            ));
            let (p0, q0) = (Vec3::new(0.0, 0.0, 9.8), Quat::identity());
            let moved = p0 + Vec3::new(0.004, -0.002, 0.001);
            let mut s = c.start_state();
            s.sample(&c, 0.0, &CabinMotion::at_rest(moved, q0));
            let rest = c.rest().position;
            let jump = c.command(&moved, &q0, 0.0).fixed_rows::<3>(0) - rest;
            for x in [0.1, 0.5, 1.0, 2.0, 4.0] {
                let at = s.at(&c, delay + x * tau).position;
                let expected = rest + jump * share(x);
                assert!((at - expected).norm() < 1e-14, "{stages} stages, x {x}: {at:?} vs {expected:?}");
            }
            // just after the command applies (1 µs = 1.3e-5 τ): jump/τ² with two stages, about 0 with three
            let (start, scale) = (s.at(&c, delay + 1e-6).acceleration.norm(), jump.norm() / (tau * tau));
            if stages == 3 {
                assert!(start < 1e-4 * scale, "{stages} stages: {start} against {scale}");
            } else {
                assert!((start - scale).abs() < 1e-4 * scale, "{stages} stages: {start} against {scale}");
            }
        }
    }

    /// The notch at the command rate: a sinusoid at its frequency is removed in the steady state,
    /// a constant and a sinusoid a decade away pass (to 2 %); the quality sets the width (the
    /// gain at f₀·(1 ± 1/(2Q)) is about 1/√2).
    #[test]
    fn the_notch_removes_its_frequency_and_passes_the_rest() {
        let rate = 100.0;
        let gain = |n: &Notch, f: f64| {
            let (mut u, mut y) = ([0.0; 2], [0.0; 2]);
            let mut peak: f64 = 0.0;
            for k in 0..40_000 {
                let x = (std::f64::consts::TAU * f * k as f64 / rate).sin();
                let out = n.b[0] * x + n.b[1] * u[0] + n.b[2] * u[1] - n.a[0] * y[0] - n.a[1] * y[1];
                (u, y) = ([x, u[0]], [out, y[0]]);
                if k >= 30_000 {
                    peak = peak.max(out.abs());
                }
            }
            peak
        };
        let n = Notch::new(0.83, 8.0, rate);
        assert!(gain(&n, 0.83) < 1e-3, "{}", gain(&n, 0.83));
        assert!((gain(&n, 0.083) - 1.0).abs() < 0.02 && (gain(&n, 8.3) - 1.0).abs() < 0.02);
        let edge = gain(&n, 0.83 * (1.0 + 1.0 / 16.0));
        assert!((edge - std::f64::consts::FRAC_1_SQRT_2).abs() < 0.05, "{edge}");
        // a constant passes exactly
        let dc: f64 = n.b.iter().sum::<f64>() / (1.0 + n.a[0] + n.a[1]);
        assert!((dc - 1.0).abs() < 1e-12);
    }

    /// The angular velocity of a relative orientation, cabin frame, by central differences:
    /// the small rotation from t − h to t + h read off its skew part (sin φ ≈ φ to 1e-10 here;
    /// an angle taken through acos would lose half the digits).
    fn angular_rate(f: impl Fn(f64) -> Mat3, t: f64, h: f64) -> Vec3 {
        let m = f(t + h) * f(t - h).transpose();
        Vec3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]) / (4.0 * h)
    }

    #[test]
    fn a_pose_from_angles_turns_as_its_angular_velocity_and_acceleration_say() {
        // angles that sweep all three axes at once, with a pitch near 1 rad
        let angles = |t: f64| {
            let (s, c) = (1.3 * t).sin_cos();
            Pose::new(0.1 * t, -0.2 * t * t, 0.3 + 0.2 * s, 0.4 * s, 0.9 + 0.1 * c, -0.7 * t + 0.05 * t * t)
        };
        let rate = |t: f64| (angles(t + 1e-5) - angles(t - 1e-5)) / 2e-5;
        let motion = |t: f64| {
            let ddq = (rate(t + 1e-4) - rate(t - 1e-4)) / 2e-4;
            pose_motion(&angles(t), &rate(t), &ddq)
        };
        for t in [0.2, 0.9, 1.7] {
            let m = motion(t);
            let w = angular_rate(|x| motion(x).orientation, t, 1e-5);
            assert!((m.angular_velocity - w).norm() < 1e-8, "t {t}: ω {:?} vs {w:?}", m.angular_velocity);
            let al = derivative(|x| motion(x).angular_velocity, t, 1e-3);
            assert!((m.angular_acceleration - al).norm() < 1e-5, "t {t}: α {:?} vs {al:?}", m.angular_acceleration);
            // the angles read back from the orientation
            assert!((zyx_angles(&m.orientation) - angles(t).fixed_rows::<3>(3)).norm() < 1e-13);
            assert!((m.orientation.transpose() * m.orientation - Mat3::identity()).norm() < 1e-15);
        }
    }

    /// The first order the LQG law's model holds is the command's derivative: the gap of a
    /// cabin moved by ε shrinks as ε², for a cabin at a tilted reference too.
    #[test]
    fn the_linear_command_is_the_commands_first_order() {
        let c = compensation("\n[control]\nfeed_point_m = [0.0, 0.3, -0.3]\ntarget = \"hold\"\nsensor = \"ideal\"\n");
        let (p0, r0) = c.reference();
        let (dir, turn) = (Vec3::new(0.3, -0.5, 0.2), Vec3::new(-0.4, 0.7, 0.3));
        let gap = |e: f64| {
            let (p, r) = (p0 + dir * e, Quat::from_scaled_axis(turn * e) * r0);
            let exact = c.command(&p, &r, 0.0) - c.rest_pose();
            (exact - c.linear_command(&p, &r)).norm() / e
        };
        let (a, b) = (gap(1e-3), gap(1e-4));
        assert!(a < 1e-3 && (a / b - 10.0).abs() < 0.5, "{a:e} {b:e}");
    }

    #[test]
    fn noise_is_seeded_and_bounded() {
        let run = |seed: u64| {
            let c = compensation(&format!("{SAMPLED}noise_m = 0.001\nseed = {seed}\n"));
            let mut s = c.start_state();
            s.sample(&c, 0.0, &CabinMotion::at_rest(Vec3::new(0.0, 0.0, 9.8), Quat::identity()));
            s.at(&c, 1.0).position - c.rest().position
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
        assert!(run(3).amax() <= 0.001 && run(3).norm() > 0.0);
    }

    /// A cabin rocking about a tilted axis with the platform holding the feed's pose (ideal
    /// sensor): the bodies placed by the relative kinematics satisfy every joint equation at
    /// position, velocity and acceleration level, and the platform's world attitude is still.
    #[test]
    fn a_commanded_pose_satisfies_every_joint() {
        let s = scene("\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"hold\"\nsensor = \"ideal\"\n");
        let st = crate::Stewart::from_scene(&s).unwrap();
        let c = st.compensation().unwrap();
        let axis = Vec3::new(0.3, -1.0, 0.4).normalize();
        let p0 = s.target_position();
        let mut worst = [0.0_f64; 3];
        for i in 0..200 {
            let t = 0.05 * i as f64;
            let (sn, cs) = (2.0 * t).sin_cos();
            let cabin = CabinMotion {
                position: p0 + Vec3::new(0.03 * sn, 0.0, 0.01 * cs),
                velocity: Vec3::new(0.06 * cs, 0.0, -0.02 * sn),
                acceleration: Vec3::new(-0.12 * sn, 0.0, -0.04 * cs),
                orientation: Quat::from_scaled_axis(axis * (0.02 * sn)),
                angular_velocity: axis * (0.04 * cs),
                angular_acceleration: axis * (-0.08 * sn),
            };
            let point = c.ideal(&cabin, t);
            let bodies = st.system_motion_at(&cabin, &point, t).unwrap();
            let mut rows = [crate::ConstraintRow::EMPTY; crate::CONSTRAINTS];
            st.joints().evaluate(&bodies, &st.strokes_at(&point, t).unwrap(), &mut rows);
            for row in &rows {
                worst[0] = worst[0].max(row.value.abs());
                worst[1] = worst[1].max(row.velocity_residual(&bodies).abs());
                worst[2] = worst[2].max(row.acceleration_residual(&bodies).abs());
            }
            let platform = &bodies[crate::constraints::PLATFORM];
            assert!(platform.angular_velocity.norm() < 1e-15 && platform.angular_acceleration.norm() < 1e-15);
            assert!(c.feed_tilt(&platform.orientation) < 1e-14, "t {t}");
        }
        assert!(worst.iter().all(|w| *w <= 1e-12), "{worst:?}");
    }

    /// The compensation's wrench on the cabin against inverse dynamics done independently: the
    /// bodies placed along the compensating motion (positions and attitudes only), their momentum
    /// and angular momentum about the moving cabin centre point differentiated numerically, plus
    /// their weight, against `Stewart::evaluate_at` (the joint multipliers of eq. 5, what the FMU
    /// outputs). A cabin swaying by 4 cm and rocking by 10 mrad at 3 rad/s (a dynamic part of
    /// 16–35 N and N·m on ~1800 N of weight); the feed on a circle, ideal sensor.
    #[test]
    fn the_compensating_wrench_is_the_bodies_rate_of_momentum_and_their_weight() {
        let s = scene(
            "\n[control]\nfeed_point_m = [0.0, 0.0, -0.3]\ntarget = \"circle\"\ncircle_center_offset_m = [-0.05, 0.0, 0.0]\ncircle_speed_m_s = 0.05\nsensor = \"ideal\"\n",
        );
        let st = crate::Stewart::from_scene(&s).unwrap();
        let c = st.compensation().unwrap();
        let (w0, amp, tilt) = (3.0, 0.04, 0.01);
        let axis = Vec3::new(1.0, 0.5, 0.2).normalize();
        let p0 = s.target_position();
        // an analytic cabin motion: translation and a rotation about a fixed world axis
        let cabin = |t: f64| {
            let (sn, cs) = (w0 * t).sin_cos();
            let (s2, c2) = (1.3 * w0 * t).sin_cos();
            let theta = tilt * sn;
            CabinMotion {
                position: p0 + Vec3::new(sn, c2 - 1.0, 0.5 * sn) * amp,
                velocity: Vec3::new(cs, -1.3 * s2, 0.5 * cs) * (amp * w0),
                acceleration: Vec3::new(-sn, -1.69 * c2, -0.5 * sn) * (amp * w0 * w0),
                orientation: Quat::from_scaled_axis(axis * theta),
                angular_velocity: axis * (tilt * w0 * cs),
                angular_acceleration: axis * (-tilt * w0 * w0 * sn),
            }
        };
        let bodies = |t: f64| {
            let m = cabin(t);
            let rel = st.relative_at(&c.ideal(&m, t), t).unwrap();
            st.place_bodies(&m, &rel)
        };
        let inertias = st.body_inertias();
        let g = st.gravity();
        // linear momentum and angular momentum about the cabin centre point, by differences of
        // the bodies' placements (angular velocity from neighbouring attitudes)
        let momenta = |t: f64| {
            let (e, b0, b1, bm) = (1e-5, bodies(t), bodies(t + 1e-5), bodies(t - 1e-5));
            let centre = cabin(t).position;
            let (mut lin, mut ang) = (Vec3::zeros(), Vec3::zeros());
            for k in 0..b0.len() {
                let m = inertias[k].mass;
                let v = (b1[k].position - bm[k].position) / (2.0 * e);
                let w = (b1[k].orientation * bm[k].orientation.inverse()).scaled_axis() / (2.0 * e);
                let r = b0[k].orientation.to_rotation_matrix();
                let i_world = r.matrix() * inertias[k].inertia_com * r.matrix().transpose();
                lin += v * m;
                ang += (b0[k].position - centre).cross(&(v * m)) + i_world * w;
            }
            (lin, ang)
        };
        let dt = 1e-3;
        for t in [0.4, 1.1, 2.3] {
            let d = |k: usize| {
                let f = |x: f64| if k == 0 { momenta(x).0 } else { momenta(x).1 };
                (f(t - 2.0 * dt) - f(t - dt) * 8.0 + f(t + dt) * 8.0 - f(t + 2.0 * dt)) / (12.0 * dt)
            };
            let (dp, dh) = (d(0), d(1));
            let (p, _) = momenta(t);
            let m = cabin(t);
            let b = bodies(t);
            let mass: f64 = inertias.iter().map(|i| i.mass).sum();
            let weight_moment = b
                .iter()
                .zip(inertias)
                .fold(Vec3::zeros(), |acc, (x, i)| acc + (x.position - m.position).cross(&(g * i.mass)));
            // the cabin's force and moment (about its centre point) on the bodies, then minus
            let force = -(dp - g * mass);
            let moment = -(dh + m.velocity.cross(&p) - weight_moment);
            let w = st.evaluate_at(&m, &c.ideal(&m, t), t).unwrap().wrench;
            let dynamic = (dp.norm(), dh.norm());
            eprintln!(
                "t {t}: force gap {:.2e} N of {:.1} N dynamic, moment gap {:.2e} N·m of {:.1}",
                (w.force - force).norm(),
                dynamic.0,
                (w.moment - moment).norm(),
                dynamic.1
            );
            assert!(dynamic.0 > 5.0, "the motion must be dynamic: {dynamic:?} N, N·m");
            assert!((w.force - force).norm() < 1e-5 * dynamic.0, "t {t}: {:?} vs {force:?}", w.force);
            assert!((w.moment - moment).norm() < 1e-5 * dynamic.1.max(1.0), "t {t}: {:?} vs {moment:?}", w.moment);
        }
    }
}
