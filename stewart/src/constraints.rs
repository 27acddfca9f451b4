//! The joint constraints of the Stewart platform with the cabin as a body (paper eqs. 4–6).
//!
//! Coordinates: every body's pose is absolute (world frame): the position of its reference point
//! (centre of mass; the cabin centre point for the cabin) and its orientation (body to world).
//! Velocity-level coordinates per body are (δr, δθ), world frame, with `R' = exp([δθ]×) R`;
//! velocities are (v, ω). Each scalar equation links two bodies and carries
//!
//! * `value` Φ(q, t),
//! * `jacobian` Φ_q, one 1×6 block per body (columns δr, δθ),
//! * `time_derivative` Φ_t, so that `Φ_q v + Φ_t = 0` on a consistent motion,
//! * `gamma` γ of eq. (6): `Φ_q v̇ = γ` with v̇ = (a, α) (for these holonomic, scleronomic-in-q
//!   equations γ = −(dΦ_q/dt)·v − Φ_tt).
//!
//! Body frames: the platform frame is parallel to the cabin frame when the platform rests at its
//! start pose; a leg part's z axis runs along the leg from the Hooke centre to the spherical
//! joint centre and its y axis is the second Hooke axis.
//!
//! Per leg k (rows `ROWS_PER_LEG·k + offset`), with u, d the upper and lower part:
//!
//! | offset | rows | joint | equation |
//! |---|---|---|---|
//! | [`HOOKE_POSITION`] | 3 | Hooke centre | p(cabin) − p(u) = 0 |
//! | [`HOOKE_ROTATION`] | 1 | Hooke cross | a(cabin) · y(u) = 0 |
//! | [`PRISMATIC_TRANSLATION`] | 2 | actuator slide | x(u)·δ = 0, y(u)·δ = 0, δ = p_sphere(d) − p_hooke(u) |
//! | [`PRISMATIC_ROTATION`] | 3 | actuator, no twist | y(u)·z(d) = 0, z(u)·x(d) = 0, x(u)·y(d) = 0 |
//! | [`DRIVING`] | 1 | actuator stroke | z(u)·δ − ℓ_k(t) = 0 |
//! | [`SPHERICAL`] | 3 | spherical | p(d) − p(platform) = 0 |
//!
//! Signs: the multiplier λ of a row puts the generalized force −λ·Φ_qᵀ on its bodies. Hence the
//! multipliers of the Hooke and spherical position rows are the force of the cabin on the upper
//! part and of the lower part on the platform, and the driving multiplier is the actuator
//! tension (positive when the actuator pulls the platform towards the cabin).

use feedcore::scene::LEGS;
use feedcore::stewart_geometry::{BODIES, StewartGeometry};
use feedcore::{Mat3, Vec3};
use nalgebra::Vector6;

use crate::relative::Stroke;
use crate::wrench::RigidMotion;

/// Index of the cabin in a system of [`SYSTEM_BODIES`] bodies; the Stewart bodies keep their
/// order (platform, upper parts 1–6, lower parts 1–6).
pub const CABIN: usize = BODIES;
pub const SYSTEM_BODIES: usize = BODIES + 1;
pub const PLATFORM: usize = 0;
pub const ROWS_PER_LEG: usize = 13;
pub const CONSTRAINTS: usize = LEGS * ROWS_PER_LEG;

pub(crate) const HOOKE_POSITION: usize = 0;
pub(crate) const HOOKE_ROTATION: usize = 3;
pub(crate) const PRISMATIC_TRANSLATION: usize = 4;
pub(crate) const PRISMATIC_ROTATION: usize = 6;
pub const DRIVING: usize = 9;
pub(crate) const SPHERICAL: usize = 10;

/// Body index of the upper part of leg `k` (0-based).
pub const fn upper(k: usize) -> usize {
    1 + k
}

/// Body index of the lower part of leg `k` (0-based).
pub const fn lower(k: usize) -> usize {
    1 + LEGS + k
}

/// One scalar constraint equation between two bodies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstraintRow {
    pub bodies: [usize; 2],
    /// ∂Φ/∂(δr, δθ) of `bodies[0]` and `bodies[1]`.
    pub jacobian: [Vector6<f64>; 2],
    pub value: f64,
    pub time_derivative: f64,
    pub gamma: f64,
}

impl ConstraintRow {
    pub const EMPTY: Self = Self {
        bodies: [0, 0],
        jacobian: [Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0); 2],
        value: 0.0,
        time_derivative: 0.0,
        gamma: 0.0,
    };

    /// Φ_q v + Φ_t for the given velocities of the system's bodies.
    pub fn velocity_residual(&self, bodies: &[RigidMotion]) -> f64 {
        self.time_derivative + (0..2).map(|n| self.jacobian[n].dot(&twist(&bodies[self.bodies[n]]))).sum::<f64>()
    }

    /// Φ_q v̇ − γ for the given accelerations of the system's bodies.
    pub fn acceleration_residual(&self, bodies: &[RigidMotion]) -> f64 {
        let b = |n: usize| {
            let m = &bodies[self.bodies[n]];
            Vector6::new(
                m.acceleration.x,
                m.acceleration.y,
                m.acceleration.z,
                m.angular_acceleration.x,
                m.angular_acceleration.y,
                m.angular_acceleration.z,
            )
        };
        self.jacobian[0].dot(&b(0)) + self.jacobian[1].dot(&b(1)) - self.gamma
    }
}

fn twist(m: &RigidMotion) -> Vector6<f64> {
    let (v, w) = (m.velocity, m.angular_velocity);
    Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z)
}

fn block(translation: Vec3, rotation: Vec3) -> Vector6<f64> {
    Vector6::new(translation.x, translation.y, translation.z, rotation.x, rotation.y, rotation.z)
}

/// Where the joints of one leg sit on its bodies, each in that body's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LegJoints {
    /// Hooke centre on the cabin (from the centre point) and first Hooke axis, cabin frame.
    base_point: Vec3,
    hooke_axis: Vec3,
    /// Hooke centre in the upper part's frame.
    hooke_in_upper: Vec3,
    /// Spherical joint centre in the lower part's and in the platform's frame.
    sphere_in_lower: Vec3,
    sphere_in_platform: Vec3,
}

/// The joints of the Stewart platform.
#[derive(Clone, Debug, PartialEq)]
pub struct Joints {
    legs: [LegJoints; LEGS],
}

/// A body's pose and velocity with its rotation matrix.
struct Frame {
    r: Vec3,
    rot: Mat3,
    v: Vec3,
    w: Vec3,
}

impl Frame {
    fn new(m: &RigidMotion) -> Self {
        Self {
            r: m.position,
            rot: m.orientation.to_rotation_matrix().into_inner(),
            v: m.velocity,
            w: m.angular_velocity,
        }
    }
}

impl Joints {
    pub fn new(geometry: &StewartGeometry) -> Self {
        let legs = std::array::from_fn(|k| LegJoints {
            base_point: geometry.base_joints[k],
            hooke_axis: geometry.hooke_first_axis(k),
            hooke_in_upper: Vec3::new(0.0, 0.0, -geometry.upper.com_from_joint_m),
            sphere_in_lower: Vec3::new(0.0, 0.0, geometry.lower.com_from_joint_m),
            sphere_in_platform: geometry.platform_joints[k],
        });
        Self { legs }
    }

    /// Hooke centre of leg `k` and its two axes (cabin-fixed, upper-part-fixed), world frame,
    /// taken from the cabin's and the upper part's poses.
    pub fn hooke(&self, k: usize, cabin: &RigidMotion, upper: &RigidMotion) -> (Vec3, [Vec3; 2]) {
        let leg = &self.legs[k];
        let center = cabin.position + cabin.orientation * leg.base_point;
        (center, [cabin.orientation * leg.hooke_axis, upper.orientation * Vec3::y()])
    }

    /// Spherical joint centre of leg `k`, world frame, from the lower part's pose.
    pub(crate) fn sphere_center(&self, k: usize, lower: &RigidMotion) -> Vec3 {
        lower.position + lower.orientation * self.legs[k].sphere_in_lower
    }

    /// All constraint equations for the poses and velocities of the system's bodies (indexed
    /// as in [`SYSTEM_BODIES`]; accelerations are not used) and the actuator strokes ℓ_k(t).
    pub fn evaluate(
        &self,
        bodies: &[RigidMotion; SYSTEM_BODIES],
        strokes: &[Stroke; LEGS],
        rows: &mut [ConstraintRow; CONSTRAINTS],
    ) {
        self.evaluate_with::<true>(bodies, strokes, rows);
    }

    /// Φ, Φ_q and Φ_t only (γ left zero; velocities not used): what a Newton iteration on the
    /// positions needs.
    pub fn evaluate_positions(
        &self,
        bodies: &[RigidMotion; SYSTEM_BODIES],
        strokes: &[Stroke; LEGS],
        rows: &mut [ConstraintRow; CONSTRAINTS],
    ) {
        self.evaluate_with::<false>(bodies, strokes, rows);
    }

    fn evaluate_with<const GAMMA: bool>(
        &self,
        bodies: &[RigidMotion; SYSTEM_BODIES],
        strokes: &[Stroke; LEGS],
        rows: &mut [ConstraintRow; CONSTRAINTS],
    ) {
        let frames: [Frame; SYSTEM_BODIES] = std::array::from_fn(|i| Frame::new(&bodies[i]));
        let (fc, fp) = (&frames[CABIN], &frames[PLATFORM]);
        for (k, leg) in self.legs.iter().enumerate() {
            let out = &mut rows[ROWS_PER_LEG * k..ROWS_PER_LEG * (k + 1)];
            let (u, d) = (upper(k), lower(k));
            let (fu, fd) = (&frames[u], &frames[d]);
            // every joint point and axis in the world, once (a body axis is a column)
            let (base, axis) = (fc.rot * leg.base_point, fc.rot * leg.hooke_axis);
            let (hooke, sphere, on_platform) =
                (fu.rot * leg.hooke_in_upper, fd.rot * leg.sphere_in_lower, fp.rot * leg.sphere_in_platform);
            let ua: [Vec3; 3] = std::array::from_fn(|i| fu.rot.column(i).into_owned());
            let da: [Vec3; 3] = std::array::from_fn(|i| fd.rot.column(i).into_owned());
            let (cu, ud, dp) = ([CABIN, u], [u, d], [d, PLATFORM]);
            points::<GAMMA>((fc, &base), (fu, &hooke), cu, &mut out[HOOKE_POSITION..HOOKE_POSITION + 3]);
            dot::<GAMMA>((fc, &axis), (fu, &ua[1]), cu, &mut out[HOOKE_ROTATION]);
            let none = Stroke::default();
            for n in 0..2 {
                let row = &mut out[PRISMATIC_TRANSLATION + n];
                along::<GAMMA>((fu, &ua[n], &hooke), (fd, &sphere), &none, ud, row);
            }
            for (n, (x, y)) in [(1, 2), (2, 0), (0, 1)].into_iter().enumerate() {
                dot::<GAMMA>((fu, &ua[x]), (fd, &da[y]), ud, &mut out[PRISMATIC_ROTATION + n]);
            }
            along::<GAMMA>((fu, &ua[2], &hooke), (fd, &sphere), &strokes[k], ud, &mut out[DRIVING]);
            points::<GAMMA>((fd, &sphere), (fp, &on_platform), dp, &mut out[SPHERICAL..SPHERICAL + 3]);
        }
    }
}

/// Coincident points: p_i(s_i) − p_j(s_j) = 0, three rows (world x, y, z). Each body comes
/// with its joint point's offset `s` in the world frame.
#[inline]
fn points<const GAMMA: bool>(
    (a, si): (&Frame, &Vec3),
    (b, sj): (&Frame, &Vec3),
    bodies: [usize; 2],
    out: &mut [ConstraintRow],
) {
    let value = a.r + si - b.r - sj;
    // centripetal accelerations of the two points
    let gamma = if GAMMA { -(a.w.cross(&a.w.cross(si)) - b.w.cross(&b.w.cross(sj))) } else { Vec3::zeros() };
    for (m, row) in out.iter_mut().enumerate() {
        let e = Vec3::ith(m, 1.0);
        *row = ConstraintRow {
            bodies,
            jacobian: [block(e, si.cross(&e)), block(-e, -sj.cross(&e))],
            value: value[m],
            time_derivative: 0.0,
            gamma: gamma[m],
        };
    }
}

/// Perpendicular body axes: (R_i x) · (R_j y) = 0, the axes given in the world frame.
#[inline]
fn dot<const GAMMA: bool>(
    (a, xw): (&Frame, &Vec3),
    (b, yw): (&Frame, &Vec3),
    bodies: [usize; 2],
    out: &mut ConstraintRow,
) {
    let gamma = if GAMMA {
        let (dx, dy) = (a.w.cross(xw), b.w.cross(yw));
        -(a.w.cross(&dx).dot(yw) + 2.0 * dx.dot(&dy) + xw.dot(&b.w.cross(&dy)))
    } else {
        0.0
    };
    *out = ConstraintRow {
        bodies,
        jacobian: [block(Vec3::zeros(), xw.cross(yw)), block(Vec3::zeros(), yw.cross(xw))],
        value: xw.dot(yw),
        time_derivative: 0.0,
        gamma,
    };
}

/// A point of body j seen along an axis of body i: (R_i e) · (p_j(s_j) − p_i(s_i)) − ℓ(t) = 0,
/// the axis and the offsets given in the world frame.
#[inline]
fn along<const GAMMA: bool>(
    (a, ew, si): (&Frame, &Vec3, &Vec3),
    (b, sj): (&Frame, &Vec3),
    stroke: &Stroke,
    bodies: [usize; 2],
    out: &mut ConstraintRow,
) {
    let delta = b.r + sj - a.r - si;
    let gamma = if GAMMA {
        let de = a.w.cross(ew);
        let ddelta = b.v + b.w.cross(sj) - a.v - a.w.cross(si);
        let dd_quadratic = b.w.cross(&b.w.cross(sj)) - a.w.cross(&a.w.cross(si));
        -(a.w.cross(&de).dot(&delta) + 2.0 * de.dot(&ddelta) + ew.dot(&dd_quadratic)) + stroke.acceleration
    } else {
        0.0
    };
    *out = ConstraintRow {
        bodies,
        jacobian: [block(-ew, ew.cross(&(b.r + sj - a.r))), block(*ew, sj.cross(ew))],
        value: ew.dot(&delta) - stroke.length,
        time_derivative: -stroke.rate,
        gamma,
    };
}
