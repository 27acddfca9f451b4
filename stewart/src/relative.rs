//! Motion of the 13 bodies relative to the cabin (cabin frame), a function of time alone.
//!
//! The platform moves as commanded ([`PathPoint`]: its centre and its orientation). Each leg is
//! the straight line from its
//! Hooke centre to its spherical joint centre; both leg parts share one orientation: the leg axis
//! `u` is the body z axis, the second Hooke axis `b = (u × a)/|u × a|` (⟂ to the first axis `a`
//! and to `u`) the body y axis. The Hooke joint forbids spin: the relative angular velocity lies in
//! span(a, b), i.e. is ⟂ `c = a × b`; with `u̇ = ω × u` this fixes `ω = u × u̇ + s·u`.
//!
//! Alongside the bodies this computes the sums the momentum form of the wrench needs (see
//! [`crate::wrench`]): mass, first moment, inertia about the cabin centre point, and the parts of
//! the inertia forces that are linear in the cabin's angular velocity or independent of it.

use feedcore::rigid::{MassProperties, skew};
use feedcore::scene::{LEGS, LegPart};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};

use crate::path::PathPoint;

/// One body relative to the cabin, cabin frame. `position` is its centre of mass;
/// `orientation` maps its body frame to the cabin frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativeBody {
    pub position: Vec3,
    pub velocity: Vec3,
    pub acceleration: Vec3,
    pub orientation: Mat3,
    pub angular_velocity: Vec3,
    pub angular_acceleration: Vec3,
    /// Inertia about the centre of mass, cabin frame.
    pub inertia: Mat3,
}

/// Length of a leg (joint centre to joint centre) and its first two time derivatives: the
/// driving constraint of the actuator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stroke {
    pub length: f64,
    pub rate: f64,
    pub acceleration: f64,
}

/// Everything about the Stewart platform's relative motion at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct RelativeState {
    pub time: f64,
    /// Platform, upper parts 1–6, lower parts 1–6.
    pub bodies: [RelativeBody; BODIES],
    pub strokes: [Stroke; LEGS],
    /// Sine of the angle between each leg and its first Hooke axis (0: Hooke joint singular).
    pub hooke_sine: [f64; LEGS],
    /// Total mass.
    pub mass: f64,
    /// Σ m ρ and its first two time derivatives (ρ: centre of mass from the cabin centre point).
    pub first_moment: [Vec3; 3],
    /// Locked inertia about the cabin centre point.
    pub inertia: Mat3,
    /// Moment of the inertia forces linear in the cabin angular velocity ω: `coriolis · ω`.
    pub coriolis: Mat3,
    /// Rate of change of the angular momentum of the relative motion about the cabin centre point.
    pub relative_momentum_rate: Vec3,
}

/// What the relative kinematics needs of the geometry, cabin frame.
pub(crate) struct LegGeometry<'a> {
    pub base_joints: &'a [Vec3; LEGS],
    pub platform_joints: &'a [Vec3; LEGS],
    pub hooke_axes: &'a [Vec3; LEGS],
    /// The 13 bodies in their own frames (the platform's is the cabin's at rest).
    pub bodies: &'a [MassProperties; BODIES],
    /// The upper and lower part of every leg.
    pub upper: &'a LegPart,
    pub lower: &'a LegPart,
}

impl RelativeState {
    /// The relative motion with the platform at `path` (at time `time`, for messages).
    /// Does not check leg lengths or singularities; [`crate::Stewart`] does.
    pub(crate) fn new(geometry: &LegGeometry, path: &PathPoint, time: f64) -> Self {
        let zero = RelativeBody {
            position: Vec3::zeros(),
            velocity: Vec3::zeros(),
            acceleration: Vec3::zeros(),
            orientation: Mat3::identity(),
            angular_velocity: Vec3::zeros(),
            angular_acceleration: Vec3::zeros(),
            inertia: Mat3::zeros(),
        };
        let mut bodies = [zero; BODIES];
        let mut strokes = [Stroke::default(); LEGS];
        let mut hooke_sine = [0.0; LEGS];
        let turn = &path.orientation;
        bodies[0] = RelativeBody {
            position: path.position,
            velocity: path.velocity,
            acceleration: path.acceleration,
            orientation: *turn,
            angular_velocity: path.angular_velocity,
            angular_acceleration: path.angular_acceleration,
            inertia: turn * geometry.bodies[0].inertia_com * turn.transpose(),
        };
        let (c_up, c_lo) = (geometry.upper.com_from_joint_m, geometry.lower.com_from_joint_m);
        for k in 0..LEGS {
            let Leg { d, dd, ddd, u, du, ddu, stroke, uxa, sine } = Leg::new(geometry, k, path);
            strokes[k] = stroke;
            hooke_sine[k] = sine;
            let a = geometry.hooke_axes[k];
            let b = uxa / sine;
            let c = a.cross(&b);
            // u·c = b·(u × a) = sine
            let base = u.cross(&du);
            let spin = -base.dot(&c) / sine;
            let w = base + u * spin;
            let dc = a.cross(&w.cross(&b));
            let partial = u.cross(&ddu) + du * spin;
            let dspin = -(w.dot(&dc) + partial.dot(&c)) / sine;
            let dw = partial + u * dspin;

            let orientation = Mat3::from_columns(&[b.cross(&u), b, u]);
            let base_joint = geometry.base_joints[k];
            bodies[1 + k] = RelativeBody {
                position: base_joint + u * c_up,
                velocity: du * c_up,
                acceleration: ddu * c_up,
                orientation,
                angular_velocity: w,
                angular_acceleration: dw,
                inertia: geometry.upper.inertia_along(&u),
            };
            bodies[1 + LEGS + k] = RelativeBody {
                position: base_joint + d - u * c_lo,
                velocity: dd - du * c_lo,
                acceleration: ddd - ddu * c_lo,
                orientation,
                angular_velocity: w,
                angular_acceleration: dw,
                inertia: geometry.lower.inertia_along(&u),
            };
        }

        let mut mass = 0.0;
        let mut first_moment = [Vec3::zeros(); 3];
        let mut inertia = Mat3::zeros();
        let mut coriolis = Mat3::zeros();
        let mut momentum_rate = Vec3::zeros();
        for (body, m) in bodies.iter().zip(geometry.bodies.iter().map(|b| b.mass)) {
            let (r, dr, ddr) = (body.position, body.velocity, body.acceleration);
            mass += m;
            first_moment[0] += r * m;
            first_moment[1] += dr * m;
            first_moment[2] += ddr * m;
            let sr = skew(&r);
            inertia += body.inertia - sr * sr * m;
            let (j, w) = (&body.inertia, &body.angular_velocity);
            let jw = j * w;
            let sw = skew(w);
            // Σ 2m ρ × (ω × ρ̇)  +  J (ω × w) + ω × J w + w × J ω
            coriolis += -(sr * skew(&dr)) * (2.0 * m) - j * sw - skew(&jw) + sw * j;
            momentum_rate += r.cross(&ddr) * m + j * body.angular_acceleration + w.cross(&jw);
        }
        Self {
            time,
            bodies,
            strokes,
            hooke_sine,
            mass,
            first_moment,
            inertia,
            coriolis,
            relative_momentum_rate: momentum_rate,
        }
    }
}

/// One leg's axis and stroke.
struct Leg {
    /// From the Hooke centre to the spherical joint centre, with its first two time derivatives.
    d: Vec3,
    dd: Vec3,
    ddd: Vec3,
    /// Its direction, with its first two time derivatives.
    u: Vec3,
    du: Vec3,
    ddu: Vec3,
    stroke: Stroke,
    /// u × a (a: the first Hooke axis) and its length, the sine of their angle.
    uxa: Vec3,
    sine: f64,
}

impl Leg {
    fn new(geometry: &LegGeometry, k: usize, path: &PathPoint) -> Leg {
        // the spherical joint moves with the platform: its centre and its rotation
        let arm = path.orientation * geometry.platform_joints[k];
        let (w, al) = (&path.angular_velocity, &path.angular_acceleration);
        let w_arm = w.cross(&arm);
        let d = path.position + arm - geometry.base_joints[k];
        let dd = path.velocity + w_arm;
        let ddd = path.acceleration + al.cross(&arm) + w.cross(&w_arm);
        let length = d.norm();
        let u = d / length;
        let rate = u.dot(&dd);
        let du = (dd - u * rate) / length;
        let accel = du.dot(&dd) + u.dot(&ddd);
        let ddu = (ddd - du * (2.0 * rate) - u * accel) / length;
        let uxa = u.cross(&geometry.hooke_axes[k]);
        Leg { d, dd, ddd, u, du, ddu, stroke: Stroke { length, rate, acceleration: accel }, uxa, sine: uxa.norm() }
    }
}

/// The strokes of the six legs and the sines of their angles to their first Hooke axes, for the
/// platform at `path` (what the driving constraints need; the rest of
/// [`RelativeState::new`] is not computed).
pub(crate) fn strokes(geometry: &LegGeometry, path: &PathPoint) -> ([Stroke; LEGS], [f64; LEGS]) {
    let legs: [Leg; LEGS] = std::array::from_fn(|k| Leg::new(geometry, k, path));
    (legs.each_ref().map(|l| l.stroke), legs.each_ref().map(|l| l.sine))
}
