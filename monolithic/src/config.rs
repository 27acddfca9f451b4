//! The configuration of the monolithic model: the cable–cabin model's (free nodes and the cabin
//! pose) and the poses of the 13 Stewart bodies.

use feedcore::rigid::{RigidMotion, exp_so3};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Quat, Vec3};

/// Pose of a Stewart body: centre of mass and orientation (body to world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub position: Vec3,
    pub orientation: Quat,
}

#[derive(Debug, PartialEq)]
pub struct Config {
    pub cable: cable::system::Config,
    /// Platform, upper parts 1–6, lower parts 1–6 (the Stewart crate's order).
    pub bodies: [Pose; BODIES],
}

impl Clone for Config {
    fn clone(&self) -> Self {
        Config { cable: self.cable.clone(), bodies: self.bodies }
    }

    fn clone_from(&mut self, source: &Self) {
        self.cable.clone_from(&source.cable);
        self.bodies = source.bodies;
    }
}

impl Config {
    /// `base` moved by the velocity-level `increment` (cable part first, then 6 per body).
    pub fn set_displaced(&mut self, base: &Config, increment: &[f64]) {
        let nc = increment.len() - 6 * BODIES;
        self.cable.set_displaced(&base.cable, &increment[..nc]);
        for (b, (pose, base)) in self.bodies.iter_mut().zip(&base.bodies).enumerate() {
            let u = &increment[nc + 6 * b..nc + 6 * b + 6];
            pose.position = base.position + Vec3::new(u[0], u[1], u[2]);
            pose.orientation = exp_so3(&Vec3::new(u[3], u[4], u[5])) * base.orientation;
        }
    }

    /// The cabin's pose and the velocities in `velocity` as a rigid motion (accelerations zero).
    pub fn cabin_motion(&self, velocity: &[f64], offset: usize) -> RigidMotion {
        let mut m = RigidMotion::at_rest(self.cable.position, self.cable.orientation);
        m.velocity = Vec3::from_column_slice(&velocity[offset..offset + 3]);
        m.angular_velocity = Vec3::from_column_slice(&velocity[offset + 3..offset + 6]);
        m
    }
}
