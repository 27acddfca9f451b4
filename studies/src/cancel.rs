//! A request to stop, from the caller (Ctrl-C at the command line, a signal in Python): runs
//! check it after every step and studies before every point, and stop with [`Cancelled`]; what
//! was finished is kept where the caller keeps it ([`crate::points`]).

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Why work stopped early: the caller asked it to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("interrupted (Ctrl-C)")]
pub struct Cancelled;

/// Asks every run and study of this process to stop after the work in hand; true if it had
/// been asked already.
pub fn request() -> bool {
    REQUESTED.swap(true, Ordering::SeqCst)
}

/// Whether a stop was requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// `Err(Cancelled)` once a stop was requested.
pub fn check() -> Result<(), Cancelled> {
    if requested() { Err(Cancelled) } else { Ok(()) }
}
