//! Geometry and mass distribution of the Stewart platform, relative to the cabin.
//!
//! Shared by the cable model (which carries the platform as a rigid mass at its starting pose)
//! and the Stewart multibody model. Everything here is in the cabin body frame.

use crate::rigid::MassProperties;
use crate::scene::{LEGS, LegPart, ValidScene};
use crate::{Mat3, Vec3};

/// The 13 moving bodies, in this order everywhere: platform, upper parts 1–6, lower parts 1–6.
pub const BODIES: usize = 1 + 2 * LEGS;

#[derive(Clone, Debug, PartialEq)]
pub struct StewartGeometry {
    /// Hooke joint centres on the cabin.
    pub base_joints: [Vec3; LEGS],
    /// Spherical joint centres relative to the platform centre (platform frame ∥ cabin frame).
    pub platform_joints: [Vec3; LEGS],
    /// Centre of the circle motion.
    pub nominal_center: Vec3,
    /// Platform centre at t = 0: on the circle, along the cabin's x axis.
    pub start_center: Vec3,
    pub platform_mass: f64,
    pub platform_inertia: Mat3,
    pub upper: LegPart,
    pub lower: LegPart,
}

impl StewartGeometry {
    pub fn from_scene(scene: &ValidScene) -> Self {
        let s = &scene.stewart;
        let nominal_center = Vec3::from(s.platform.nominal_center_m);
        Self {
            base_joints: to_array(s.base_joints.points()),
            platform_joints: to_array(s.platform_joints.points()),
            nominal_center,
            start_center: nominal_center + Vec3::x() * scene.motion.radius_m,
            platform_mass: s.platform.mass_kg,
            platform_inertia: Mat3::from_row_slice(s.platform.inertia_kg_m2.as_flattened()),
            upper: s.upper_leg.clone(),
            lower: s.lower_leg.clone(),
        }
    }

    /// First Hooke axis of leg `k`: fixed in the cabin, in the base plane, tangential to the
    /// base circle.
    pub fn hooke_first_axis(&self, k: usize) -> Vec3 {
        let b = self.base_joints[k];
        Vec3::new(-b.y, b.x, 0.0).normalize()
    }

    /// Vector from the Hooke centre to the spherical joint centre of leg `k`.
    pub fn leg_vector(&self, k: usize, platform_center: &Vec3) -> Vec3 {
        platform_center + self.platform_joints[k] - self.base_joints[k]
    }

    /// Shortest and longest leg (joint centre to joint centre) for which the two parts still
    /// overlap and neither part reaches past the other's joint.
    pub fn leg_length_range(&self) -> (f64, f64) {
        (self.upper.length_m.max(self.lower.length_m), self.upper.length_m + self.lower.length_m)
    }

    /// Mass properties (cabin frame) of the 13 bodies with the platform centre at
    /// `platform_center`, in the order of [`BODIES`].
    pub fn body_mass_properties(&self, platform_center: &Vec3) -> [MassProperties; BODIES] {
        let mut bodies = [MassProperties::ZERO; BODIES];
        bodies[0] =
            MassProperties { mass: self.platform_mass, com: *platform_center, inertia_com: self.platform_inertia };
        for k in 0..LEGS {
            let d = self.leg_vector(k, platform_center);
            let u = d.normalize();
            let b = self.base_joints[k];
            bodies[1 + k] = leg_part(&self.upper, b + u * self.upper.com_from_joint_m, &u);
            bodies[1 + LEGS + k] = leg_part(&self.lower, b + d - u * self.lower.com_from_joint_m, &u);
        }
        bodies
    }

    /// Mass properties of the 13 bodies in their own frames (centre of mass at the origin), in
    /// the order of [`BODIES`]: the platform's frame is parallel to the cabin's at rest, a leg part's z
    /// axis is the leg axis.
    pub fn body_frame_mass_properties(&self) -> [MassProperties; BODIES] {
        let own = |mass: f64, inertia_com: Mat3| MassProperties { mass, com: Vec3::zeros(), inertia_com };
        let upper = own(self.upper.mass_kg, self.upper.inertia_along(&Vec3::z()));
        let lower = own(self.lower.mass_kg, self.lower.inertia_along(&Vec3::z()));
        let mut bodies = [upper; BODIES];
        bodies[0] = own(self.platform_mass, self.platform_inertia);
        bodies[1 + LEGS..].fill(lower);
        bodies
    }

    /// The platform with its legs, frozen with the platform centre at `platform_center`.
    pub fn locked_mass_properties(&self, platform_center: &Vec3) -> MassProperties {
        self.body_mass_properties(platform_center).into_iter().sum()
    }

    pub fn total_mass(&self) -> f64 {
        self.platform_mass + LEGS as f64 * (self.upper.mass_kg + self.lower.mass_kg)
    }
}

impl LegPart {
    /// Inertia about the centre of mass of the slender part with its axis along the unit vector
    /// `axis`: transverse about every axis ⊥ `axis`, axial about `axis`.
    pub fn inertia_along(&self, axis: &Vec3) -> Mat3 {
        let uu = axis * axis.transpose();
        (Mat3::identity() - uu) * self.inertia_transverse_kg_m2 + uu * self.inertia_axial_kg_m2
    }
}

/// A leg part with its centre of mass at `com` and its axis along `u`.
fn leg_part(part: &LegPart, com: Vec3, u: &Vec3) -> MassProperties {
    MassProperties { mass: part.mass_kg, com, inertia_com: part.inertia_along(u) }
}

fn to_array(points: Vec<Vec3>) -> [Vec3; LEGS] {
    points.try_into().expect("a ValidScene has six joints on each Stewart ring")
}

impl ValidScene {
    pub fn stewart_geometry(&self) -> StewartGeometry {
        StewartGeometry::from_scene(self)
    }
}
