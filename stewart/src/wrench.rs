//! The wrench the Stewart platform exerts on the cabin, in momentum form, and its exact Jacobians.
//!
//! With the relative motion prescribed, the reaction of the cabin on the 13 bodies is the sum of
//! their inertia forces minus their weights. In the world frame, with `S = Σ m ρ` (ρ: centre of
//! mass from the cabin centre point), `I` the locked inertia about the cabin centre point and
//! `a' = a − g`:
//!
//! ```text
//! F = −[ m a' + α × S + ω × (ω × S) + 2 ω × Ṡ + S̈ ]
//! M = −[ S × a' + I α + ω × I ω + C ω + ḣ ]
//! ```
//!
//! where `C ω` collects the terms linear in ω (Coriolis, relative spin) and `ḣ` the rate of the
//! relative angular momentum (see [`RelativeState`]). `S, Ṡ, S̈, I, C, ḣ` are the cabin-frame sums
//! rotated to the world, so the wrench is linear in (a, α), quadratic in ω, independent of the
//! cabin position and of its linear velocity; the Jacobians below are the exact derivatives.

use feedcore::rigid::skew;
use feedcore::{Mat3, Quat, Vec3};
use nalgebra::{Matrix6, Vector6};

use crate::relative::RelativeState;

pub use feedcore::rigid::RigidMotion;

/// Motion of the cabin centre point and of the cabin frame.
pub type CabinMotion = RigidMotion;

/// What the platform exerts on the cabin: force, and moment about the cabin centre point; world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wrench {
    pub force: Vec3,
    pub moment: Vec3,
}

impl Wrench {
    /// (force, moment) as one 6-vector.
    pub fn to_vector(&self) -> Vector6<f64> {
        Vector6::new(self.force.x, self.force.y, self.force.z, self.moment.x, self.moment.y, self.moment.z)
    }

    pub(crate) fn from_vector(v: &Vector6<f64>) -> Self {
        Self { force: v.fixed_rows::<3>(0).into_owned(), moment: v.fixed_rows::<3>(3).into_owned() }
    }
}

/// Exact derivatives of the wrench 6-vector (force, moment) with respect to the cabin motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WrenchJacobians {
    /// ∂W/∂(a, α): minus the added mass.
    pub acceleration: Matrix6<f64>,
    /// ∂W/∂(v, ω).
    pub velocity: Matrix6<f64>,
    /// ∂W/∂(δr, δθ), δθ a world-frame rotation of the cabin (`R' = exp([δθ]×) R`) at fixed
    /// world-frame velocities and accelerations.
    pub pose: Matrix6<f64>,
}

impl WrenchJacobians {
    /// The added mass the platform puts on the cabin: the locked spatial mass matrix about the
    /// cabin centre point, `−∂W/∂(a, α)`.
    pub fn added_mass(&self) -> Matrix6<f64> {
        -self.acceleration
    }
}

/// The cabin-frame sums of a [`RelativeState`] rotated into the world frame.
struct WorldSums {
    s: Vec3,
    ds: Vec3,
    dds: Vec3,
    inertia: Mat3,
    coriolis: Mat3,
    momentum_rate: Vec3,
}

impl WorldSums {
    fn new(rel: &RelativeState, orientation: &Quat) -> Self {
        let r = orientation.to_rotation_matrix().into_inner();
        let rt = r.transpose();
        Self {
            s: r * rel.first_moment[0],
            ds: r * rel.first_moment[1],
            dds: r * rel.first_moment[2],
            inertia: r * rel.inertia * rt,
            coriolis: r * rel.coriolis * rt,
            momentum_rate: r * rel.relative_momentum_rate,
        }
    }
}

impl RelativeState {
    /// The wrench on the cabin for the given cabin motion and gravity vector (world).
    pub fn wrench(&self, cabin: &CabinMotion, gravity: &Vec3) -> Wrench {
        let w = WorldSums::new(self, &cabin.orientation);
        self.wrench_from(&w, cabin, gravity)
    }

    fn wrench_from(&self, w: &WorldSums, cabin: &CabinMotion, gravity: &Vec3) -> Wrench {
        let (om, al) = (&cabin.angular_velocity, &cabin.angular_acceleration);
        let a = cabin.acceleration - gravity;
        let force = -(a * self.mass + al.cross(&w.s) + om.cross(&om.cross(&w.s)) + om.cross(&w.ds) * 2.0 + w.dds);
        let moment =
            -(w.s.cross(&a) + w.inertia * al + om.cross(&(w.inertia * om)) + w.coriolis * om + w.momentum_rate);
        Wrench { force, moment }
    }

    /// The wrench and its exact Jacobians.
    pub fn wrench_with_jacobians(&self, cabin: &CabinMotion, gravity: &Vec3) -> (Wrench, WrenchJacobians) {
        let w = WorldSums::new(self, &cabin.orientation);
        let wrench = self.wrench_from(&w, cabin, gravity);
        let (om, al) = (&cabin.angular_velocity, &cabin.angular_acceleration);
        let a = cabin.acceleration - gravity;
        let (s_s, s_ds, s_dds) = (skew(&w.s), skew(&w.ds), skew(&w.dds));
        let (s_om, s_al) = (skew(om), skew(al));
        let i_om = w.inertia * om;

        let mut acceleration = Matrix6::zeros();
        acceleration.fixed_view_mut::<3, 3>(0, 0).copy_from(&(Mat3::identity() * -self.mass));
        acceleration.fixed_view_mut::<3, 3>(0, 3).copy_from(&s_s);
        acceleration.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-s_s));
        acceleration.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-w.inertia));

        let mut velocity = Matrix6::zeros();
        let df_dom = skew(&om.cross(&w.s)) + s_om * s_s + s_ds * 2.0;
        let dm_dom = -(s_om * w.inertia - skew(&i_om) + w.coriolis);
        velocity.fixed_view_mut::<3, 3>(0, 3).copy_from(&df_dom);
        velocity.fixed_view_mut::<3, 3>(3, 3).copy_from(&dm_dom);

        // Rotating the cabin by δθ rotates every world-frame sum X: δX = δθ × X (vectors),
        // δX = [δθ]X − X[δθ] (tensors).
        let mut pose = Matrix6::zeros();
        let df_dth = s_al * s_s + s_om * s_om * s_s + s_om * s_ds * 2.0 + s_dds;
        let dm_dth =
            -(skew(&a) * s_s - skew(&(w.inertia * al)) + w.inertia * s_al + s_om * (w.inertia * s_om - skew(&i_om))
                - skew(&(w.coriolis * om))
                + w.coriolis * s_om
                - skew(&w.momentum_rate));
        pose.fixed_view_mut::<3, 3>(0, 3).copy_from(&df_dth);
        pose.fixed_view_mut::<3, 3>(3, 3).copy_from(&dm_dth);

        (wrench, WrenchJacobians { acceleration, velocity, pose })
    }
}
