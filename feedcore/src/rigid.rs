//! Rigid-body math: rotations on SO(3) without singularities, and mass properties.
//!
//! Rotations are unit quaternions (body to world). Small rotations are world-frame rotation
//! vectors `θ`, composed on the left: `R' = exp([θ]×) R`.

use crate::{Mat3, Quat, Vec3};

/// The cross-product matrix: `skew(a) * b == a × b`.
pub fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// `exp([θ]×)` as a unit quaternion.
pub fn exp_so3(theta: &Vec3) -> Quat {
    let t2 = theta.norm_squared();
    if t2 < 1e-6 {
        // |θ| < 1e-3 (every time step's increment): the series of cos(θ/2) and sin(θ/2)/θ to
        // the terms in θ⁶ is exact to round-off there, and needs no sine, cosine or root.
        let h = 0.25 * t2;
        let w = 1.0 - h * (0.5 - h * (1.0 / 24.0 - h / 720.0));
        let s = 0.5 * (1.0 - h * (1.0 / 6.0 - h * (1.0 / 120.0 - h / 5040.0)));
        return Quat::new_unchecked(nalgebra::Quaternion::new(w, s * theta.x, s * theta.y, s * theta.z));
    }
    Quat::from_scaled_axis(*theta)
}

/// Left Jacobian of SO(3): `exp([θ + δ]×) = exp([J(θ) δ]×) exp([θ]×) + O(δ²)`.
///
/// It maps a change of a world-frame rotation vector to the world-frame rotation it causes.
pub fn left_jacobian_so3(theta: &Vec3) -> Mat3 {
    let t2 = theta.norm_squared();
    let k = skew(theta);
    // Series below 1e-4 rad keep full precision (the closed form cancels catastrophically).
    let (a, b) = if t2 < 1e-8 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        let t = t2.sqrt();
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    Mat3::identity() + k * a + k * k * b
}

/// `∂(a × F)/∂θ` for a force `F` fixed in the world acting at an arm `a` that turns with the
/// body (`δa = δθ × a`): `[F]× [a]×`. The rotational stiffness of every load on a turning arm
/// (the cable ends on the cabin, a weight about a point other than its centre of mass).
pub fn turning_arm_stiffness(force: &Vec3, arm: &Vec3) -> Mat3 {
    skew(force) * skew(arm)
}

/// The world rotation vector `δθ` that a change `dq` of a quaternion's components `q` makes to
/// the rotation of `q / |q|` (the components need not be normalized):
/// `δθ = 2 vec(δn ⊗ n*)` with `n = q / |q|`, `δn = (dq − n (n·dq)) / |q|`.
pub fn rotation_of_quaternion_change(q: &nalgebra::Quaternion<f64>, dq: &nalgebra::Quaternion<f64>) -> Vec3 {
    let s = q.norm();
    let n = q / s;
    let dn = (dq - n * n.coords.dot(&dq.coords)) / s;
    (dn * n.conjugate()).imag() * 2.0
}

/// A small change of a rigid body's motion ([`RigidMotion`]), world frame; `rotation` is a world
/// rotation vector (`R' = exp([δθ]×) R`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotionChange {
    pub position: Vec3,
    pub rotation: Vec3,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
    pub acceleration: Vec3,
    pub angular_acceleration: Vec3,
}

/// The change of a quaternion's components `q` under a small world rotation `δθ`:
/// `δq = ½ [0, δθ] ⊗ q`.
pub fn quaternion_change(rotation: &Vec3, q: &nalgebra::Quaternion<f64>) -> nalgebra::Quaternion<f64> {
    nalgebra::Quaternion::from_imag(rotation * 0.5) * q
}

/// Mass, centre of mass and inertia (about the centre of mass) of a rigid body or a rigid
/// assembly, all expressed in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProperties {
    pub mass: f64,
    pub com: Vec3,
    pub inertia_com: Mat3,
}

impl MassProperties {
    pub const ZERO: Self = Self {
        mass: 0.0,
        com: Vec3::new(0.0, 0.0, 0.0),
        inertia_com: Mat3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    };

    pub fn point(mass: f64, at: Vec3) -> Self {
        Self { mass, com: at, inertia_com: Mat3::zeros() }
    }

    /// A body whose inertia about its centre of mass is `inertia_body` in its own frame,
    /// placed with orientation `rotation` and centre of mass at `com`.
    pub fn body(mass: f64, com: Vec3, rotation: &Mat3, inertia_body: &Mat3) -> Self {
        Self { mass, com, inertia_com: rotation * inertia_body * rotation.transpose() }
    }

    /// The wrench of the body's weight (force; moment about the frame's origin; world frame) when
    /// the frame is turned to `orientation` (body to world) under `gravity`.
    pub fn weight_wrench(&self, orientation: &Quat, gravity: &Vec3) -> nalgebra::Vector6<f64> {
        let f = gravity * self.mass;
        let m = (orientation * self.com).cross(&f);
        nalgebra::Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)
    }

    /// Inertia about `point` (parallel-axis theorem).
    pub(crate) fn inertia_about(&self, point: &Vec3) -> Mat3 {
        let d = self.com - point;
        self.inertia_com + (Mat3::identity() * d.norm_squared() - d * d.transpose()) * self.mass
    }

    /// The same body seen in another frame: `x_new = rotation · x + translation`.
    pub fn transformed(&self, rotation: &Mat3, translation: &Vec3) -> Self {
        Self {
            mass: self.mass,
            com: rotation * self.com + translation,
            inertia_com: rotation * self.inertia_com * rotation.transpose(),
        }
    }

    /// Rigid union of two bodies.
    pub fn combined(&self, other: &Self) -> Self {
        let mass = self.mass + other.mass;
        if mass == 0.0 {
            return Self::ZERO;
        }
        let com = (self.com * self.mass + other.com * other.mass) / mass;
        let inertia_com = self.inertia_about(&com) + other.inertia_about(&com);
        Self { mass, com, inertia_com }
    }

    /// The 6×6 spatial mass matrix about `point`, rows and columns (translation, rotation),
    /// for velocities (velocity of `point`, angular velocity): kinetic energy ½ vᵀ M v.
    pub fn spatial_matrix_about(&self, point: &Vec3) -> nalgebra::Matrix6<f64> {
        let c = skew(&(self.com - point)) * self.mass;
        let mut m = nalgebra::Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Mat3::identity() * self.mass));
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-c));
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&c);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.inertia_about(point));
        m
    }
}

impl std::iter::Sum for MassProperties {
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        iter.fold(Self::ZERO, |acc, b| acc.combined(&b))
    }
}

/// Inertial and gravitational terms of one rigid body in the equations of motion, written about
/// a reference point O of the body (not necessarily its centre of mass), with world-frame
/// velocity-level coordinates: the velocity of O, the angular velocity ω, and rotations
/// `R' = exp([δθ]×) R`. The body's contribution to the residual `M v̇ + g − f` is
///
/// ```text
/// force:  m (a + α × c + ω × (ω × c)) − m g
/// moment: J_O α + m c × a + ω × (J_O ω) − c × m g
/// ```
///
/// with c the vector from O to the centre of mass and J_O the inertia about O (both world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyTerms {
    /// Residual contribution (force; moment about O).
    pub residual: nalgebra::Vector6<f64>,
    /// ∂residual/∂(a, α): the mass matrix about O.
    pub mass: nalgebra::Matrix6<f64>,
    /// ∂residual/∂(v, ω): gyroscopic terms.
    pub gyroscopic: nalgebra::Matrix6<f64>,
    /// ∂residual/∂(δr, δθ): only rotations act (through c and J_O).
    pub stiffness: nalgebra::Matrix6<f64>,
}

impl BodyTerms {
    /// `body`: mass properties in the world frame (centre of mass and inertia already rotated);
    /// `origin`: the reference point O (world); `omega`, `accel` (of O), `alpha`: world frame.
    pub fn new(
        body: &MassProperties,
        origin: &Vec3,
        omega: &Vec3,
        accel: &Vec3,
        alpha: &Vec3,
        gravity: &Vec3,
    ) -> BodyTerms {
        let residual = Self::residual(body, origin, omega, accel, alpha, gravity);
        let m = body.mass;
        let c = body.com - origin;
        let jo = body.inertia_about(origin);
        let (sc, sw, sa, sal) = (skew(&c), skew(omega), skew(accel), skew(alpha));
        let jw = jo * omega;
        let mg = gravity * m;
        let mut mass = nalgebra::Matrix6::zeros();
        mass.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Mat3::identity() * m));
        mass.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-sc * m));
        mass.fixed_view_mut::<3, 3>(3, 0).copy_from(&(sc * m));
        mass.fixed_view_mut::<3, 3>(3, 3).copy_from(&jo);
        let mut gyroscopic = nalgebra::Matrix6::zeros();
        gyroscopic.fixed_view_mut::<3, 3>(0, 3).copy_from(&((-skew(&omega.cross(&c)) - sw * sc) * m));
        gyroscopic.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-skew(&jw) + sw * jo));
        // a rotation δθ turns c into c + δθ × c and J_O into J_O + [δθ]× J_O − J_O [δθ]×
        let mut stiffness = nalgebra::Matrix6::zeros();
        stiffness.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-(sal + sw * sw) * sc * m));
        let krr = -skew(&(jo * alpha))
            + jo * sal
            + sa * sc * m
            + sw * (jo * sw - skew(&jw))
            + turning_arm_stiffness(&-mg, &c);
        stiffness.fixed_view_mut::<3, 3>(3, 3).copy_from(&krr);
        BodyTerms { residual, mass, gyroscopic, stiffness }
    }
}

impl BodyTerms {
    /// The residual contribution alone (force; moment about O), for Newton iterations that
    /// keep their matrix; arguments as for [`BodyTerms::new`].
    pub fn residual(
        body: &MassProperties,
        origin: &Vec3,
        omega: &Vec3,
        accel: &Vec3,
        alpha: &Vec3,
        gravity: &Vec3,
    ) -> nalgebra::Vector6<f64> {
        let m = body.mass;
        let c = body.com - origin;
        let jo = body.inertia_about(origin);
        let jw = jo * omega;
        let mg = gravity * m;
        let f = accel * m + alpha.cross(&c) * m + omega.cross(&omega.cross(&c)) * m - mg;
        let t = jo * alpha + c.cross(accel) * m + omega.cross(&jw) - c.cross(&mg);
        nalgebra::Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
    }
}

/// Pose, velocity and acceleration of a rigid body; all vectors in the world frame. `position`
/// is the body's reference point: the centre of mass of a Stewart body, the centre point of the
/// cabin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    pub position: Vec3,
    /// Body to world.
    pub orientation: Quat,
    pub velocity: Vec3,
    pub angular_velocity: Vec3,
    pub acceleration: Vec3,
    pub angular_acceleration: Vec3,
}

impl RigidMotion {
    pub fn at_rest(position: Vec3, orientation: Quat) -> Self {
        Self {
            position,
            orientation,
            velocity: Vec3::zeros(),
            angular_velocity: Vec3::zeros(),
            acceleration: Vec3::zeros(),
            angular_acceleration: Vec3::zeros(),
        }
    }

    /// The first field that is not finite, as (name, value).
    pub fn non_finite(&self) -> Option<(&'static str, String)> {
        let q = self.orientation.coords;
        let fields: [(&str, &[f64]); 6] = [
            ("position", self.position.as_slice()),
            ("orientation", q.as_slice()),
            ("velocity", self.velocity.as_slice()),
            ("angular_velocity", self.angular_velocity.as_slice()),
            ("acceleration", self.acceleration.as_slice()),
            ("angular_acceleration", self.angular_acceleration.as_slice()),
        ];
        fields.into_iter().find(|(_, v)| v.iter().any(|x| !x.is_finite())).map(|(n, v)| (n, format!("{v:?}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn exponential_of_small_rotations_matches_the_closed_form() {
        for scale in [0.0, 1e-12, 1e-8, 1e-5, 3e-4, 9.9e-4, 1.1e-3, 0.3] {
            let theta = Vec3::new(0.6, -0.48, 0.64) * scale;
            let q = exp_so3(&theta);
            let r = Quat::from_scaled_axis(theta);
            assert!((q.coords - r.coords).amax() <= 2e-16, "|θ| = {scale}: {q:?} against {r:?}");
            assert!((q.coords.norm() - 1.0).abs() <= 2e-16);
        }
    }

    #[test]
    fn left_jacobian_matches_finite_differences() {
        for theta in [Vec3::new(0.3, -0.2, 0.7), Vec3::new(1e-6, 2e-6, -1e-6), Vec3::new(2.5, 0.1, -0.4)] {
            let j = left_jacobian_so3(&theta);
            let r0 = exp_so3(&theta);
            let eps = 1e-6;
            for k in 0..3 {
                let mut d = Vec3::zeros();
                d[k] = eps;
                let rp = exp_so3(&(theta + d));
                let rm = exp_so3(&(theta - d));
                // world-frame rotation from r0 to rp, and to rm
                let wp = (rp * r0.inverse()).scaled_axis();
                let wm = (rm * r0.inverse()).scaled_axis();
                let col = (wp - wm) / (2.0 * eps);
                assert_relative_eq!(col, j.column(k).into_owned(), epsilon = 1e-8);
            }
        }
    }

    #[test]
    fn parallel_axis_and_spatial_matrix_agree_with_point_masses() {
        // Two point masses on a rod: inertia about the midpoint is 2·m·(L/2)² transverse.
        let a = MassProperties::point(3.0, Vec3::new(1.0, 0.0, 0.0));
        let b = MassProperties::point(3.0, Vec3::new(-1.0, 0.0, 0.0));
        let ab = a.combined(&b);
        assert_relative_eq!(ab.com, Vec3::zeros());
        assert_relative_eq!(ab.inertia_com, Mat3::from_diagonal(&Vec3::new(0.0, 6.0, 6.0)), epsilon = 1e-14);
        // Kinetic energy from the spatial matrix equals the sum over the points.
        let p = Vec3::new(0.2, -0.4, 0.9);
        let (v, w) = (Vec3::new(0.3, 0.1, -0.2), Vec3::new(0.5, -0.7, 0.2));
        let m6 = ab.spatial_matrix_about(&p);
        let mut x = nalgebra::Vector6::zeros();
        x.fixed_rows_mut::<3>(0).copy_from(&v);
        x.fixed_rows_mut::<3>(3).copy_from(&w);
        let ke6 = 0.5 * x.dot(&(m6 * x));
        let ke_points: f64 = [a, b].iter().map(|q| 0.5 * q.mass * (v + w.cross(&(q.com - p))).norm_squared()).sum();
        assert_relative_eq!(ke6, ke_points, epsilon = 1e-12);
    }
}
