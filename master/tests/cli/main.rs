//! The `master` command line as its users drive it, the figures it draws, and the methods
//! behind it on the packaged FMUs; one test binary (one link instead of one per file, and the
//! tests of every module share the cores).
//!
//! * `run`, `analyses`, `stewart`, `package`: what each command prints and writes;
//! * `adaptive`: the adaptive macro step through `run`, `compare` and `bench`;
//! * `plots`: the SVG figures read back;
//! * `misuse`: careless and hostile use of the command line;
//! * `mutants`: every scene key set to hostile values, each outcome classified;
//! * `shipped`: every shipped scene with every method, as shipped;
//! * `archive_mutants`: hostile SSP archives and FMU states, each outcome classified;
//! * `slack`: a cable going slack and taut again, the monolithic model against IJCSA;
//! * `cosim`: the coupling schemes and the adaptive step against the monolithic model;
//! * `step_map`: IJCSA with the FMUs' step-map extension against finite differences;
//! * `ssp_system`: SSP systems of FMUs that know nothing of the project's physics;
//! * `fmi3`: the LT50m system of FMI 3.0 FMUs, and of both versions, against FMI 2.0;
//! * `model_exchange`: hostile Model Exchange FMUs, and the rollback of units the master integrates;
//! * `sweep`: sweeps and their shards against the library, point by point;
//! * `calibrate`: model updating against modes of scenes with known keys;
//! * `resume`: long commands killed halfway and continued with --resume;
//! * `net`: the net in space: its figure, its VTK series and mode shapes, bad `--vtk` targets.

#[path = "../common/mod.rs"]
mod common;

mod adaptive;
mod analyses;
mod archive_mutants;
mod calibrate;
mod cosim;
mod design;
mod feed;
mod fmi3;
mod misuse;
mod model_exchange;
mod mutants;
mod net;
mod package;
mod plots;
mod reproduce;
mod resume;
mod run;
mod shipped;
mod slack;
mod ssp_system;
mod stability;
mod step_map;
mod stewart;
mod sweep;

use std::process::{Command, Output};

/// The `master` binary under test.
pub(crate) const MASTER: &str = env!("CARGO_BIN_EXE_master");

/// Runs `master` with `args` and waits for it.
pub(crate) fn master(args: &[&str]) -> Output {
    Command::new(MASTER).args(args).output().unwrap()
}
