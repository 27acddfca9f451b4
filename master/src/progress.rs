//! A progress bar for long runs, drawn on one terminal line of stderr:
//!
//! ```text
//! [=========>              ]  38.2%  t 38.20/100.00 s  elapsed 0:05  left 0:08
//! ```
//!
//! Cheap enough to call every time step: [`Progress::update`] is one integer compare until the
//! step at which it next looks at the clock; that step is chosen from the measured step rate so
//! that the clock is read about every [`CHECK_INTERVAL`] and the line redrawn at most every
//! [`REDRAW_INTERVAL`]. Drawing formats into a buffer allocated once. The bar is off (every
//! update is the compare only) with `--quiet` or when stderr is not a terminal, and never draws
//! for runs shorter than one redraw interval.

use std::io::{self, IsTerminal, Write};
use std::time::{Duration, Instant};

/// Shortest time between two redraws.
pub const REDRAW_INTERVAL: Duration = Duration::from_millis(100);
/// About how often the clock is read while running.
pub const CHECK_INTERVAL: Duration = Duration::from_millis(25);
/// Width of the bar between the brackets, in characters (the whole line fits 80 columns).
const BAR_WIDTH: usize = 24;
/// The stride between clock reads never grows beyond this many steps.
const MAX_STRIDE: u64 = 1 << 20;

/// A monotonic clock: time since an arbitrary fixed origin. Injected so that tests control time.
pub trait Clock {
    fn now(&self) -> Duration;
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now(&self) -> Duration {
        (**self).now()
    }
}

/// The real clock ([`Instant`]).
#[derive(Clone, Copy, Debug)]
pub struct SystemClock {
    origin: Instant,
}

impl SystemClock {
    pub fn new() -> Self {
        Self { origin: Instant::now() }
    }
}

impl Default for SystemClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }
}

/// Estimated time left after `elapsed` for a run that is `fraction` done, assuming a constant
/// rate; `None` before any progress (nothing to extrapolate from) or for a non-finite fraction.
pub fn eta(elapsed: Duration, fraction: f64) -> Option<Duration> {
    if !(fraction > 0.0 && fraction.is_finite()) {
        return None;
    }
    let f = fraction.min(1.0);
    Duration::try_from_secs_f64(elapsed.as_secs_f64() * (1.0 - f) / f).ok()
}

/// Writes `d` as `m:ss`, or `h:mm:ss` from one hour on (whole seconds, rounded down).
pub fn write_duration(out: &mut impl Write, d: Duration) -> io::Result<()> {
    let s = d.as_secs();
    let (h, m, s) = (s / 3600, (s / 60) % 60, s % 60);
    if h > 0 { write!(out, "{h}:{m:02}:{s:02}") } else { write!(out, "{m}:{s:02}") }
}

/// The progress bar. `W` is where it draws (stderr), `C` its clock; both are parameters so
/// that tests can inject a buffer and a fake clock.
pub struct Progress<W: Write, C: Clock> {
    out: W,
    clock: C,
    total_steps: u64,
    t_end: f64,
    /// `update` does nothing but compare until `step >= next_check`; `u64::MAX` when off.
    next_check: u64,
    stride: u64,
    start: Duration,
    last_check: (u64, Duration),
    last_draw: Duration,
    drawn: bool,
    line: Vec<u8>,
}

impl Progress<io::Stderr, SystemClock> {
    /// A bar on stderr for a run of `total_steps` steps up to simulated time `t_end` (seconds);
    /// off when `quiet` or when stderr is not a terminal.
    pub fn stderr(total_steps: u64, t_end: f64, quiet: bool) -> Self {
        let enabled = !quiet && io::stderr().is_terminal();
        Self::with_parts(io::stderr(), SystemClock::new(), total_steps, t_end, enabled)
    }
}

impl<W: Write, C: Clock> Progress<W, C> {
    /// A bar drawing to `out` with `clock`; the run starts now (by `clock`).
    pub fn with_parts(out: W, clock: C, total_steps: u64, t_end: f64, enabled: bool) -> Self {
        let start = clock.now();
        Self {
            out,
            clock,
            total_steps,
            t_end,
            next_check: if enabled { 1 } else { u64::MAX },
            stride: 1,
            start,
            last_check: (0, start),
            // The first draw waits one redraw interval: short runs never show a bar.
            last_draw: start,
            drawn: false,
            line: Vec::with_capacity(128),
        }
    }

    /// Whether the bar can draw at all.
    pub fn is_enabled(&self) -> bool {
        self.next_check != u64::MAX
    }

    /// Reports that `step` of `total_steps` steps is done, at simulated time `t_sim`.
    #[inline]
    pub fn update(&mut self, step: u64, t_sim: f64) {
        if step >= self.next_check {
            self.check(step, t_sim);
        }
    }

    #[cold]
    #[inline(never)]
    fn check(&mut self, step: u64, t_sim: f64) {
        let now = self.clock.now();
        let (last_step, last_time) = self.last_check;
        let dt = now.saturating_sub(last_time);
        let ds = step.saturating_sub(last_step);
        // Aim the next clock read CHECK_INTERVAL ahead at the measured step rate; while the
        // clock shows no progress (coarse clock, very fast steps) double the stride instead.
        self.stride = if dt.is_zero() || ds == 0 {
            self.stride.saturating_mul(2)
        } else {
            (ds as f64 * CHECK_INTERVAL.as_secs_f64() / dt.as_secs_f64()) as u64
        }
        .clamp(1, MAX_STRIDE);
        self.last_check = (step, now);
        self.next_check = step.saturating_add(self.stride);
        if now.saturating_sub(self.last_draw) >= REDRAW_INTERVAL {
            self.last_draw = now;
            // A terminal that went away is no reason to stop a simulation: drop the bar.
            if self.draw(step, t_sim, now).is_err() {
                self.next_check = u64::MAX;
            }
        }
    }

    fn draw(&mut self, step: u64, t_sim: f64, now: Duration) -> io::Result<()> {
        let fraction = if self.total_steps > 0 {
            (step as f64 / self.total_steps as f64).min(1.0)
        } else if self.t_end > 0.0 {
            (t_sim / self.t_end).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let elapsed = now.saturating_sub(self.start);
        let line = &mut self.line;
        line.clear();
        line.extend_from_slice(b"\r[");
        let filled = ((fraction * BAR_WIDTH as f64) as usize).min(BAR_WIDTH);
        for k in 0..BAR_WIDTH {
            line.push(match k.cmp(&filled) {
                std::cmp::Ordering::Less => b'=',
                std::cmp::Ordering::Equal => b'>',
                std::cmp::Ordering::Greater => b' ',
            });
        }
        write!(line, "] {:5.1}%  t {:.2}/{:.2} s  elapsed ", 100.0 * fraction, t_sim, self.t_end)?;
        write_duration(line, elapsed)?;
        line.extend_from_slice(b"  left ");
        match eta(elapsed, fraction) {
            Some(left) => write_duration(line, left)?,
            None => line.extend_from_slice(b"--:--"),
        }
        // Erase whatever a longer previous line left behind.
        line.extend_from_slice(b"\x1b[K");
        self.out.write_all(line)?;
        self.out.flush()?;
        self.drawn = true;
        Ok(())
    }

    /// Clears the bar's line (if it was ever drawn) so that what follows starts on a clean
    /// line, and stops drawing. Also done on drop.
    pub fn finish(&mut self) {
        self.next_check = u64::MAX;
        if self.drawn {
            self.drawn = false;
            let _ = self.out.write_all(b"\r\x1b[K").and_then(|()| self.out.flush());
        }
    }

    /// The writer (for tests that draw into a buffer).
    pub fn writer(&self) -> &W {
        &self.out
    }

    /// The clock (for tests with a fake clock).
    pub fn clock(&self) -> &C {
        &self.clock
    }
}

impl<W: Write, C: Clock> Drop for Progress<W, C> {
    fn drop(&mut self) {
        self.finish();
    }
}
