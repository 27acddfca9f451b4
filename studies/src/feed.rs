//! The feed in the world frame (scene `[control]`): its position and tilt error against the
//! target, the leg lengths and actuator forces, and the leg-stroke and actuator-force limits —
//! recorded at every step, reported when reached (never clipped).
//!
//! The feed is placed from the cabin's pose (the cable–cabin model's) and the platform's pose
//! relative to the cabin: `feed = p + R (c + Q f)`, the platform's attitude `R Q`; the tilt error
//! is the angle of the feed's axis from its start direction.

use std::io::Write;

use feedcore::scene::LEGS;
use feedcore::{Quat, Vec3};
use serde::Serialize;
use stewart::Compensation;

/// The feed and the legs after one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FeedSample {
    /// Feed position minus target, world frame, mm.
    pub err_mm: [f64; 3],
    /// Angle of the feed's axis from its start direction, mrad.
    pub tilt_mrad: f64,
    pub legs_m: [f64; LEGS],
    /// Actuator tensions, N.
    pub forces_n: [f64; LEGS],
    /// With an inertial unit: the estimated cabin position minus the true one (world, mm) and
    /// the angle between the estimated and the true attitude (mrad).
    pub estimate_err: Option<[f64; 4]>,
}

impl FeedSample {
    /// The feed of a cabin at (p, R) with the platform at `relative` (centre and orientation,
    /// cabin frame); `estimate`: the cabin pose the compensation estimates, with an inertial unit.
    pub fn place(
        c: &Compensation,
        t: f64,
        cabin: (&Vec3, &Quat),
        relative: (&Vec3, &Quat),
        legs_m: [f64; LEGS],
        forces_n: [f64; LEGS],
        estimate: Option<(Vec3, Quat)>,
    ) -> FeedSample {
        let ((p, r), (centre, turn)) = (cabin, relative);
        let attitude = r * turn;
        let (err, _) = c.feed_error(&(p + r * centre), &attitude, t);
        let estimate_err = estimate.map(|(position, orientation)| {
            let e = (position - p) * 1e3;
            // the angle of the rotation from the true attitude to the estimated one
            let q = (orientation * r.inverse()).into_inner();
            [e.x, e.y, e.z, 2.0 * q.imag().norm().atan2(q.w.abs()) * 1e3]
        });
        FeedSample {
            err_mm: (err * 1e3).into(),
            tilt_mrad: c.feed_tilt(&attitude) * 1e3,
            legs_m,
            forces_n,
            estimate_err,
        }
    }

    fn error_mm(&self) -> f64 {
        Vec3::from(self.err_mm).norm()
    }
}

/// A limit reached: when, which leg (1-based), what, the value and the limit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LimitEvent {
    pub time_s: f64,
    pub leg: usize,
    /// `shortest_leg`, `longest_leg` or `actuator_force`.
    pub limit: &'static str,
    pub value: f64,
    pub bound: f64,
}

/// Figures of the feed over every step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeedSummary {
    pub rms_mm: f64,
    pub peak_mm: f64,
    pub peak_time_s: f64,
    pub tilt_rms_mrad: f64,
    pub tilt_peak_mrad: f64,
    /// With an inertial unit: RMS of the estimate's position error (mm) and attitude error (mrad).
    pub estimate_rms: Option<(f64, f64)>,
    /// Every time a limit was reached (a leg staying beyond it counts once, until it returns).
    pub events: Vec<LimitEvent>,
}

/// The feed's record of a run.
#[derive(Clone, Debug, Default)]
pub struct FeedTrace {
    /// At the trace's sample times.
    pub samples: Vec<FeedSample>,
    pub summary: FeedSummary,
    legs: Option<[(f64, f64); LEGS]>,
    force: Option<f64>,
    /// Per leg: beyond its shortest, longest, force limit now.
    beyond: [[bool; 3]; LEGS],
    sum_sq: f64,
    tilt_sum_sq: f64,
    estimate_sum_sq: (f64, f64),
    steps: u64,
    /// Whether the compensation has an estimate (an inertial unit): its columns are written.
    fused: bool,
}

impl FeedTrace {
    pub fn new(c: &Compensation) -> FeedTrace {
        FeedTrace { legs: c.leg_limits(), force: c.force_limit(), fused: c.estimates(), ..Default::default() }
    }

    /// CSV column names of the feed, in [`FeedTrace::write_row`] order.
    pub fn csv_header(&self) -> String {
        let mut h = String::from("feed_err_x_mm,feed_err_y_mm,feed_err_z_mm,feed_err_tilt_mrad");
        for k in 1..=LEGS {
            h += &format!(",leg{k}_m");
        }
        for k in 1..=LEGS {
            h += &format!(",actuator{k}_n");
        }
        if self.fused {
            h += ",estimate_err_x_mm,estimate_err_y_mm,estimate_err_z_mm,estimate_err_rot_mrad";
        }
        h
    }

    /// The feed after a step at time `t`; `keep`: a sample time of the trace.
    pub fn observe(&mut self, t: f64, s: &FeedSample, keep: bool) {
        let e = s.error_mm();
        self.sum_sq += e * e;
        self.tilt_sum_sq += s.tilt_mrad * s.tilt_mrad;
        self.steps += 1;
        let sum = &mut self.summary;
        sum.rms_mm = (self.sum_sq / self.steps as f64).sqrt();
        sum.tilt_rms_mrad = (self.tilt_sum_sq / self.steps as f64).sqrt();
        if let Some([x, y, z, rot]) = s.estimate_err.filter(|_| self.fused) {
            self.estimate_sum_sq.0 += x * x + y * y + z * z;
            self.estimate_sum_sq.1 += rot * rot;
            let n = self.steps as f64;
            sum.estimate_rms = Some(((self.estimate_sum_sq.0 / n).sqrt(), (self.estimate_sum_sq.1 / n).sqrt()));
        }
        if e > sum.peak_mm {
            sum.peak_mm = e;
            sum.peak_time_s = t;
        }
        sum.tilt_peak_mrad = sum.tilt_peak_mrad.max(s.tilt_mrad);
        for k in 0..LEGS {
            let (lo, hi) = self.legs.map_or((f64::NEG_INFINITY, f64::INFINITY), |l| l[k]);
            let force = self.force.unwrap_or(f64::INFINITY);
            let checks = [
                ("shortest_leg", s.legs_m[k] < lo, s.legs_m[k], lo),
                ("longest_leg", s.legs_m[k] > hi, s.legs_m[k], hi),
                ("actuator_force", s.forces_n[k].abs() > force, s.forces_n[k], force),
            ];
            for (i, (limit, beyond, value, bound)) in checks.into_iter().enumerate() {
                if beyond && !self.beyond[k][i] {
                    sum.events.push(LimitEvent { time_s: t, leg: k + 1, limit, value, bound });
                }
                self.beyond[k][i] = beyond;
            }
        }
        if keep {
            self.samples.push(*s);
        }
    }

    /// The feed columns of sample `i`, each with a leading comma.
    pub fn write_row(&self, f: &mut dyn Write, i: usize) -> std::io::Result<()> {
        let s = &self.samples[i];
        for x in s.err_mm.iter().chain([s.tilt_mrad].iter()).chain(&s.legs_m).chain(&s.forces_n) {
            write!(f, ",{x:e}")?;
        }
        if self.fused {
            for x in s.estimate_err.unwrap_or([f64::NAN; 4]) {
                write!(f, ",{x:e}")?;
            }
        }
        Ok(())
    }

    /// The JSON figures.
    pub fn json(&self) -> serde_json::Value {
        let s = &self.summary;
        let mut v = serde_json::json!({
            "feed_err_rms_mm": s.rms_mm,
            "feed_err_peak_mm": s.peak_mm,
            "feed_err_peak_time_s": s.peak_time_s,
            "feed_err_tilt_rms_mrad": s.tilt_rms_mrad,
            "feed_err_tilt_peak_mrad": s.tilt_peak_mrad,
            "limit_events": s.events,
        });
        if let Some((position, rotation)) = s.estimate_rms {
            v["estimate_err_rms_mm"] = position.into();
            v["estimate_err_rot_rms_mrad"] = rotation.into();
        }
        v
    }
}
