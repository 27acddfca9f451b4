//! The feed's error over a run of the monolithic model: what the second level's figures are
//! measured from (every step counted, t = 0 included, as `master run` counts them).

use feedcore::scene::ValidScene;

use crate::{Monolithic, MonolithicError};

/// RMS and peak of the feed's position error (m) and the RMS of its axis's tilt (rad), and the
/// steps at which a leg or an actuator was beyond its limit.
#[derive(Clone, Debug, PartialEq)]
pub struct FeedRun {
    pub rms_m: f64,
    pub peak_m: f64,
    pub tilt_rms_rad: f64,
    pub steps_beyond_limits: usize,
    pub steps: usize,
}

/// The largest step for the second level's sensors: a whole fraction of the shortest sample
/// period, at most an eighth of it and 2.5 ms (`master tune`'s and `master compensation`'s).
pub fn step_for(scene: &ValidScene) -> f64 {
    let period = scene.control.as_ref().and_then(|c| c.shortest_period()).map_or(f64::NAN, |(t, _)| t);
    period / (period / 0.0025 - 1e-9).ceil().max(8.0)
}

#[derive(Debug, thiserror::Error)]
pub enum FeedError {
    #[error(transparent)]
    Model(#[from] MonolithicError),
    #[error("the scene has no [control]: no feed to follow")]
    NoControl,
    #[error("the feed error is not finite at t = {0} s")]
    NotFinite(f64),
}

/// Runs `scene` from its start for `steps` steps of `h`.
pub fn feed_run(scene: &ValidScene, h: f64, steps: usize) -> Result<FeedRun, FeedError> {
    let mut m = Monolithic::new(scene)?;
    let comp = m.compensation().cloned().ok_or(FeedError::NoControl)?;
    let (legs, force) = (comp.leg_limits(), comp.force_limit());
    let (mut sum, mut peak, mut tilt, mut beyond) = (0.0, 0.0f64, 0.0, 0usize);
    for step in 0..=steps {
        if step > 0 {
            m.step(h)?;
        }
        let s = m.sample();
        let (p, r) = (&s.cabin.position, &s.cabin.orientation);
        let attitude = r * s.platform_rotation;
        let (error, _) = comp.feed_error(&(p + r * s.platform), &attitude, s.time);
        let e = error.norm();
        if !e.is_finite() {
            return Err(FeedError::NotFinite(s.time));
        }
        sum += e * e;
        peak = peak.max(e);
        tilt += comp.feed_tilt(&attitude).powi(2);
        let out_of_range = |x: f64, (lo, hi): (f64, f64)| x < lo || x > hi;
        let leg_beyond = legs.is_some_and(|l| (0..l.len()).any(|k| out_of_range(s.leg_lengths[k], l[k])));
        let force_beyond = force.is_some_and(|f| s.actuator_forces.iter().any(|a| a.abs() > f));
        beyond += usize::from(leg_beyond || force_beyond);
    }
    let n = (steps + 1) as f64;
    Ok(FeedRun {
        rms_m: (sum / n).sqrt(),
        peak_m: peak,
        tilt_rms_rad: (tilt / n).sqrt(),
        steps_beyond_limits: beyond,
        steps,
    })
}
