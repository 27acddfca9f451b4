//! What a caller sees of a study as it goes: each piece of work as it starts (its label), a
//! watch of each run's steps, and each point as it finishes. The command line shows them as
//! progress lines and bars; the Python package shows nothing.

use crate::stepping::{Unwatched, Watch};

/// A caller's view of a study.
pub trait Observer: Sync {
    /// Work named `label` starts (a run, or the repeated runs of one measurement).
    fn begin(&self, _label: &str) {}
    /// A watch for the steps of the run about to start.
    fn watch(&self) -> Box<dyn Watch + '_>;
    /// A point finished, with a line that says which and how.
    fn point(&self, _line: &str) {}
}

/// Nothing is shown.
pub struct Silent;

impl Observer for Silent {
    fn watch(&self) -> Box<dyn Watch + '_> {
        Box::new(Unwatched)
    }
}
