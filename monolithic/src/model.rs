//! What does not change during a run of the monolithic model: the cable–cabin system, the
//! Stewart platform, the Stewart bodies' inertia, the integrator, and where each unknown sits.

use cable::model::{CableCabin, ModelError, Payload};
use cable::system::System;
use feedcore::genalpha::{Integrator, Newton, OptionsError};
use feedcore::rigid::MassProperties;
use feedcore::scene::{SensorKind, ValidScene, WrenchModel};
use feedcore::stewart_geometry::BODIES;
use feedcore::{Mat3, Vec3};
use stewart::constraints::{CABIN, CONSTRAINTS, ROWS_PER_LEG, SYSTEM_BODIES};
use stewart::{RigidMotion, Stewart, StewartError};

use crate::config::{Config, Pose};
use crate::kkt::BODY_NAMES;

/// Why a model cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    CableCabin(#[from] ModelError),
    #[error(transparent)]
    Stewart(#[from] StewartError),
    #[error("monolithic model: {0}")]
    Options(#[from] OptionsError),
    /// With an ideal sensor the strokes at the step's end follow the cabin's velocity and
    /// acceleration there, which the driving constraints Φ(q, t) cannot express.
    #[error(
        "monolithic model: [control] sensor = \"ideal\" makes the legs' strokes depend on the cabin's \
         velocity and acceleration at the step's end, which the index-3 formulation's driving \
         constraints Φ(q, t) cannot express (it needs constraints on velocities and accelerations); \
         use sensor = \"sampled\" (or \"off\"), or a coupling scheme for the ideal sensor"
    )]
    IdealSensor,
}

/// The immutable model.
pub struct Model {
    /// The cable–cabin system with the platform left to its joints (external payload).
    pub system: System,
    pub stewart: Stewart,
    /// Mass properties of the Stewart bodies, body frame, about their centres of mass.
    pub bodies: [MassProperties; BODIES],
    pub integrator: Integrator,
    /// The first moment of the platform and legs about the cabin centre point at the start,
    /// cabin frame, when the weight shift is left out (`[analyses] wrench = "inertial_only"`).
    pub weight_shift_from: Option<Vec3>,
}

/// The model with its initial configuration and velocities (cables and cabin at rest at the
/// static equilibrium — the cabin moving instead with a momentum-consistent start — and the
/// Stewart bodies on their prescribed relative motion at time 0).
pub struct Start {
    pub model: Model,
    pub config: Config,
    pub velocity: Vec<f64>,
}

impl Model {
    pub fn build(scene: &ValidScene) -> Result<Start, BuildError> {
        if scene.control.as_ref().is_some_and(|c| c.sensor == SensorKind::Ideal) {
            return Err(BuildError::IdealSensor);
        }
        let cc = CableCabin::build(scene, 0)?;
        let stewart = Stewart::from_scene(scene)?;
        let system = cc.system(Payload::External);
        let cable = cc.equilibrium_config();
        // at rest, or moving as a momentum-consistent start asks (`CableCabin::start_twist`)
        let twist = cc.start_twist(&stewart.start_momentum()?)?;
        let cabin = RigidMotion {
            velocity: twist.fixed_rows::<3>(0).into(),
            angular_velocity: twist.fixed_rows::<3>(3).into(),
            ..RigidMotion::at_rest(cable.position, cable.orientation)
        };
        let placed = stewart.system_motion(&cabin, 0.0)?;
        let bodies = *stewart.body_inertias();
        let poses = std::array::from_fn(|b| Pose { position: placed[b].position, orientation: placed[b].orientation });
        // The tolerance must be small against the shortest length of the model: a cable
        // element, or the distance from a leg part's joint to its centre of mass.
        let g = stewart.geometry();
        let shortest = system
            .element_length
            .iter()
            .copied()
            .chain([g.upper.com_from_joint_m, g.lower.com_from_joint_m])
            .fold(f64::INFINITY, f64::min);
        let s = &scene.solver;
        let integrator = Integrator::new(s.rho_inf, Newton::new(s.newton_tol, s.newton_max_iter, shortest)?)?;
        let weight_shift_from = match scene.analyses.wrench {
            WrenchModel::Full => None,
            WrenchModel::InertialOnly => Some(stewart.relative(0.0)?.first_moment[0]),
        };
        let model = Model { system, stewart, bodies, integrator, weight_shift_from };
        let mut velocity = vec![0.0; model.motion_dim()];
        // the Stewart bodies and the cabin (cable nodes at rest)
        for b in 0..SYSTEM_BODIES {
            let o = model.body_offset(b);
            velocity[o..o + 3].copy_from_slice(placed[b].velocity.as_slice());
            velocity[o + 3..o + 6].copy_from_slice(placed[b].angular_velocity.as_slice());
        }
        Ok(Start { model, config: Config { cable, bodies: poses }, velocity })
    }

    /// Unknowns of the cable–cabin part (free nodes, then the cabin).
    pub(crate) fn cable_dim(&self) -> usize {
        self.system.dim()
    }

    /// Motion unknowns: the cable–cabin part, then 6 per Stewart body.
    pub(crate) fn motion_dim(&self) -> usize {
        self.cable_dim() + 6 * BODIES
    }

    /// Start of body `b`'s unknowns (Stewart order; the cabin at [`CABIN`]).
    pub fn body_offset(&self, b: usize) -> usize {
        if b == CABIN { self.system.cabin_offset() } else { self.cable_dim() + 6 * b }
    }

    /// What unknown `index` is.
    pub fn unknown_name(&self, index: usize) -> String {
        let (nc, n) = (self.cable_dim(), self.motion_dim());
        let axis = ["translation x", "translation y", "translation z", "rotation x", "rotation y", "rotation z"];
        if index < nc {
            self.system.unknown_name(index)
        } else if index < n {
            let b = (index - nc) / 6;
            format!("{} {}", BODY_NAMES[b], axis[(index - nc) % 6])
        } else if index < n + CONSTRAINTS {
            let k = index - n;
            format!("Lagrange multiplier of Stewart constraint row {k} (leg {})", k / ROWS_PER_LEG + 1)
        } else {
            format!("unknown {index} (of {})", n + CONSTRAINTS)
        }
    }

    /// World-frame rotation tangents (identity on translations): see
    /// [`feedcore::rigid::left_jacobian_so3`].
    pub fn tangent(increment: &[f64], offset: usize) -> Mat3 {
        feedcore::rigid::left_jacobian_so3(&Vec3::from_column_slice(&increment[offset + 3..offset + 6]))
    }
}
