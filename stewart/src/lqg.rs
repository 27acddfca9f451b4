//! The second level's LQG law (`[control] law = "lqg"`): at each reading of the inertial unit the
//! controller made from the scene's design model (`design::plant`, `design::lqg`) takes the
//! reading and any fix that has arrived, and returns the platform's pose command, applied at
//! once through the command filter's stages (the servo the design model holds).
//!
//! The readings enter as deviations from the unit's reading at rest, a fix as the cabin's
//! displacement from its reference position and its rotation vector from the reference attitude
//! (world frame). The fixes come every `fix_every` readings; the controller's gains repeat with
//! that period, counted from the last fix that arrived. A fix that does not come when one is due
//! (at the start, before the first has travelled its delay) counts as read as predicted; one that
//! comes sooner than the design's delay is held until it is as old as the design assumes.

use std::collections::VecDeque;

use design::lqg::{Controller, ControllerState};
use feedcore::scene::ValidScene;
use feedcore::{Quat, Vec3};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::imu::{Imu, ImuState};
use crate::wrench::CabinMotion;

/// Two instants closer than this are the same instant, s.
const SAME_INSTANT: f64 = 1e-9;

/// The law of one scene (immutable).
#[derive(Clone, Debug, PartialEq)]
pub struct LqgLaw {
    pub(crate) imu: Imu,
    controller: Controller,
    fix_every: usize,
    /// The delay the design assumes, readings.
    delay_steps: usize,
    /// The unit's reading at rest at the reference attitude, cabin frame.
    rest_reading: Vec3,
    /// The cabin's pose deviation (displacement, rotation) from the controller's state.
    cabin_map: DMatrix<f64>,
    reference: (Vec3, Quat),
    gravity: Vec3,
}

/// What the law carries from reading to reading.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct LqgState {
    imu: ImuState,
    controller: ControllerState,
    /// Index k of the next reading, taken at the first communication point ≥ k·T.
    next_reading: u64,
    /// The gains' phase at the last reading: readings since the last fix, modulo the period.
    phase: usize,
    /// Fixes measured and not yet arrived: (time measured, deviation).
    fixes: VecDeque<(f64, [f64; 6])>,
}

impl Clone for LqgState {
    fn clone(&self) -> Self {
        LqgState {
            imu: self.imu,
            controller: self.controller.clone(),
            next_reading: self.next_reading,
            phase: self.phase,
            fixes: self.fixes.clone(),
        }
    }

    /// Reuses the storage (snapshots taken every step allocate nothing).
    fn clone_from(&mut self, source: &Self) {
        self.imu = source.imu;
        self.controller.copy_from(&source.controller);
        self.next_reading = source.next_reading;
        self.phase = source.phase;
        self.fixes.clone_from(&source.fixes);
    }
}

impl LqgLaw {
    /// The law of a scene with `law = "lqg"`: its controller synthesized from `[control.lqg]`
    /// with the scene's instruments (None for another law).
    pub fn of_scene(scene: &ValidScene) -> Result<Option<LqgLaw>, String> {
        let Some(control) = scene.control.as_ref().filter(|c| c.lqg_design().is_some()) else { return Ok(None) };
        let spec = control.imu.as_ref().ok_or("law = \"lqg\" without [control.imu]")?;
        let plant = design::plant::of_scene(scene).map_err(|e| e.to_string())?;
        let syn =
            design::lqg::synthesize(&plant.plant).map_err(|e| format!("the LQG controller of [control.lqg]: {e}"))?;
        let (n, nc) = (plant.plant.states(), plant.plant.continuous_states());
        let mut cabin_map = DMatrix::zeros(6, n);
        cabin_map.view_mut((0, 0), (6, nc)).copy_from(&plant.cabin.0);
        let reference = (scene.target_position(), scene.target_orientation());
        Ok(Some(LqgLaw {
            imu: Imu::new(spec, scene.gravity()),
            controller: syn.controller,
            fix_every: plant.fix_every,
            delay_steps: plant.delay_steps,
            rest_reading: -reference.1.inverse_transform_vector(&scene.gravity()),
            cabin_map,
            reference,
            gravity: scene.gravity(),
        }))
    }

    pub fn start(&self) -> LqgState {
        let p = self.fix_every;
        LqgState {
            imu: self.imu.start(),
            controller: self.controller.start(),
            next_reading: 0,
            // so that the first reading is at phase −d (mod p): a fix measured then arrives at phase 0
            phase: (2 * p - 1 - self.delay_steps % p) % p,
            fixes: VecDeque::new(),
        }
    }

    /// The fix of a measured cabin pose, as the controller reads it.
    pub fn fix(&self, position: &Vec3, attitude: &Quat) -> [f64; 6] {
        let d = position - self.reference.0;
        let r = (attitude * self.reference.1.inverse()).scaled_axis();
        [d.x, d.y, d.z, r.x, r.y, r.z]
    }

    /// Whether a reading is due at `t`.
    pub fn reading_due(&self, s: &LqgState, t: f64) -> bool {
        (s.next_reading as f64) * self.imu.period <= t + SAME_INSTANT
    }

    /// Keeps a fix measured at `t` until it arrives.
    pub fn add_fix(&self, s: &mut LqgState, t: f64, fix: [f64; 6]) {
        s.fixes.push_back((t, fix));
    }

    /// The reading at `t` of the cabin moving as `cabin`, with the fixes that have arrived by
    /// then (`delay` after they were measured): the new command (pose deviation from rest).
    pub fn read(&self, s: &mut LqgState, cabin: &CabinMotion, t: f64, delay: f64) -> [f64; 6] {
        let reading = self.imu.read(&mut s.imu, cabin, t);
        let mut arrived = None;
        // a fix is taken when it has arrived and is as old as the design assumes (one that came
        // sooner is held: the controller reads its age from its phase)
        let age = delay.max(self.delay_steps as f64 * self.imu.period);
        while let Some(&(measured, fix)) = s.fixes.front() {
            if measured + age > t + SAME_INSTANT {
                break;
            }
            s.fixes.pop_front();
            arrived = Some(fix);
        }
        s.phase = if arrived.is_some() { 0 } else { (s.phase + 1) % self.fix_every };
        let mut y = [0.0; 12];
        // the reading's deviation less what the gravity's turning adds beyond first order at the
        // estimated attitude (its linear part the model holds)
        let (_, turned) = self.estimate(s);
        let tilt = (turned * self.reference.1.inverse()).scaled_axis();
        let exact = -turned.inverse_transform_vector(&self.gravity);
        let linear = self.rest_reading + self.reference.1.inverse_transform_vector(&tilt.cross(&self.gravity));
        let force = Vec3::from(reading.specific_force) - self.rest_reading - (exact - linear);
        y[..3].copy_from_slice(force.as_slice());
        y[3..6].copy_from_slice(&reading.angular_rate);
        let present = match arrived {
            Some(fix) => {
                y[6..].copy_from_slice(&fix);
                12
            }
            None => 6,
        };
        s.next_reading = ((t + SAME_INSTANT) / self.imu.period).floor() as u64 + 1;
        let u = self.controller.step(&mut s.controller, s.phase, &y, present);
        std::array::from_fn(|i| u[i])
    }

    /// The controller's estimate of the cabin's pose after its last reading.
    pub fn estimate(&self, s: &LqgState) -> (Vec3, Quat) {
        let x = s.controller.estimate();
        let mut pose = [0.0; 6];
        for (i, p) in pose.iter_mut().enumerate() {
            *p = (0..x.len()).map(|j| self.cabin_map[(i, j)] * x[j]).sum();
        }
        (
            self.reference.0 + Vec3::new(pose[0], pose[1], pose[2]),
            Quat::from_scaled_axis(Vec3::new(pose[3], pose[4], pose[5])) * self.reference.1,
        )
    }
}
