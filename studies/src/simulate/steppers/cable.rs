//! The cable–cabin model alone, platform locked, under the scene's disturbance.

use cable::dynamics::{Dynamics, DynamicsError};
use cable::model::{CableCabin, Payload};
use feedcore::Vec3;
use feedcore::scene::ValidScene;
use nalgebra::Vector6;

use super::{Stepper, fixed, stopped, vec6};
use crate::net::Frame;
use crate::simulate::RunError;
use crate::simulate::record::{Observed, Probe, stepped};
use crate::stepping::{Request, Step};

pub(in crate::simulate) struct CableStepper {
    dynamics: Dynamics,
    disturbance: Option<feedcore::scene::Disturbance>,
    /// The time reached.
    time: f64,
    /// The platform's centre, locked at its start (cabin frame).
    platform: Vec3,
    method: &'static str,
}

impl CableStepper {
    pub(in crate::simulate) fn new(scene: &ValidScene, method: &'static str) -> Result<CableStepper, RunError> {
        let setup = |e: &(dyn std::error::Error + 'static)| RunError::setup(method, e);
        let model = CableCabin::build(scene, 0).map_err(|e| setup(&e))?;
        let disturbance = scene.disturbance.clone();
        let wrench = wrench_of(&disturbance, 0.0);
        let dynamics = model.dynamics_with(Payload::Locked, 0.0, &wrench).map_err(|e| setup(&e))?;
        let platform = scene.stewart_geometry().start_center;
        Ok(CableStepper { dynamics, disturbance, time: 0.0, platform, method })
    }
}

/// The disturbance's wrench on the cabin at `t` (none: zero).
fn wrench_of(disturbance: &Option<feedcore::scene::Disturbance>, t: f64) -> Vector6<f64> {
    Vector6::from(disturbance.as_ref().map_or([0.0; 6], |d| d.wrench(t)))
}

impl Stepper for CableStepper {
    fn probe(&mut self) -> Result<Probe, RunError> {
        let c = self.dynamics.cabin();
        let wrench = vec6(&wrench_of(&self.disturbance, self.time));
        Ok(Probe { position: c.position, orientation: c.orientation, wrench, feed: None })
    }

    fn step(&mut self, request: Request) -> Result<Step<Observed>, RunError> {
        let (h, t) = fixed(self.method, request)?;
        let s = self.dynamics.step(h, &wrench_of(&self.disturbance, t)).map_err(|e| match e {
            DynamicsError::Stopped { time, reason } => stopped(self.method, time, reason.to_string()),
            e => stopped(self.method, e.time().unwrap_or(t - h), e.to_string()),
        })?;
        self.time = t;
        Ok(stepped(h, s.iterations, 0.0, self.probe()?))
    }

    fn net(&mut self, frame: &mut Frame) -> bool {
        frame.fill_cables(self.dynamics.system(), self.dynamics.config());
        frame.time = self.time;
        frame.platform = (self.platform, feedcore::Quat::identity());
        frame.leg_forces = None;
        true
    }
}
