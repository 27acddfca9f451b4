//! First-order changes of the model's outputs under a small change of the cabin's motion, the
//! platform's motion relative to the cabin held (as within one communication step): what
//! directional derivatives of the wrench, the actuator forces, the platform's pose and the feed's
//! error are made of.

use feedcore::Vec3;
use feedcore::rigid::{MotionChange, RigidMotion, left_jacobian_so3, quaternion_change, skew};
use feedcore::scene::LEGS;
use nalgebra::{Matrix3x6, Quaternion, Vector6};

use crate::{CabinMotion, Compensation, PathPoint, Stewart, StewartError, WrenchJacobians};

fn stack(a: Vec3, b: Vec3) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

impl WrenchJacobians {
    /// The wrench's change.
    pub fn change(&self, d: &MotionChange) -> Vector6<f64> {
        self.pose * stack(d.position, d.rotation)
            + self.velocity * stack(d.velocity, d.angular_velocity)
            + self.acceleration * stack(d.acceleration, d.angular_acceleration)
    }
}

/// Rates of the actuator forces: row k is ∂/∂(component k), column j actuator j; world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActuatorRates {
    pub acceleration: Matrix3x6<f64>,
    pub angular_acceleration: Matrix3x6<f64>,
    pub angular_velocity: Matrix3x6<f64>,
}

impl Stewart {
    /// ∂(actuator forces)/∂(a, α, ω) of the cabin (world frame) with the platform at
    /// `point`, exact: the Newton–Euler equations make the forces linear in (a, α) and quadratic
    /// in ω, so unit differences (central for ω) are the derivatives.
    pub fn actuator_rates_at(
        &self,
        cabin: &CabinMotion,
        point: &PathPoint,
        t: f64,
    ) -> Result<ActuatorRates, StewartError> {
        let forces = |c: &CabinMotion| self.evaluate_at(c, point, t).map(|e| e.actuator_forces);
        let base = forces(cabin)?;
        let mut r = ActuatorRates {
            acceleration: Matrix3x6::zeros(),
            angular_acceleration: Matrix3x6::zeros(),
            angular_velocity: Matrix3x6::zeros(),
        };
        for k in 0..3 {
            let mut c = *cabin;
            c.acceleration[k] += 1.0;
            let fa = forces(&c)?;
            let mut c = *cabin;
            c.angular_acceleration[k] += 1.0;
            let fal = forces(&c)?;
            let (mut cp, mut cm) = (*cabin, *cabin);
            cp.angular_velocity[k] += 1.0;
            cm.angular_velocity[k] -= 1.0;
            let (fp, fm) = (forces(&cp)?, forces(&cm)?);
            for j in 0..LEGS {
                r.acceleration[(k, j)] = fa[j] - base[j];
                r.angular_acceleration[(k, j)] = fal[j] - base[j];
                r.angular_velocity[(k, j)] = 0.5 * (fp[j] - fm[j]);
            }
        }
        Ok(r)
    }
}

impl ActuatorRates {
    /// The actuator forces' change. A rotation acts by turning the cabin-frame components of
    /// the acceleration against gravity, the angular acceleration and the angular velocity.
    pub fn change(&self, cabin: &CabinMotion, gravity: &Vec3, d: &MotionChange) -> Vector6<f64> {
        let th_a = skew(&(cabin.acceleration - gravity)) * d.rotation;
        let th_al = skew(&cabin.angular_acceleration) * d.rotation;
        let th_w = skew(&cabin.angular_velocity) * d.rotation;
        self.acceleration.transpose() * (d.acceleration + th_a)
            + self.angular_acceleration.transpose() * (d.angular_acceleration + th_al)
            + self.angular_velocity.transpose() * (d.angular_velocity + th_w)
    }
}

/// The change of the platform's pose carried rigidly by the cabin (centre point at
/// `cabin_position`): its position's and its orientation quaternion's (w, x, y, z).
pub fn carried_pose_change(cabin_position: &Vec3, platform: &RigidMotion, d: &MotionChange) -> (Vec3, Quaternion<f64>) {
    let arm = platform.position - cabin_position;
    let q = platform.orientation.into_inner();
    (d.position + d.rotation.cross(&arm), quaternion_change(&d.rotation, &q))
}

impl Compensation {
    /// The change of the feed's error ([`Compensation::feed_error`]) at time `t` when the cabin
    /// (centre point at `cabin_position`) carries the platform rigidly: the position error's and
    /// the rotation vector's, which a world rotation δθ moves by `J(φ)⁻¹ δθ` (J the left
    /// Jacobian of SO(3) at the rotation φ).
    pub fn feed_error_change(
        &self,
        cabin_position: &Vec3,
        platform: &RigidMotion,
        t: f64,
        d: &MotionChange,
    ) -> Result<(Vec3, Vec3), StewartError> {
        let feed = platform.position + platform.orientation * self.feed_point();
        let (_, phi) = self.feed_error(&platform.position, &platform.orientation, t);
        let jinv = left_jacobian_so3(&phi).try_inverse().ok_or(StewartError::FeedRotationAtPi { time: t })?;
        Ok((d.position + d.rotation.cross(&(feed - cabin_position)), jinv * d.rotation))
    }
}
