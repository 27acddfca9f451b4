//! Ctrl-C, and a kill that can be caught (SIGTERM, SIGHUP): a command stops between its steps or
//! points instead of dying mid-write, its temporary files removed. Long work keeps what it
//! finished (see [`crate::journal`]) and the process exits with 130; a second signal exits at
//! once (what it leaves, the next run removes: [`studies::tempfiles`]). The request to stop is the
//! library's ([`studies::cancel`]), which every run and study checks.

/// The process's exit status after an interrupt (128 + SIGINT), as shells report it.
pub(crate) const EXIT_CODE: u8 = 130;

/// Takes over Ctrl-C (SIGINT), SIGTERM and SIGHUP for the rest of the process.
pub(crate) fn install() {
    // A second handler cannot be set (a test harness may have one): Ctrl-C then keeps its
    // default, which ends the process.
    let _ = ctrlc::set_handler(|| {
        if studies::cancel::request() {
            std::process::exit(i32::from(EXIT_CODE));
        }
        eprintln!("\ninterrupted: stopping after the work in hand (Ctrl-C again to stop at once)");
    });
}
