//! Inverse and forward kinematics of the Stewart platform relative to the cabin (cabin frame).
//!
//! A platform pose is its centre `c` and its orientation `R` (platform to cabin frame). Leg k runs
//! from base joint `B_k` to `c + R P_k`. Small pose changes are (δc, δθ) with `R' = exp([δθ]×) R`.

use feedcore::rigid::exp_so3;
use feedcore::scene::LEGS;
use feedcore::stewart_geometry::StewartGeometry;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Matrix6, Vector6};

use crate::StewartError;

/// Leg lengths (joint centre to joint centre) of a platform pose: the inverse kinematics.
pub fn leg_lengths(geometry: &StewartGeometry, center: &Vec3, rotation: &Mat3) -> [f64; LEGS] {
    std::array::from_fn(|k| (center + rotation * geometry.platform_joints[k] - geometry.base_joints[k]).norm())
}

/// ∂ℓ/∂(δc, δθ): row k is (u_k, (R P_k) × u_k). Its transpose maps the six leg tensions to the
/// wrench the legs exert on the platform (about its centre), with a minus sign.
pub(crate) fn leg_jacobian(geometry: &StewartGeometry, center: &Vec3, rotation: &Mat3) -> Matrix6<f64> {
    let mut j = Matrix6::zeros();
    for k in 0..LEGS {
        let arm = rotation * geometry.platform_joints[k];
        let u = (center + arm - geometry.base_joints[k]).normalize();
        let m = arm.cross(&u);
        j.set_row(k, &nalgebra::RowVector6::new(u.x, u.y, u.z, m.x, m.y, m.z));
    }
    j
}

/// Ratio of the largest to the smallest singular value (∞ when singular).
pub(crate) fn condition_number(j: &Matrix6<f64>) -> f64 {
    let s = j.singular_values();
    let (max, min) = (s.max(), s.min());
    if min > 0.0 { max / min } else { f64::INFINITY }
}

/// The platform pose with the given leg lengths (forward kinematics), by Newton's method on the
/// six lengths from the pose `guess`. Converges to the pose on the branch of `guess`.
pub fn forward_kinematics(
    geometry: &StewartGeometry,
    lengths: &[f64; LEGS],
    guess: (Vec3, Quat),
) -> Result<(Vec3, Quat), StewartError> {
    const MAX_ITERATIONS: usize = 50;
    let (mut center, mut rotation) = guess;
    let scale = lengths.iter().fold(1.0_f64, |m, l| m.max(l.abs()));
    let mut residual = f64::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let r = rotation.to_rotation_matrix().into_inner();
        let now = leg_lengths(geometry, &center, &r);
        let error = Vector6::from_fn(|k, _| lengths[k] - now[k]);
        let previous = residual;
        residual = error.amax();
        // Done when at rounding level, or when Newton stops improving near it.
        if residual <= 4.0 * f64::EPSILON * scale || (residual < 1e-10 * scale && residual >= previous) {
            return Ok((center, rotation));
        }
        let step = leg_jacobian(geometry, &center, &r)
            .lu()
            .solve(&error)
            .ok_or(StewartError::ForwardKinematics { iterations: MAX_ITERATIONS, residual })?;
        center += step.fixed_rows::<3>(0);
        rotation = exp_so3(&step.fixed_rows::<3>(3).into_owned()) * rotation;
    }
    Err(StewartError::ForwardKinematics { iterations: MAX_ITERATIONS, residual })
}
