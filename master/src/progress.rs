//! The progress bar of long runs (indicatif), on stderr, as a watcher of the run's steps:
//!
//! ```text
//! [=========>              ]  38%  t 38.20/100.00 s  elapsed 0:05  left 0:08
//! ```
//!
//! Updated every step, cheaply (indicatif throttles drawing to a few times a second); hidden
//! with `--quiet` and whenever stderr is not a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use studies::limits::Schedule;
use studies::observe::Observer;
use studies::stepping::Watch;

/// Positions of the bar: thousandths of the end time.
const POSITIONS: u64 = 1000;

pub(crate) struct Progress {
    quiet: bool,
    bar: Option<(ProgressBar, f64)>,
}

impl Progress {
    /// A bar shown when the run starts; never when `quiet`.
    pub(crate) fn new(quiet: bool) -> Progress {
        Progress { quiet, bar: None }
    }
}

impl Watch for Progress {
    fn start(&mut self, schedule: &Schedule) {
        let t_end = schedule.t_end();
        let target = if self.quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
        let style = ProgressStyle::with_template("[{bar:24}] {percent:>3}%  t {t} s  elapsed {elapsed}  left {eta}")
            .expect("a valid template")
            .progress_chars("=> ")
            .with_key("t", move |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.2}/{t_end:.2}", (s.pos() as f64 / POSITIONS as f64 * t_end).min(t_end));
            });
        self.bar = Some((ProgressBar::with_draw_target(Some(POSITIONS), target).with_style(style), t_end));
    }

    #[inline]
    fn stepped(&mut self, _: u64, t: f64) -> Result<(), String> {
        if let Some((bar, t_end)) = &self.bar {
            bar.set_position(((t / t_end) * POSITIONS as f64) as u64);
        }
        Ok(())
    }

    fn finish(&mut self) {
        if let Some((bar, _)) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// The command line's view of a study: a line on stderr for each piece of work begun and each
/// point finished (`lines`), a bar for each run (`bars`, on a terminal).
pub(crate) struct Shown {
    pub(crate) lines: bool,
    pub(crate) bars: bool,
}

impl Observer for Shown {
    fn begin(&self, label: &str) {
        if self.lines {
            eprintln!("{label} …");
        }
    }

    fn watch(&self) -> Box<dyn Watch + '_> {
        Box::new(Progress::new(!self.bars))
    }

    fn point(&self, line: &str) {
        if self.lines {
            eprintln!("{line}");
        }
    }
}
