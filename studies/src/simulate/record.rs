//! What every step leaves: the probe of the model, and the recorder that checks it and keeps
//! the trace.

use feedcore::Vec3;

use super::{RunError, Trace};
use crate::feed::FeedSample;
use crate::stepping::Step;

/// The cabin pose and the wrench now (and the feed, with `[control]`).
pub(super) struct Probe {
    pub(super) position: Vec3,
    pub(super) orientation: feedcore::Quat,
    pub(super) wrench: [f64; 6],
    pub(super) feed: Option<FeedSample>,
}

/// Watches every step: refuses non-finite values, keeps the summary, samples every `every`
/// steps.
pub(super) struct Recorder {
    pub(super) trace: Trace,
    pub(super) every: u64,
    pub(super) origin: Option<(Vec3, feedcore::Quat)>,
    pub(super) method: &'static str,
}

impl Recorder {
    pub(super) fn stopped(&self, time: f64, reason: impl Into<String>) -> RunError {
        RunError::Stopped { method: self.method, time, reason: reason.into() }
    }

    /// The state after step `k` (0: the start) at time `t`.
    pub(super) fn observe(&mut self, k: u64, t: f64, p: &Probe) -> Result<(), RunError> {
        if crate::cancel::requested() {
            return Err(RunError::Interrupted { method: self.method, time: t });
        }
        let names = ["x", "y", "z"];
        for i in 0..3 {
            if !p.position[i].is_finite() {
                return Err(self.stopped(t, format!("the cabin position {} is {}", names[i], p.position[i])));
            }
        }
        if !p.orientation.coords.iter().all(|x| x.is_finite()) {
            return Err(self.stopped(t, "the cabin orientation is not finite"));
        }
        const WRENCH: [&str; 6] = ["Fx", "Fy", "Fz", "Mx", "My", "Mz"];
        if let Some(i) = p.wrench.iter().position(|x| !x.is_finite()) {
            return Err(self.stopped(t, format!("the wrench on the cabin {} is {}", WRENCH[i], p.wrench[i])));
        }
        let (p0, q0) = *self.origin.get_or_insert((p.position, p.orientation));
        let d = (p.position - p0) * 1e3;
        let s = &mut self.trace.summary;
        for i in 0..3 {
            s.max_abs_disp_mm[i] = s.max_abs_disp_mm[i].max(d[i].abs());
        }
        let distance = d.norm();
        if !distance.is_finite() {
            return Err(self.stopped(t, format!("the cabin displacement is {distance} mm")));
        }
        if distance > s.peak_mm {
            s.peak_mm = distance;
            s.peak_time_s = t;
        }
        if let (Some(trace), Some(sample)) = (self.trace.feed.as_mut(), p.feed.as_ref()) {
            let names = ["x", "y", "z"];
            if let Some(i) = sample.err_mm.iter().position(|x| !x.is_finite()) {
                return Err(self.stopped(t, format!("the feed error {} is {}", names[i], sample.err_mm[i])));
            }
            trace.observe(t, sample, k.is_multiple_of(self.every));
            let rms = trace.summary.rms_mm;
            if !rms.is_finite() {
                return Err(self.stopped(t, format!("the feed error's RMS is {rms} mm")));
            }
        }
        if k.is_multiple_of(self.every) {
            let r = (p.orientation * q0.inverse()).scaled_axis() * 1e3;
            self.trace.t.push(t);
            self.trace.disp_mm.push([d.x, d.y, d.z]);
            self.trace.rot_mrad.push([r.x, r.y, r.z]);
            self.trace.wrench.push(p.wrench);
        }
        Ok(())
    }
}

/// What a step of a method leaves to observe.
pub(super) struct Observed {
    pub(super) probe: Probe,
    /// Largest position-constraint residual (monolithic), m.
    pub(super) constraint_residual: f64,
}

/// A step of `h` with its cost and what it left.
pub(super) fn stepped(h: f64, iterations: usize, residual: f64, probe: Probe) -> Step<Observed> {
    Step { h, rejected: 0, iterations, residual, payload: Observed { probe, constraint_residual: 0.0 } }
}
