//! The cable–cabin model of a scene: form-found equilibrium, Rayleigh damping fitted to its
//! modes, and ready-to-run dynamics. This is the entry point for the CLI and the FMU.

use feedcore::scene::{DampingFit, SceneError, ValidScene};
use nalgebra::Vector6;

use crate::chain_matrix::LinkedChain;
use crate::damping::{rayleigh_coefficients, rayleigh_matrix};
use crate::dynamics::{Dynamics, DynamicsError, DynamicsOptions};
use crate::modes::{Modes, modes};
use crate::net::CableNet;
use crate::statics::{Equilibrium, StaticsError, form_find, form_find_under};
use crate::system::{Config, Support, System};

#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("form-finding statics: {0}")]
    Statics(#[from] StaticsError),
    #[error("modal analysis: {0}")]
    Modes(String),
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    #[error("the cabin's mass matrix about its centre point is not positive definite")]
    CabinMass,
}

/// Rayleigh coefficients and where they came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayleighFit {
    pub ratio: f64,
    pub frequencies_hz: [f64; 2],
    pub alpha: f64,
    pub beta: f64,
}

/// How the Stewart platform enters the cable–cabin dynamics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Payload {
    /// Rigidly attached at its starting pose (a "locked" platform).
    Locked,
    /// Left out of the body: an external wrench on the cabin stands for it (co-simulation).
    External,
}

/// A scene's cable–cabin model at its static equilibrium.
#[derive(Clone, Debug)]
pub struct CableCabin {
    pub scene: ValidScene,
    pub net: CableNet,
    pub equilibrium: Equilibrium,
    /// Modes of the locked system, if they were needed (damping fit or the scene asked).
    pub modes: Option<Modes>,
    pub damping: RayleighFit,
    /// The locked system at the equilibrium, with its damping matrix.
    locked: System,
}

impl CableCabin {
    /// Form finding, and the modal analysis the damping fit (and the scene) asks for.
    pub fn from_scene(scene: &ValidScene) -> Result<CableCabin, ModelError> {
        Self::build(scene, scene.analyses.modes)
    }

    /// As [`CableCabin::from_scene`], with at least `mode_count` modes computed.
    pub fn build(scene: &ValidScene, mode_count: usize) -> Result<CableCabin, ModelError> {
        let net = CableNet::from_scene(scene);
        let equilibrium =
            form_find(&net, scene.target_position(), scene.target_orientation()).map_err(ModelError::Statics)?;
        let mut locked = System::new(net.clone(), equilibrium.lengths(), true, Support::Free);
        locked.wind = scene.wind.as_ref().map(|w| std::sync::Arc::new(feedcore::wind::WindLoad::new(w)));
        let cfg = locked.config_from(&equilibrium);
        let d = &scene.damping;
        let needed = Self::modes_built(scene, mode_count);
        let modes = if needed > 0 {
            Some(modes(&locked, &cfg, needed).map_err(|e| ModelError::Modes(e.to_string()))?)
        } else {
            None
        };
        let frequencies_hz = match scene.damping_fit() {
            DampingFit::Modes([a, b]) => match modes.as_ref().map(|md| &md.frequencies_hz) {
                Some(f) if b <= f.len() => [f[a - 1], f[b - 1]],
                found => {
                    return Err(ModelError::Modes(format!(
                        "the system has only {} modes; damping.fit_modes asks for mode {b}",
                        found.map_or(0, Vec::len)
                    )));
                }
            },
            DampingFit::Frequencies(f) => f,
        };
        if frequencies_hz[0] <= 0.0 {
            return Err(ModelError::Modes(format!(
                "cannot fit damping at a non-positive frequency {:?} Hz (unstable equilibrium?)",
                frequencies_hz
            )));
        }
        let w = frequencies_hz.map(|f| 2.0 * std::f64::consts::PI * f);
        let (alpha, beta) = rayleigh_coefficients(d.ratio, w[0], w[1]);
        locked.damping = Some(LinkedChain::new(rayleigh_matrix(&locked, &cfg, alpha, beta)));
        Ok(CableCabin {
            scene: scene.clone(),
            net,
            equilibrium,
            modes,
            damping: RayleighFit { ratio: d.ratio, frequencies_hz, alpha, beta },
            locked,
        })
    }

    /// The system with the platform locked on the cabin, or left to an external wrench. Both
    /// share the same damping matrix.
    pub fn system(&self, payload: Payload) -> System {
        match payload {
            Payload::Locked => self.locked.clone(),
            Payload::External => {
                let mut s = System::new(self.net.clone(), self.equilibrium.lengths(), false, Support::Free);
                s.damping = self.locked.damping.clone();
                s.wind = self.locked.wind.clone();
                s
            }
        }
    }

    /// The same model in equilibrium at the same pose with the platform replaced by the
    /// external `wrench` on the cabin: the unstretched lengths are form-found for it, the
    /// damping keeps its fitted coefficients (on the stiffness of the new equilibrium).
    pub fn under_wrench(&self, wrench: &Vector6<f64>) -> Result<CableCabin, ModelError> {
        let (p, q) = (self.equilibrium.position, self.equilibrium.orientation);
        let equilibrium = form_find_under(&self.net, p, q, wrench).map_err(ModelError::Statics)?;
        let mut locked = System::new(self.net.clone(), equilibrium.lengths(), true, Support::Free);
        let cfg = locked.config_from(&equilibrium);
        locked.damping = Some(LinkedChain::new(rayleigh_matrix(&locked, &cfg, self.damping.alpha, self.damping.beta)));
        locked.wind = self.locked.wind.clone();
        Ok(CableCabin {
            scene: self.scene.clone(),
            net: self.net.clone(),
            equilibrium,
            modes: None,
            damping: self.damping,
            locked,
        })
    }

    /// The number of modes [`CableCabin::build`] computes for `scene` asked for `mode_count`:
    /// those of the damping fit, or more.
    pub fn modes_built(scene: &ValidScene, mode_count: usize) -> usize {
        let fit = match scene.damping_fit() {
            DampingFit::Modes([_, b]) => b,
            DampingFit::Frequencies(_) => 0,
        };
        fit.max(mode_count)
    }

    /// The model's unknowns (degrees of freedom): three per interior cable node, six of the
    /// cabin.
    pub fn unknowns(scene: &ValidScene) -> usize {
        3 * scene.cable_count() * scene.cables.elements.saturating_sub(1) + 6
    }

    /// Bytes [`CableCabin::build`] and the dynamics would allocate for `scene` with at least
    /// `mode_count` modes, as a float (it may not fit any integer for absurd sizes). Everything
    /// grows linearly in n, the number of unknowns: the modal analysis
    /// ([`crate::modes::memory_estimate`]), the chain matrices and the states.
    pub fn memory_estimate(scene: &ValidScene, mode_count: usize) -> f64 {
        let n = Self::unknowns(scene) as f64;
        let modal = crate::modes::memory_estimate(n, Self::modes_built(scene, mode_count));
        // chain blocks (3×3 and 3×6 per node) in a handful of matrices and factors, vectors
        let linear = 400.0 * n;
        modal + 8.0 * linear
    }

    pub fn equilibrium_config(&self) -> Config {
        self.locked.config_from(&self.equilibrium)
    }

    /// The wrench (force; moment about the cabin centre point; world frame) of the platform's
    /// weight at its starting pose: what an external platform exerts on the cabin at rest.
    pub fn static_payload_wrench(&self) -> Vector6<f64> {
        self.net.payload.weight_wrench(&self.equilibrium.orientation, &self.net.spec.gravity)
    }

    /// Dynamics starting at rest at the equilibrium at time `t0`; with an external payload the
    /// wrench at `t0` is its static wrench.
    pub fn dynamics(&self, payload: Payload, t0: f64) -> Result<Dynamics, ModelError> {
        let wrench = match payload {
            Payload::Locked => Vector6::zeros(),
            Payload::External => self.static_payload_wrench(),
        };
        self.dynamics_with(payload, t0, &wrench)
    }

    /// Dynamics starting at rest at the equilibrium at time `t0` under the external `wrench`
    /// (its initial acceleration follows from it).
    pub fn dynamics_with(&self, payload: Payload, t0: f64, wrench: &Vector6<f64>) -> Result<Dynamics, ModelError> {
        self.dynamics_from(payload, t0, wrench, &Vector6::zeros())
    }

    /// As [`CableCabin::dynamics_with`], the cabin starting with `cabin_velocity` (velocity of
    /// its centre point and angular velocity, world frame; see [`CableCabin::start_twist`]); the
    /// cable nodes start at rest.
    pub fn dynamics_from(
        &self,
        payload: Payload,
        t0: f64,
        wrench: &Vector6<f64>,
        cabin_velocity: &Vector6<f64>,
    ) -> Result<Dynamics, ModelError> {
        let sys = self.system(payload);
        let mut velocity = vec![0.0; sys.dim()];
        let c0 = sys.cabin_offset();
        velocity[c0..].copy_from_slice(cabin_velocity.as_slice());
        let s = &self.scene.solver;
        let options =
            DynamicsOptions { rho_inf: s.rho_inf, newton_tol: s.newton_tol, newton_max_iter: s.newton_max_iter };
        Dynamics::new(sys, self.equilibrium_config(), velocity, t0, wrench, options).map_err(ModelError::Dynamics)
    }

    /// The cabin's velocity and angular velocity (world frame) right after the start: zero,
    /// except for `[motion] start = "consistent"`. There the platform starts at full speed as in
    /// the abrupt start, but it pushes off the cabin: the impulse between them is internal and
    /// the cables, carrying finite forces, take none of it, so the momentum of the cabin with
    /// everything riding on it (platform, legs, the cables' end nodes) stays zero:
    /// `M_locked · V + R h_rel = 0`, with `M_locked` the spatial mass matrix about the cabin
    /// centre point of the body with the platform locked at its start and `h_rel` the momentum
    /// of the platform's motion relative to the cabin at t = 0 (cabin frame, linear then angular
    /// about the cabin centre point), which the caller takes from the platform's model; it is
    /// not used for the other starts.
    pub fn start_twist(&self, h: &Vector6<f64>) -> Result<Vector6<f64>, ModelError> {
        if self.scene.motion.start != feedcore::scene::Start::Consistent {
            return Ok(Vector6::zeros());
        }
        let (p, q) = (self.equilibrium.position, self.equilibrium.orientation);
        let rot = q.to_rotation_matrix().into_inner();
        let (lin, ang) = (rot * h.fixed_rows::<3>(0), rot * h.fixed_rows::<3>(3));
        let world = Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z);
        let mass = self.locked.body.transformed(&rot, &p).spatial_matrix_about(&p);
        mass.cholesky().map(|c| c.solve(&(-world))).ok_or(ModelError::CabinMass)
    }
}
