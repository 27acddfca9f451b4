//! The cable net: anchors, attachment points, cable material, and the rigid bodies the cables
//! carry. Independent of any scene file, so that tests can build arbitrary nets.

use feedcore::Vec3;
use feedcore::rigid::MassProperties;
use feedcore::scene::{StewartMode, ValidScene};

use crate::shooting::CableSpec;

/// Geometry and material of a net of cables carrying one rigid cabin.
#[derive(Clone, Debug)]
pub struct CableNet {
    /// Fixed cable ends (tower tops), world frame; cable i starts here.
    pub anchors: Vec<Vec3>,
    /// Cable ends on the cabin, body frame, relative to the cabin centre point (the reference
    /// point whose pose the model reports).
    pub attachments: Vec<Vec3>,
    pub spec: CableSpec,
    /// The cabin itself, body frame (centre of mass relative to the cabin centre point).
    pub cabin: MassProperties,
    /// The Stewart platform frozen at its starting pose, body frame; zero if absent. It loads the
    /// statics always, and rides on the cabin as a rigid mass when the Stewart is locked.
    pub payload: MassProperties,
}

impl CableNet {
    pub fn from_scene(scene: &ValidScene) -> CableNet {
        let payload = match scene.analyses.stewart {
            StewartMode::Absent => MassProperties::ZERO,
            StewartMode::Locked | StewartMode::Coupled => {
                let g = scene.stewart_geometry();
                g.locked_mass_properties(&g.start_center)
            }
        };
        CableNet {
            anchors: scene.anchors(),
            attachments: scene.attachments_body(),
            spec: CableSpec {
                elements: scene.cables.elements,
                ea: scene.cables.axial_stiffness(),
                mass_per_length: scene.cables.mass_per_length(),
                gravity: scene.gravity(),
            },
            cabin: scene.cabin_mass_properties(),
            payload,
        }
    }

    pub fn cable_count(&self) -> usize {
        self.anchors.len()
    }

    /// Weight of everything the cables carry at the cabin (cabin and payload), body frame.
    pub fn suspended(&self) -> MassProperties {
        self.cabin.combined(&self.payload)
    }
}
