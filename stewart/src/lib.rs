//! The Stewart platform hanging in the feed cabin as a multibody system (paper eqs. 3–7): the
//! moving platform and six legs of two parts each (Hooke joint to the cabin, prismatic actuator,
//! spherical joint to the platform), driven so that the platform translates on a circle relative
//! to the cabin (`[motion]`) or moves as the compensation commands (`[control]`: position and
//! attitude), while the cabin moves as given from outside.
//!
//! * [`path`]: the prescribed circle motion of the platform centre;
//! * [`relative`]: every body's motion relative to the cabin, a function of time alone;
//! * [`wrench`]: the wrench on the cabin in momentum form and its exact Jacobians;
//! * [`constraints`]: Φ, Φ_q, Φ_t and γ of all joints, the cabin included as a body;
//! * [`reactions`]: the Lagrange multipliers: joint reactions and actuator forces;
//! * [`kinematics`]: inverse and forward kinematics of the platform pose;
//! * [`sensitivity`]: the outputs' first-order changes under a change of the cabin's motion;
//! * [`imu`], [`fusion`]: the inertial unit on the cabin and the Kalman filter that fuses it with
//!   the total station's delayed fixes (the compensation's estimate of the cabin's pose);
//! * [`lqg`]: the LQG law, its controller made from the scene's design model.
//!
//! Conventions: world frame Z up, gravity (0, 0, −g); cabin motion and the wrench in the world
//! frame; the wrench is what the platform exerts on the cabin (moment about the cabin centre
//! point); actuator forces are tensions (positive when pulling the platform towards the cabin).
//! Before t = 0 the platform rests at its start point, so any negative time gives the static state.

pub mod compensation;
pub mod constraints;
mod error;
pub mod fusion;
pub mod imu;
pub mod kinematics;
pub mod lqg;
pub mod path;
pub mod reactions;
pub mod relative;
pub mod sensitivity;
pub mod wrench;

use feedcore::rigid::MassProperties;
use feedcore::scene::{LEGS, Motion, ValidScene};
use feedcore::stewart_geometry::{BODIES, StewartGeometry};
use feedcore::{Quat, Vec3};
use nalgebra::{Rotation3, Vector6};
pub use path::PathPoint;

pub use compensation::{CommandState, Compensation};
pub use constraints::{CABIN, CONSTRAINTS, ConstraintRow, Joints, SYSTEM_BODIES};
pub use error::StewartError;
pub use path::CirclePath;
pub use reactions::LegReactions;
pub use relative::{RelativeState, Stroke};
pub use sensitivity::ActuatorRates;
pub use wrench::{CabinMotion, RigidMotion, Wrench, WrenchJacobians};

/// A leg this close to its first Hooke axis (sine of the angle) locks the Hooke joint.
const HOOKE_SINGULAR_SINE: f64 = 1e-6;
/// Poses whose leg force Jacobian has a larger condition number are treated as singular.
const SINGULAR_CONDITION: f64 = 1e8;
/// Samples of the first revolution checked when the model is built.
const PATH_CHECKS: usize = 720;

/// Everything computed by one [`Stewart::evaluate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    pub time: f64,
    /// Wrench on the cabin from the Hooke joint reactions.
    pub wrench: Wrench,
    /// Actuator tensions, N (positive: the actuator pulls the platform towards the cabin).
    pub actuator_forces: [f64; LEGS],
    /// The platform (centre of mass = centre), world frame.
    pub platform: RigidMotion,
    pub legs: [LegReactions; LEGS],
    /// All multipliers λ of eq. (5), in the row order of [`constraints`].
    pub multipliers: [f64; CONSTRAINTS],
    /// Leg lengths (joint centre to joint centre), m.
    pub leg_lengths: [f64; LEGS],
}

/// Extremes over the first revolution of the platform with the cabin held at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedCabinRange {
    /// Time of the first revolution (0 if the platform does not move), s.
    pub duration: f64,
    pub samples: usize,
    /// Componentwise extremes of the wrench 6-vector (force, moment).
    pub wrench_min: Vector6<f64>,
    pub wrench_max: Vector6<f64>,
    /// Extremes of each actuator's tension.
    pub actuator_min: [f64; LEGS],
    pub actuator_max: [f64; LEGS],
}

impl FixedCabinRange {
    /// The largest actuator force in magnitude (tension or compression).
    pub fn actuator_force_max(&self) -> f64 {
        self.actuator_min.iter().chain(&self.actuator_max).fold(0.0, |m, f| m.max(f.abs()))
    }
}

/// The Stewart platform model of one scene.
#[derive(Clone, Debug)]
pub struct Stewart {
    geometry: StewartGeometry,
    path: CirclePath,
    gravity: Vec3,
    hooke_axes: [Vec3; LEGS],
    joints: Joints,
    /// The 13 bodies in their own frames ([`StewartGeometry::body_frame_mass_properties`]).
    bodies: [MassProperties; BODIES],
    length_range: (f64, f64),
    /// The scene's `[control]`: the platform's motion comes from the measured cabin pose.
    compensation: Option<Compensation>,
}

impl Stewart {
    /// The model of a scene; with a `[control]` section the platform rests at its start point
    /// relative to the cabin unless the compensation moves it (`[motion]` is not used).
    pub fn from_scene(scene: &ValidScene) -> Result<Stewart, StewartError> {
        let mut motion = scene.motion.clone();
        if scene.control.is_some() {
            motion.speed_m_s = 0.0;
        }
        let mut stewart = Self::new(scene.stewart_geometry(), &motion, scene.gravity())?;
        let rest = stewart.path.at_rest();
        let legs = stewart.strokes_at(&rest, 0.0)?.map(|s| s.length);
        stewart.compensation = Some(Compensation::new(scene, rest.position, legs).map_err(StewartError::Design)?);
        Ok(stewart)
    }

    /// The compensation of the scene's `[control]` (a model built from a scene without one has an
    /// `off` compensation: the feed point is the platform centre, its target its start position).
    pub fn compensation(&self) -> Option<&Compensation> {
        self.compensation.as_ref()
    }

    /// The model for a geometry, a platform motion and gravity (world frame, the scene's
    /// [`feedcore::scene::Scene::gravity`]). Checks the whole prescribed motion (rest pose and first revolution)
    /// for leg lengths and singular poses.
    pub fn new(geometry: StewartGeometry, motion: &Motion, gravity: Vec3) -> Result<Stewart, StewartError> {
        if !gravity.iter().all(|g| g.is_finite()) {
            return Err(StewartError::Input { what: "gravity".into(), value: format!("{:?}", gravity.as_slice()) });
        }
        let path = CirclePath::new(geometry.nominal_center, motion);
        let hooke_axes = std::array::from_fn(|k| geometry.hooke_first_axis(k));
        let bodies = geometry.body_frame_mass_properties();
        let stewart = Stewart {
            joints: Joints::new(&geometry),
            length_range: geometry.leg_length_range(),
            gravity,
            path,
            hooke_axes,
            bodies,
            geometry,
            compensation: None,
        };
        stewart.check_path()?;
        Ok(stewart)
    }

    fn check_path(&self) -> Result<(), StewartError> {
        let mut times = vec![0.0];
        if let Some(end) = self.path.revolution_time() {
            times.extend((1..=PATH_CHECKS).map(|i| end * i as f64 / PATH_CHECKS as f64));
        }
        for t in times {
            let rel = self.relative(t)?;
            let platform = &rel.bodies[0];
            let j = kinematics::leg_jacobian(&self.geometry, &platform.position, &platform.orientation);
            let condition = kinematics::condition_number(&j);
            if condition.is_nan() || condition >= SINGULAR_CONDITION {
                return Err(StewartError::SingularPose { time: t, condition });
            }
        }
        Ok(())
    }

    pub fn geometry(&self) -> &StewartGeometry {
        &self.geometry
    }

    pub fn path(&self) -> &CirclePath {
        &self.path
    }

    pub fn joints(&self) -> &Joints {
        &self.joints
    }

    /// Gravity vector, world frame.
    pub fn gravity(&self) -> Vec3 {
        self.gravity
    }

    pub fn total_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.mass).sum()
    }

    /// Mass and inertia of the 13 bodies (platform, upper 1–6, lower 1–6) in their own frames,
    /// centre of mass at the origin. The platform frame is the cabin's at rest; a leg part's z
    /// axis is the leg axis.
    pub fn body_inertias(&self) -> &[MassProperties; BODIES] {
        &self.bodies
    }

    /// The motion of all bodies relative to the cabin at time `t`; fails if a leg leaves its
    /// stroke or lies along its Hooke axis.
    pub fn relative(&self, t: f64) -> Result<RelativeState, StewartError> {
        if !t.is_finite() {
            return Err(StewartError::Input { what: "time".into(), value: t.to_string() });
        }
        self.relative_at(&self.path.at(t), t)
    }

    /// The motion of all bodies relative to the cabin with the platform at `point`
    /// (cabin frame) at time `t`.
    pub fn relative_at(&self, point: &PathPoint, t: f64) -> Result<RelativeState, StewartError> {
        if !t.is_finite() {
            return Err(StewartError::Input { what: "time".into(), value: t.to_string() });
        }
        if !point.is_finite() {
            return Err(StewartError::Input {
                what: format!("platform command at t = {t} s"),
                value: format!("{point:?}"),
            });
        }
        self.checked(RelativeState::new(&self.leg_geometry(), point, t))
    }

    /// The relative state with the platform at rest at its start point.
    pub fn relative_at_rest(&self) -> Result<RelativeState, StewartError> {
        self.checked(RelativeState::new(&self.leg_geometry(), &self.path.at_rest(), 0.0))
    }

    /// Momentum of the platform's motion relative to the cabin at t = 0, cabin frame: linear
    /// `Σ m v` and angular about the cabin centre point `Σ (ρ × m v + I ω)`. Zero at rest and
    /// with a ramped start; with the abrupt path it is what the cabin must take up for a
    /// momentum-consistent start ([`feedcore::scene::Start::Consistent`]).
    pub fn start_momentum(&self) -> Result<Vector6<f64>, StewartError> {
        let rel = self.relative(0.0)?;
        let mut h = Vector6::zeros();
        for (body, inertia) in rel.bodies.iter().zip(&self.bodies) {
            let p = body.velocity * inertia.mass;
            let l = body.position.cross(&p) + body.inertia * body.angular_velocity;
            h += Vector6::new(p.x, p.y, p.z, l.x, l.y, l.z);
        }
        Ok(h)
    }

    fn checked(&self, rel: RelativeState) -> Result<RelativeState, StewartError> {
        self.check_legs(&rel.strokes, &rel.hooke_sine, rel.time)?;
        Ok(rel)
    }

    /// Every leg within its stroke and off its Hooke axis.
    fn check_legs(&self, strokes: &[Stroke; LEGS], hooke_sine: &[f64; LEGS], time: f64) -> Result<(), StewartError> {
        let (shortest, longest) = self.length_range;
        for k in 0..LEGS {
            let length = strokes[k].length;
            if !(shortest..=longest).contains(&length) {
                return Err(StewartError::LegLength { leg: k + 1, time, length, shortest, longest });
            }
            if hooke_sine[k].is_nan() || hooke_sine[k] <= HOOKE_SINGULAR_SINE {
                return Err(StewartError::HookeSingular { leg: k + 1, time, sin_angle: hooke_sine[k] });
            }
        }
        Ok(())
    }

    fn leg_geometry(&self) -> relative::LegGeometry<'_> {
        let g = &self.geometry;
        relative::LegGeometry {
            base_joints: &g.base_joints,
            platform_joints: &g.platform_joints,
            hooke_axes: &self.hooke_axes,
            bodies: &self.bodies,
            upper: &g.upper,
            lower: &g.lower,
        }
    }

    fn check_cabin(cabin: &CabinMotion) -> Result<(), StewartError> {
        match cabin.non_finite() {
            Some((name, value)) => Err(StewartError::Input { what: format!("cabin {name}"), value }),
            None => Ok(()),
        }
    }

    /// Wrench on the cabin at time `t` for the given cabin motion (momentum form; equal to the
    /// sum of the Hooke joint reactions of [`Stewart::evaluate`]).
    pub fn wrench(&self, cabin: &CabinMotion, t: f64) -> Result<Wrench, StewartError> {
        Self::check_cabin(cabin)?;
        Ok(self.relative(t)?.wrench(cabin, &self.gravity))
    }

    /// Wrench plus its exact Jacobians with respect to the cabin motion.
    pub fn wrench_with_jacobians(
        &self,
        cabin: &CabinMotion,
        t: f64,
    ) -> Result<(Wrench, WrenchJacobians), StewartError> {
        self.wrench_with_jacobians_at(cabin, &self.path.at(t), t)
    }

    /// [`Stewart::wrench_with_jacobians`] with the platform at `point` (cabin frame); the
    /// Jacobians are at fixed relative motion.
    pub fn wrench_with_jacobians_at(
        &self,
        cabin: &CabinMotion,
        point: &PathPoint,
        t: f64,
    ) -> Result<(Wrench, WrenchJacobians), StewartError> {
        self.wrench_with_jacobians_of(&self.relative_at(point, t)?, cabin)
    }

    /// [`Stewart::wrench`] with a relative state computed before ([`Stewart::relative_at`]).
    pub fn wrench_of(&self, rel: &RelativeState, cabin: &CabinMotion) -> Result<Wrench, StewartError> {
        Self::check_cabin(cabin)?;
        Ok(rel.wrench(cabin, &self.gravity))
    }

    /// [`Stewart::wrench_with_jacobians`] with a relative state computed before
    /// ([`Stewart::relative_at`]).
    pub fn wrench_with_jacobians_of(
        &self,
        rel: &RelativeState,
        cabin: &CabinMotion,
    ) -> Result<(Wrench, WrenchJacobians), StewartError> {
        Self::check_cabin(cabin)?;
        Ok(rel.wrench_with_jacobians(cabin, &self.gravity))
    }

    /// Wrench on a cabin at rest at the given pose with the platform at rest at its start point.
    pub fn static_wrench(&self, position: &Vec3, orientation: &Quat) -> Result<Wrench, StewartError> {
        let cabin = CabinMotion::at_rest(*position, *orientation);
        Self::check_cabin(&cabin)?;
        Ok(self.relative_at_rest()?.wrench(&cabin, &self.gravity))
    }

    /// World-frame motion of the 13 bodies (platform, upper 1–6, lower 1–6; positions are
    /// centres of mass) for the given cabin motion and relative state.
    pub fn place_bodies(&self, cabin: &CabinMotion, rel: &RelativeState) -> [RigidMotion; BODIES] {
        let rc = cabin.orientation.to_rotation_matrix().into_inner();
        let (w, al) = (cabin.angular_velocity, cabin.angular_acceleration);
        std::array::from_fn(|i| {
            let b = &rel.bodies[i];
            let (s, ds, dds) = (rc * b.position, rc * b.velocity, rc * b.acceleration);
            let (wr, dwr) = (rc * b.angular_velocity, rc * b.angular_acceleration);
            let orientation = Quat::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rc * b.orientation));
            RigidMotion {
                position: cabin.position + s,
                orientation,
                velocity: cabin.velocity + w.cross(&s) + ds,
                angular_velocity: w + wr,
                acceleration: cabin.acceleration + al.cross(&s) + w.cross(&w.cross(&s)) + w.cross(&ds) * 2.0 + dds,
                angular_acceleration: al + w.cross(&wr) + dwr,
            }
        })
    }

    /// The cabin and the 13 bodies placed consistently at time `t`, in the order of
    /// [`constraints`] (cabin at index [`CABIN`]).
    pub fn system_motion(&self, cabin: &CabinMotion, t: f64) -> Result<[RigidMotion; SYSTEM_BODIES], StewartError> {
        self.system_motion_at(cabin, &self.path.at(t), t)
    }

    /// [`Stewart::system_motion`] with the platform at `point` (cabin frame).
    pub(crate) fn system_motion_at(
        &self,
        cabin: &CabinMotion,
        point: &PathPoint,
        t: f64,
    ) -> Result<[RigidMotion; SYSTEM_BODIES], StewartError> {
        Self::check_cabin(cabin)?;
        let rel = self.relative_at(point, t)?;
        let bodies = self.place_bodies(cabin, &rel);
        Ok(std::array::from_fn(|i| if i == CABIN { *cabin } else { bodies[i] }))
    }

    /// Actuator strokes ℓ_k(t) (joint centre to joint centre) and their rates.
    pub fn strokes(&self, t: f64) -> Result<[Stroke; LEGS], StewartError> {
        if !t.is_finite() {
            return Err(StewartError::Input { what: "time".into(), value: t.to_string() });
        }
        self.strokes_at(&self.path.at(t), t)
    }

    /// Actuator strokes with the platform at `point` (cabin frame).
    pub fn strokes_at(&self, point: &PathPoint, t: f64) -> Result<[Stroke; LEGS], StewartError> {
        let (strokes, hooke_sine) = relative::strokes(&self.leg_geometry(), point);
        self.check_legs(&strokes, &hooke_sine, t)?;
        Ok(strokes)
    }

    /// All constraint equations at time `t` for the given system motion (see [`constraints`]).
    pub fn constraints(
        &self,
        bodies: &[RigidMotion; SYSTEM_BODIES],
        t: f64,
        rows: &mut [ConstraintRow; CONSTRAINTS],
    ) -> Result<(), StewartError> {
        let strokes = self.strokes(t)?;
        self.joints.evaluate(bodies, &strokes, rows);
        Ok(())
    }

    /// Joint reactions, actuator forces and platform motion at time `t` for the given cabin
    /// motion: Newton–Euler equations of the 13 bodies with Lagrange multipliers.
    pub fn evaluate(&self, cabin: &CabinMotion, t: f64) -> Result<Evaluation, StewartError> {
        self.evaluate_at(cabin, &self.path.at(t), t)
    }

    /// [`Stewart::evaluate`] with the platform at `point` (cabin frame).
    pub fn evaluate_at(&self, cabin: &CabinMotion, point: &PathPoint, t: f64) -> Result<Evaluation, StewartError> {
        let system = self.system_motion_at(cabin, point, t)?;
        let mut rows = [ConstraintRow::EMPTY; CONSTRAINTS];
        let strokes = self.strokes_at(point, t)?;
        self.joints.evaluate(&system, &strokes, &mut rows);
        let forces = std::array::from_fn(|i| {
            reactions::net_force(&system[i], self.bodies[i].mass, &self.bodies[i].inertia_com, &self.gravity)
        });
        let singular = || StewartError::SingularPose { time: t, condition: f64::INFINITY };
        let lambda = reactions::multipliers(&self.joints, &rows, &system, &forces).ok_or_else(singular)?;
        if lambda.iter().any(|l| !l.is_finite()) {
            return Err(singular());
        }
        Ok(Evaluation {
            time: t,
            wrench: reactions::cabin_wrench(&rows, &lambda),
            actuator_forces: std::array::from_fn(|k| lambda[constraints::ROWS_PER_LEG * k + constraints::DRIVING]),
            platform: system[constraints::PLATFORM],
            legs: std::array::from_fn(|k| reactions::leg_reactions(&self.joints, k, &rows, &lambda, &system)),
            multipliers: lambda,
            leg_lengths: strokes.map(|s| s.length),
        })
    }

    /// Fixed-cabin mode (the paper's refs. [2, 3]): evaluations at the given times with the
    /// cabin held at rest at the given pose.
    pub fn fixed_cabin(
        &self,
        position: &Vec3,
        orientation: &Quat,
        times: impl IntoIterator<Item = f64>,
    ) -> Result<Vec<Evaluation>, StewartError> {
        let cabin = CabinMotion::at_rest(*position, *orientation);
        times.into_iter().map(|t| self.evaluate(&cabin, t)).collect()
    }

    /// Fixed-cabin mode over the platform's first revolution, from t = 0 (start included),
    /// sampled at most `dt` apart: the extremes of the wrench and of the actuator forces.
    pub fn fixed_cabin_range(
        &self,
        position: &Vec3,
        orientation: &Quat,
        dt: f64,
    ) -> Result<FixedCabinRange, StewartError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(StewartError::Input { what: "sampling interval".into(), value: dt.to_string() });
        }
        let duration = self.path.revolution_time().unwrap_or(0.0);
        let steps = (duration / dt).ceil() as usize;
        let cabin = CabinMotion::at_rest(*position, *orientation);
        let mut range = FixedCabinRange {
            duration,
            samples: steps + 1,
            wrench_min: Vector6::repeat(f64::INFINITY),
            wrench_max: Vector6::repeat(f64::NEG_INFINITY),
            actuator_min: [f64::INFINITY; LEGS],
            actuator_max: [f64::NEG_INFINITY; LEGS],
        };
        for i in 0..=steps {
            let t = if steps == 0 { 0.0 } else { duration * i as f64 / steps as f64 };
            let e = self.evaluate(&cabin, t)?;
            let w = e.wrench.to_vector();
            range.wrench_min = range.wrench_min.inf(&w);
            range.wrench_max = range.wrench_max.sup(&w);
            for k in 0..LEGS {
                range.actuator_min[k] = range.actuator_min[k].min(e.actuator_forces[k]);
                range.actuator_max[k] = range.actuator_max[k].max(e.actuator_forces[k]);
            }
        }
        Ok(range)
    }
}
