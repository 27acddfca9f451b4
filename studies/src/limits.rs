//! What a run may cost, checked before anything is built: the number of steps (and that they
//! end exactly at the end time, or for the adaptive step that even its largest steps stay
//! within the cap), and the memory the models will take, estimated from the scene against what
//! the machine has.

use feedcore::scene::ValidScene;

/// Default cap on the macro steps of one run: 1000 s at h = 1 ms, or the bench reference
/// (100 s at 0.625 ms) six times over; about two minutes of IJCSA at ~100 µs per step.
pub const MAX_STEPS: u64 = 1_000_000;

/// Caps a run is checked against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub max_steps: u64,
    /// Memory a run may take, bytes; `None`: what the machine has available now.
    pub max_memory_bytes: Option<u64>,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { max_steps: MAX_STEPS, max_memory_bytes: None }
    }
}

/// Why a run is refused before it starts.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error("the step h = {0} s must be a positive finite number")]
    BadStep(f64),
    #[error("the end time {0} s must be a positive finite number")]
    BadEnd(f64),
    #[error(
        "the end time {} s is not a whole number of steps h = {} s ({} steps); {}",
        num(*.t_end), num(*.dt), num(*.ratio), suggest(*.below, *.above)
    )]
    NotMultiple { dt: f64, t_end: f64, ratio: f64, below: f64, above: f64 },
    #[error(
        "{} steps (t_end {} s / h {} s) exceed the cap of {cap} steps; raise it with --max-steps if that many \
         are meant",
        num(*.steps), num(*.t_end), num(*.dt)
    )]
    TooManySteps { steps: f64, dt: f64, t_end: f64, cap: u64 },
    #[error(
        "{} steps even at the largest step --h-max {} s (t_end {} s) exceed the cap of {cap} steps; raise --h-max, \
         or --max-steps if that many are meant",
        num(*.steps), num(*.h_max), num(*.t_end)
    )]
    AdaptiveTooManySteps { steps: f64, h_max: f64, t_end: f64, cap: u64 },
    #[error("the smallest step {} s and the largest {} s must satisfy 0 < h-min ≤ h-max", num(*.h_min), num(*.h_max))]
    BadStepRange { h_min: f64, h_max: f64 },
    #[error(
        "the models would need about {} MB ({what}), more than the {} MB {source_of_limit}; use fewer \
         cables.elements{hint}, or raise the limit with --max-memory-mb",
        .needed / 1_000_000, .limit / 1_000_000
    )]
    Memory { needed: u64, limit: u64, what: String, source_of_limit: &'static str, hint: &'static str },
}

/// A number for a message: 9 significant digits, exponent form when very large or small.
pub fn num(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e7).contains(&x.abs()) {
        format!("{x:.4e}")
    } else {
        let s = format!("{x:.9}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn suggest(below: f64, above: f64) -> String {
    if num(below) == num(above) {
        format!("use an end time of {} s, or a step that divides it", num(above))
    } else {
        format!("use an end time of {} s or {} s, or a step that divides it", num(below), num(above))
    }
}

/// The steps of a run: `steps` of `dt` reach `t_end` exactly (to round-off).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub dt: f64,
    pub t_end: f64,
    pub steps: u64,
}

/// How far `t_end / dt` may be from a whole number and still count as one (relative).
const WHOLE: f64 = 1e-9;

impl Plan {
    /// Checks the step against the end time and the step cap.
    pub fn new(dt: f64, t_end: f64, limits: &Limits) -> Result<Plan, PlanError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(PlanError::BadStep(dt));
        }
        if !(t_end > 0.0 && t_end.is_finite()) {
            return Err(PlanError::BadEnd(t_end));
        }
        let ratio = t_end / dt;
        if !(ratio <= limits.max_steps as f64 + 0.5) {
            return Err(PlanError::TooManySteps { steps: ratio.round(), dt, t_end, cap: limits.max_steps });
        }
        let steps = ratio.round();
        if steps < 1.0 || (ratio - steps).abs() > WHOLE * ratio {
            let (lo, hi) = (ratio.floor(), ratio.ceil().max(1.0));
            return Err(PlanError::NotMultiple {
                dt,
                t_end,
                ratio,
                below: if lo >= 1.0 { lo * dt } else { dt },
                above: hi * dt,
            });
        }
        Ok(Plan { dt, t_end, steps: steps as u64 })
    }

    /// Time at the end of step `k` (1-based); the last is `t_end` itself. Every step is `dt`
    /// long: `t_end` is a whole number of steps to round-off (checked in [`Plan::new`]).
    pub fn time(&self, k: u64) -> f64 {
        if k == self.steps { self.t_end } else { k as f64 * self.dt }
    }
}

/// How the steps of a run are taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Schedule {
    /// `steps` steps of `dt`, the last ending at `t_end`.
    Fixed(Plan),
    /// Steps within `[h_min, h_max]` chosen as the run goes (the adaptive step), the last
    /// landing on `t_end`; at most `max_steps` of them.
    Adaptive { t_end: f64, h_min: f64, h_max: f64, max_steps: u64 },
}

impl Schedule {
    /// Checks an adaptive run: the end time, the step range, and that even steps of `h_max`
    /// stay within the step cap (a run that needs more steps stops when it reaches the cap).
    pub fn adaptive(t_end: f64, h_min: f64, h_max: f64, limits: &Limits) -> Result<Schedule, PlanError> {
        if !(t_end > 0.0 && t_end.is_finite()) {
            return Err(PlanError::BadEnd(t_end));
        }
        if !(h_min > 0.0 && h_max.is_finite() && h_min <= h_max) {
            return Err(PlanError::BadStepRange { h_min, h_max });
        }
        let fewest = (t_end / h_max).ceil();
        if fewest > limits.max_steps as f64 {
            return Err(PlanError::AdaptiveTooManySteps { steps: fewest, h_max, t_end, cap: limits.max_steps });
        }
        Ok(Schedule::Adaptive { t_end, h_min, h_max, max_steps: limits.max_steps })
    }

    pub fn t_end(&self) -> f64 {
        match self {
            Schedule::Fixed(p) => p.t_end,
            Schedule::Adaptive { t_end, .. } => *t_end,
        }
    }
}

/// What the models of a run hold in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Footprint {
    /// The cable–cabin model alone.
    CableModel,
    /// The monolithic model, or the FMUs of a co-simulation.
    Coupled,
}

/// Fixed cost of the process and the models: measured 6.1 MB for `master statics` and 6.3 MB
/// for `master modes` at 20 elements per cable; the FMUs of a co-simulation (two libraries,
/// their unpacked archives) add a few MB more.
const BASE_BYTES_CABLE: u64 = 8_000_000;
const BASE_BYTES_COUPLED: u64 = 16_000_000;
/// Bytes per cable node (3 unknowns, element data, the block-tridiagonal matrix and its factor,
/// states kept for rollback). Measured on pose C with 2000 and 8000 elements per cable:
/// 1.2 kB for the cable model alone, 5.2 kB for the monolithic model.
const NODE_BYTES_CABLE: u64 = 1_500;
const NODE_BYTES_COUPLED: u64 = 6_000;
/// Elements per cable the run will build: the scene's, or a larger override set on an FMU
/// through `[system.parameters]` (`<fmu>.elements_per_cable`).
pub fn elements_per_cable(scene: &ValidScene) -> u64 {
    let overridden = scene
        .system
        .iter()
        .flat_map(|s| s.parameters.iter())
        .filter_map(|(k, v)| k.ends_with(".elements_per_cable").then(|| v.trim().parse::<u64>().ok()).flatten());
    overridden.fold(scene.cables.elements as u64, u64::max)
}

/// Estimated peak memory (bytes) of a run or analysis of `scene` that computes `modes` natural
/// modes (0: none; the damping fit's own modes are counted anyway), and what dominates it.
pub fn memory_needed(scene: &ValidScene, footprint: Footprint, modes: usize) -> (u64, String) {
    let cables = scene.cable_count() as u64;
    let elements = elements_per_cable(scene);
    let nodes = cables.saturating_mul(elements);
    let (base, per_node) = match footprint {
        Footprint::CableModel => (BASE_BYTES_CABLE, NODE_BYTES_CABLE),
        Footprint::Coupled => (BASE_BYTES_COUPLED, NODE_BYTES_COUPLED),
    };
    let linear = nodes.saturating_mul(per_node);
    let mut total = base.saturating_add(linear);
    let mut what = format!("{cables} cables × {elements} elements");
    let modes = scene.damping.fit_modes.map_or(0, |m| m[1]).max(modes);
    if modes > 0 {
        // unknowns of the free nodes and the cabin
        let n = 3u64.saturating_mul(cables).saturating_mul(elements.saturating_sub(1)).saturating_add(6);
        let basis = cable::modes::memory_estimate(n as f64, modes);
        total = total.saturating_add(basis as u64);
        what.push_str(&format!(", {modes} modes of {n} unknowns"));
    }
    (total, what)
}

/// Memory the machine has available now (`MemAvailable` of /proc/meminfo), bytes.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// The peak resident memory of this process so far (`VmHWM` of /proc/self/status), bytes.
pub fn peak_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// Refuses a run whose estimated memory exceeds the limit (or what is available).
pub fn check_memory(scene: &ValidScene, footprint: Footprint, modes: usize, limits: &Limits) -> Result<(), PlanError> {
    check_memory_of(scene, footprint, modes, 1, limits)
}

/// Refuses `copies` runs at once (parallel workers) whose estimated memory together exceeds
/// the limit (or what is available).
pub fn check_memory_of(
    scene: &ValidScene,
    footprint: Footprint,
    modes: usize,
    copies: u64,
    limits: &Limits,
) -> Result<(), PlanError> {
    let (limit, source_of_limit) = match limits.max_memory_bytes {
        Some(b) => (b, "allowed by --max-memory-mb"),
        None => match available_memory() {
            Some(b) => (b, "available on this machine"),
            None => return Ok(()),
        },
    };
    let (one, mut what) = memory_needed(scene, footprint, modes);
    let needed = one.saturating_mul(copies.max(1));
    if copies > 1 {
        what.push_str(&format!(", on {copies} workers at once"));
    }
    if needed <= limit {
        return Ok(());
    }
    let hint = if copies > 1 {
        " (or fewer workers with --jobs)"
    } else if scene.damping.fit_modes.is_some() {
        " (or damping.fit_frequencies_hz instead of fit_modes: no eigen solve)"
    } else {
        ""
    };
    Err(PlanError::Memory { needed, limit, what, source_of_limit, hint })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_must_reach_the_end_time_exactly() {
        let l = Limits::default();
        assert_eq!(Plan::new(0.01, 1.0, &l).unwrap().steps, 100);
        assert_eq!(Plan::new(0.1, 0.3, &l).unwrap().steps, 3); // 0.3 / 0.1 = 2.9999999999999996
        let e = Plan::new(0.3, 1.0, &l).unwrap_err();
        assert!(matches!(e, PlanError::NotMultiple { .. }), "{e}");
        assert!(e.to_string().contains("0.9") && e.to_string().contains("1.2"), "{e}");
        assert!(matches!(Plan::new(5.0, 1.0, &l).unwrap_err(), PlanError::NotMultiple { .. }));
        assert!(matches!(Plan::new(-0.01, 1.0, &l).unwrap_err(), PlanError::BadStep(_)));
        assert!(matches!(Plan::new(0.01, f64::NAN, &l).unwrap_err(), PlanError::BadEnd(_)));
        assert!(matches!(Plan::new(1e-9, 1.0, &l).unwrap_err(), PlanError::TooManySteps { .. }));
        assert!(matches!(Plan::new(0.01, 1e300, &l).unwrap_err(), PlanError::TooManySteps { .. }));
        let more = Limits { max_steps: 10_000_000, ..l };
        assert_eq!(Plan::new(1e-7, 1.0, &more).unwrap().steps, 10_000_000);
        let p = Plan::new(0.1, 0.3, &l).unwrap();
        assert_eq!(p.time(3), 0.3);
    }

    #[test]
    fn adaptive_runs_are_checked_against_the_cap_at_their_largest_step() {
        let l = Limits { max_steps: 1000, ..Limits::default() };
        // the end time need not be a multiple of any step
        assert!(matches!(Schedule::adaptive(0.37, 1e-5, 0.1, &l), Ok(Schedule::Adaptive { t_end: 0.37, .. })));
        // 100 s at h-max 0.1 s: 1000 steps fit; at 0.05 s, 2000 do not
        assert!(Schedule::adaptive(100.0, 1e-5, 0.1, &l).is_ok());
        let e = Schedule::adaptive(100.0, 1e-5, 0.05, &l).unwrap_err();
        assert!(matches!(e, PlanError::AdaptiveTooManySteps { .. }), "{e}");
        assert!(e.to_string().contains("2000 steps") && e.to_string().contains("--h-max"), "{e}");
        assert!(matches!(Schedule::adaptive(1.0, 0.2, 0.1, &l).unwrap_err(), PlanError::BadStepRange { .. }));
        assert!(matches!(Schedule::adaptive(f64::INFINITY, 1e-5, 0.1, &l).unwrap_err(), PlanError::BadEnd(_)));
        assert!(matches!(Schedule::adaptive(1.0, 0.0, 0.1, &l).unwrap_err(), PlanError::BadStepRange { .. }));
    }
}
