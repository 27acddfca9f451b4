//! Ctrl-C, and a kill that can be caught (SIGTERM, SIGHUP): a command stops between its steps or
//! points instead of dying mid-write, its temporary files removed. Long work keeps what it
//! finished (see [`crate::journal`]) and the process exits with 130; a second signal exits at
//! once (what it leaves, the next run removes: [`crate::tempfiles`]).

use std::sync::atomic::{AtomicBool, Ordering};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The process's exit status after an interrupt (128 + SIGINT), as shells report it.
pub const EXIT_CODE: u8 = 130;

/// Why work stopped early: the user interrupted it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("interrupted (Ctrl-C)")]
pub struct Interrupted;

/// Takes over Ctrl-C (SIGINT), SIGTERM and SIGHUP for the rest of the process.
pub fn install() {
    // A second handler cannot be set (a test harness may have one): Ctrl-C then keeps its
    // default, which ends the process.
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            std::process::exit(i32::from(EXIT_CODE));
        }
        eprintln!("\ninterrupted: stopping after the work in hand (Ctrl-C again to stop at once)");
    });
}

/// Whether Ctrl-C was pressed.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// `Err(Interrupted)` once Ctrl-C was pressed.
pub fn check() -> Result<(), Interrupted> {
    if interrupted() { Err(Interrupted) } else { Ok(()) }
}
