//! The `master` command line as its users drive it, and the figures it draws; one test binary
//! (one link instead of one per file).
//!
//! * `run`, `analyses`, `stewart`, `package`: what each command prints and writes;
//! * `plots`: the SVG figures read back;
//! * `misuse`: careless and hostile use of the command line;
//! * `mutants`: every scene key set to hostile values, each outcome classified.

#[path = "../common/mod.rs"]
mod common;

mod analyses;
mod misuse;
mod mutants;
mod package;
mod plots;
mod run;
mod stewart;

use std::process::{Command, Output};

/// The `master` binary under test.
pub(crate) const MASTER: &str = env!("CARGO_BIN_EXE_master");

/// Runs `master` with `args` and waits for it.
pub(crate) fn master(args: &[&str]) -> Output {
    Command::new(MASTER).args(args).output().unwrap()
}
