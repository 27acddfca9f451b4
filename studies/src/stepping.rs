//! The step loop every run goes through, whatever it steps (the LT50m methods, any system of
//! FMUs): fixed steps whose last ends exactly at the end time, or adaptive steps whose last lands
//! on it; the step cap; what the caller watches of it; the totals of every step (steps,
//! iterations, rejected tries, the step sizes, the largest interface residual, which must stay
//! finite).

use crate::limits::Schedule;

/// What a caller watches of a run as it steps: a progress bar, a callback that may stop it.
pub trait Watch {
    /// The run starts on `schedule`.
    fn start(&mut self, _schedule: &Schedule) {}
    /// Step `k` ended at `t`; an error stops the run with that reason.
    fn stepped(&mut self, _k: u64, _t: f64) -> Result<(), String> {
        Ok(())
    }
    /// The run reached its end.
    fn finish(&mut self) {}
}

/// Nothing watches the run.
pub struct Unwatched;

impl Watch for Unwatched {}

/// What the loop asks of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// A step of exactly `h` ending at `t`.
    Fixed { h: f64, t: f64 },
    /// One accepted adaptive step, ending at most at `t_stop`.
    Adaptive { t_stop: f64 },
}

/// What one step did.
#[derive(Clone, Debug)]
pub struct Step<P> {
    /// The step taken, s.
    pub h: f64,
    /// Tries rejected before it (the adaptive step).
    pub rejected: usize,
    /// System evaluations, or Newton iterations, of the step.
    pub iterations: usize,
    /// Largest scaled interface residual at its end (0 where there is no interface).
    pub residual: f64,
    /// What the caller observes after it (e.g. the cabin pose).
    pub payload: P,
}

/// A step taken, or the run ended on purpose by one of its units (e.g. an FMU returning
/// fmi2Discard) with the reason.
pub enum Flow<P> {
    Stepped(Step<P>),
    Ended(String),
}

/// Totals over every step of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Totals {
    pub steps: u64,
    pub iterations: u64,
    pub rejected: u64,
    /// Smallest and largest step taken, s (0 before any step).
    pub h_min: f64,
    pub h_max: f64,
    pub max_residual: f64,
    /// Set when a unit ended the run early: the time reached and why.
    pub ended: Option<(f64, String)>,
}

/// Takes the steps of `schedule` with `step`, then shows each to `after` (its number, the time
/// at its end — the end time itself after the last — and the step) and to `watch`.
/// `stopped(t, reason)` makes the error of a run that must stop at `t`: a non-finite interface
/// residual, an adaptive run that reached the step cap, or the watcher's reason.
pub fn drive<P, E>(
    schedule: &Schedule,
    watch: &mut dyn Watch,
    stopped: impl Fn(f64, String) -> E,
    mut step: impl FnMut(Request) -> Result<Flow<P>, E>,
    mut after: impl FnMut(u64, f64, &Step<P>) -> Result<(), E>,
) -> Result<Totals, E> {
    watch.start(schedule);
    let mut totals = Totals { h_min: f64::INFINITY, ..Totals::default() };
    let (mut k, mut t) = (0u64, 0.0f64);
    loop {
        let request = match *schedule {
            Schedule::Fixed(plan) if k == plan.steps => break,
            Schedule::Fixed(plan) => Request::Fixed { h: plan.dt, t: plan.time(k + 1) },
            Schedule::Adaptive { t_end, .. } if t >= t_end => break,
            Schedule::Adaptive { max_steps, .. } if k == max_steps => {
                return Err(stopped(
                    t,
                    format!(
                        "the adaptive step reached the cap of {max_steps} steps before the end time (steps of {:.3e} \
                         … {:.3e} s so far); raise it with --max-steps, or loosen --rtol",
                        totals.h_min, totals.h_max
                    ),
                ));
            }
            Schedule::Adaptive { t_end, .. } => Request::Adaptive { t_stop: t_end },
        };
        let s = match step(request)? {
            Flow::Stepped(s) => s,
            Flow::Ended(why) => {
                totals.ended = Some((t, why));
                break;
            }
        };
        k += 1;
        t = match (request, *schedule) {
            (Request::Fixed { t, .. }, _) => t,
            // the adaptive step's last step lands on the end time (to round-off)
            (Request::Adaptive { .. }, Schedule::Adaptive { t_end, .. }) if t + s.h >= t_end * (1.0 - 1e-12) => t_end,
            (Request::Adaptive { .. }, _) => t + s.h,
        };
        if !s.residual.is_finite() {
            return Err(stopped(t, format!("the interface residual is {}", s.residual)));
        }
        totals.steps = k;
        totals.iterations += s.iterations as u64;
        totals.rejected += s.rejected as u64;
        totals.h_min = totals.h_min.min(s.h);
        totals.h_max = totals.h_max.max(s.h);
        totals.max_residual = totals.max_residual.max(s.residual);
        after(k, t, &s)?;
        watch.stepped(k, t).map_err(|reason| stopped(t, reason))?;
    }
    watch.finish();
    if totals.steps == 0 {
        totals.h_min = 0.0;
    }
    Ok(totals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::limits::{Limits, Plan};

    fn unit(h: f64) -> Result<Flow<()>, String> {
        Ok(Flow::Stepped(Step { h, rejected: 1, iterations: 2, residual: 1e-9, payload: () }))
    }

    #[test]
    fn fixed_steps_end_exactly_at_the_end_time() {
        let plan = Plan::new(0.1, 0.3, &Limits::default()).unwrap();
        let mut times = Vec::new();
        let totals = drive(
            &Schedule::Fixed(plan),
            &mut Unwatched,
            |t, r| format!("{t}: {r}"),
            |r| match r {
                Request::Fixed { h, .. } => unit(h),
                Request::Adaptive { .. } => Err("adaptive".into()),
            },
            |k, t, _| {
                times.push((k, t));
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(times, [(1, 0.1), (2, 0.2), (3, 0.3)]);
        assert_eq!((totals.steps, totals.iterations, totals.rejected), (3, 6, 3));
        assert_eq!((totals.h_min, totals.h_max, totals.max_residual), (0.1, 0.1, 1e-9));
    }

    /// Steps that double until the stop, the last cut to land on it: the loop ends at the end
    /// time exactly, and the cap stops a run that would need more steps.
    #[test]
    fn adaptive_steps_land_on_the_end_time_and_obey_the_cap() {
        let schedule = Schedule::adaptive(1.0, 1e-3, 0.5, &Limits::default()).unwrap();
        let (mut now, mut h) = (0.0f64, 0.01f64);
        let mut times = Vec::new();
        let totals = drive(
            &schedule,
            &mut Unwatched,
            |t, r| format!("{t}: {r}"),
            |r| {
                let Request::Adaptive { t_stop } = r else { return Err("fixed".into()) };
                let taken = h.min(t_stop - now);
                now += taken;
                h *= 2.0;
                unit(taken)
            },
            |_, t, _| {
                times.push(t);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(*times.last().unwrap(), 1.0);
        assert_eq!((totals.steps, times.len()), (7, 7));
        // 0.01, 0.02, … 0.32, then the 0.37 s left
        assert_eq!(totals.h_min, 0.01);
        assert!((totals.h_max - 0.37).abs() < 1e-12, "{}", totals.h_max);
        // the same run under a cap of 3 steps stops at the cap, saying so
        let capped = Schedule::Adaptive { t_end: 1.0, h_min: 1e-3, h_max: 0.5, max_steps: 3 };
        let e =
            drive(&capped, &mut Unwatched, |t, r| format!("{t}: {r}"), |_| unit(0.01), |_, _, _| Ok(())).unwrap_err();
        assert!(e.starts_with("0.03") && e.contains("cap of 3 steps") && e.contains("--max-steps"), "{e}");
    }

    #[test]
    fn a_non_finite_residual_stops_the_run_and_an_ended_unit_ends_it() {
        let plan = Schedule::Fixed(Plan::new(0.1, 1.0, &Limits::default()).unwrap());
        let mut k = 0;
        let e = drive(
            &plan,
            &mut Unwatched,
            |t, r| format!("{t}: {r}"),
            |_| {
                k += 1;
                Ok(Flow::Stepped(Step {
                    h: 0.1,
                    rejected: 0,
                    iterations: 1,
                    residual: if k == 4 { f64::NAN } else { 0.0 },
                    payload: (),
                }))
            },
            |_, _, _| Ok(()),
        )
        .unwrap_err();
        assert_eq!(e, "0.4: the interface residual is NaN");
        let mut k = 0;
        let totals = drive(
            &plan,
            &mut Unwatched,
            |t, r| format!("{t}: {r}"),
            |_| {
                k += 1;
                if k == 3 { Ok(Flow::Ended("done".into())) } else { unit(0.1) }
            },
            |_, _, _| Ok(()),
        )
        .unwrap();
        assert_eq!((totals.steps, totals.ended), (2, Some((0.2, "done".to_string()))));
    }
}
