//! Joint reactions and actuator forces: the Lagrange multipliers of eq. (5) for the 13 moving
//! bodies, `Φ_qᵀ λ = f − M v̇` (78 equations, 78 multipliers; the accelerations are known).
//!
//! Solved leg by leg. The two rigid rotations of a leg about its Hooke axes (cabin held) satisfy
//! every internal constraint of the leg, so projecting the leg's equations on them leaves only the
//! spherical-joint multipliers (virtual work). Two such equations per leg and the platform's six
//! determine the 18 spherical multipliers; then each lower part gives its prismatic and driving
//! multipliers (6×6), and each upper part its Hooke multipliers (6×4, consistent).

use feedcore::Vec3;
use feedcore::scene::LEGS;
use feedcore::stewart_geometry::BODIES;
use nalgebra::{Matrix4, Matrix6, SMatrix, SVector, Vector4, Vector6};

use crate::constraints::{
    CABIN, CONSTRAINTS, ConstraintRow, DRIVING, HOOKE_POSITION, HOOKE_ROTATION, Joints, PLATFORM,
    PRISMATIC_TRANSLATION, ROWS_PER_LEG, SPHERICAL, SYSTEM_BODIES, lower, upper,
};
use crate::wrench::{RigidMotion, Wrench};

/// Reactions in one leg; world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LegReactions {
    /// Force and moment of the cabin on the upper part at the Hooke centre.
    pub hooke_force: Vec3,
    pub hooke_moment: Vec3,
    /// Force of the upper part on the lower part, actuator force included, and its moment about
    /// the spherical joint centre.
    pub prismatic_force: Vec3,
    pub prismatic_moment: Vec3,
    /// Force of the lower part on the platform.
    pub spherical_force: Vec3,
}

/// Generalized applied-minus-inertia force `f − M v̇` of a body of mass `m` and body-frame
/// inertia `j`: (m (g − a), −(J α + ω × J ω)), world frame.
pub(crate) fn net_force(body: &RigidMotion, m: f64, j: &feedcore::Mat3, gravity: &Vec3) -> Vector6<f64> {
    let r = body.orientation.to_rotation_matrix().into_inner();
    let jw = r * j * r.transpose();
    let w = &body.angular_velocity;
    let f = (gravity - body.acceleration) * m;
    let t = -(jw * body.angular_acceleration + w.cross(&(jw * w)));
    Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
}

/// Multipliers λ for the constraint rows (from [`crate::constraints::Joints::evaluate`]) and the
/// generalized forces `f − M v̇` of the 13 moving bodies; `None` if the pose is singular.
pub(crate) fn multipliers(
    joints: &Joints,
    rows: &[ConstraintRow; CONSTRAINTS],
    bodies: &[RigidMotion; SYSTEM_BODIES],
    forces: &[Vector6<f64>; BODIES],
) -> Option<[f64; CONSTRAINTS]> {
    let leg_rows = |k: usize| &rows[ROWS_PER_LEG * k..ROWS_PER_LEG * (k + 1)];
    // Spherical rows link (lower, platform): block 0 is the lower part's, 1 the platform's.
    let mut a = SMatrix::<f64, 18, 18>::zeros();
    let mut rhs = SVector::<f64, 18>::zeros();
    for k in 0..LEGS {
        let rows = leg_rows(k);
        let (hooke, axes) = joints.hooke(k, &bodies[CABIN], &bodies[upper(k)]);
        for (n, axis) in axes.iter().enumerate() {
            let rigid = |body: &RigidMotion| {
                let v = axis.cross(&(body.position - hooke));
                Vector6::new(v.x, v.y, v.z, axis.x, axis.y, axis.z)
            };
            let (nu, nd) = (rigid(&bodies[upper(k)]), rigid(&bodies[lower(k)]));
            for j in 0..3 {
                a[(2 * k + n, 3 * k + j)] = rows[SPHERICAL + j].jacobian[0].dot(&nd);
            }
            rhs[2 * k + n] = nu.dot(&forces[upper(k)]) + nd.dot(&forces[lower(k)]);
        }
        for j in 0..3 {
            let col = rows[SPHERICAL + j].jacobian[1];
            for m in 0..6 {
                a[(12 + m, 3 * k + j)] = col[m];
            }
        }
    }
    rhs.fixed_rows_mut::<6>(12).copy_from(&forces[PLATFORM]);
    let sigma = a.lu().solve(&rhs)?;

    let mut lambda = [0.0; CONSTRAINTS];
    for k in 0..LEGS {
        let rows = leg_rows(k);
        let lam = &mut lambda[ROWS_PER_LEG * k..ROWS_PER_LEG * (k + 1)];
        let mut q_lower = forces[lower(k)];
        for j in 0..3 {
            lam[SPHERICAL + j] = sigma[3 * k + j];
            q_lower -= rows[SPHERICAL + j].jacobian[0] * sigma[3 * k + j];
        }
        // Lower part: prismatic (5) and driving (1) rows, contiguous; block 1 is the lower part's.
        let slide = PRISMATIC_TRANSLATION..=DRIVING;
        let m_lower =
            Matrix6::from_columns(&std::array::from_fn::<_, 6, _>(|n| rows[PRISMATIC_TRANSLATION + n].jacobian[1]));
        let slide_lambda = m_lower.lu().solve(&q_lower)?;
        let mut q_upper = forces[upper(k)];
        for (n, r) in slide.enumerate() {
            lam[r] = slide_lambda[n];
            q_upper -= rows[r].jacobian[0] * slide_lambda[n];
        }
        // Upper part: Hooke rows (cabin, upper); block 1 is the upper part's. Least squares on a
        // consistent 6×4 system through the normal equations.
        let g = SMatrix::<f64, 6, 4>::from_columns(&std::array::from_fn::<_, 4, _>(|n| {
            rows[HOOKE_POSITION + n].jacobian[1]
        }));
        let normal: Matrix4<f64> = g.transpose() * g;
        let hooke: Vector4<f64> = normal.cholesky()?.solve(&(g.transpose() * q_upper));
        lam[HOOKE_POSITION..HOOKE_POSITION + 4].copy_from_slice(hooke.as_slice());
    }
    Some(lambda)
}

/// The wrench on the cabin from the multipliers: −Σ λ Φ_q(cabin)ᵀ over the Hooke rows.
pub(crate) fn cabin_wrench(rows: &[ConstraintRow; CONSTRAINTS], lambda: &[f64; CONSTRAINTS]) -> Wrench {
    let mut w = Vector6::zeros();
    for (row, l) in rows.iter().zip(lambda) {
        for n in 0..2 {
            if row.bodies[n] == CABIN {
                w -= row.jacobian[n] * *l;
            }
        }
    }
    Wrench::from_vector(&w)
}

/// The reactions in leg `k` from the multipliers.
pub(crate) fn leg_reactions(
    joints: &Joints,
    k: usize,
    rows: &[ConstraintRow; CONSTRAINTS],
    lambda: &[f64; CONSTRAINTS],
    bodies: &[RigidMotion; SYSTEM_BODIES],
) -> LegReactions {
    let base = ROWS_PER_LEG * k;
    let (rows, lam) = (&rows[base..base + ROWS_PER_LEG], &lambda[base..base + ROWS_PER_LEG]);
    let vec = |at: usize| Vec3::new(lam[at], lam[at + 1], lam[at + 2]);
    // A row's reaction on a body is −λ·(its Jacobian block); for the Hooke rotation row that
    // block of the upper part is (y × a, a pure moment).
    let hooke_rotation = &rows[HOOKE_ROTATION];
    let hooke_moment = -hooke_rotation.jacobian[1].fixed_rows::<3>(3) * lam[HOOKE_ROTATION];
    let mut slide = Vector6::zeros();
    for r in PRISMATIC_TRANSLATION..=DRIVING {
        slide -= rows[r].jacobian[1] * lam[r];
    }
    let force: Vec3 = slide.fixed_rows::<3>(0).into_owned();
    let lower_body = &bodies[lower(k)];
    let arm = lower_body.position - joints.sphere_center(k, lower_body);
    LegReactions {
        hooke_force: vec(HOOKE_POSITION),
        hooke_moment,
        prismatic_force: force,
        prismatic_moment: slide.fixed_rows::<3>(3) + arm.cross(&force),
        spherical_force: vec(SPHERICAL),
    }
}
