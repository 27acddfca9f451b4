//! The progress bar of long runs (indicatif), on stderr:
//!
//! ```text
//! [=========>              ]  38%  t 38.20/100.00 s  elapsed 0:05  left 0:08
//! ```
//!
//! `update` every step is cheap (indicatif throttles drawing to a few times a second); the bar
//! is hidden with `--quiet` and whenever stderr is not a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar for `steps` steps of `dt` up to `t_end` (s); hidden when `quiet`.
    pub fn new(steps: u64, dt: f64, t_end: f64, quiet: bool) -> Progress {
        let target = if quiet { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
        let style = ProgressStyle::with_template("[{bar:24}] {percent:>3}%  t {t} s  elapsed {elapsed}  left {eta}")
            .expect("a valid template")
            .progress_chars("=> ")
            .with_key("t", move |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.2}/{t_end:.2}", (s.pos() as f64 * dt).min(t_end));
            });
        Progress { bar: ProgressBar::with_draw_target(Some(steps), target).with_style(style) }
    }

    /// Step `k` is done.
    #[inline]
    pub fn update(&self, k: u64) {
        self.bar.set_position(k);
    }

    /// Clears the bar's line.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
