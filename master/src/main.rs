//! `master`: the command-line tool of the feed-positioning co-simulation toolkit.
//!
//! Every subcommand lives in its own module under `commands/`; this file only parses the
//! command line and reports errors.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod commands;

#[derive(Parser)]
#[command(
    name = "master",
    version,
    about = "Co-simulation of a cable-suspended feed cabin with a Stewart platform (LT50m scenes)",
    long_about = "Co-simulation of a cable-suspended feed cabin with a Stewart platform.\n\n\
                  Each command reads a scene file (see scenes/*.toml) and prints readable tables, \
                  or JSON with --json."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Form-finding statics: unstretched cable lengths that hold the cabin at the scene's target pose.
    Statics(commands::statics::Args),
    /// Natural frequencies and mode shapes of the cable–cabin system about its static equilibrium.
    Modes(commands::modes::Args),
    /// Stewart platform on a fixed cabin: added mass, static wrench, wrench range over one circle.
    Stewart(commands::stewart::Args),
    /// Simulate the scene with a coupling scheme, the monolithic model or the decoupled model.
    Run(commands::run::Args),
    /// Compare coupling schemes against the monolithic model at the same step.
    Compare(commands::compare::Args),
    /// Run time against error: every scheme at several steps against a fine monolithic reference.
    Bench(commands::bench::Args),
    /// Stability map of the coupling schemes over the platform's mass and the macro step.
    Stability(commands::stability::Args),
    /// Statics, first frequencies and short coupled runs over a grid of poses and parameters, on every core.
    Sweep(commands::sweep::Args),
    /// Run time and peak memory against elements per cable, set-up and stepping apart.
    Scaling(commands::scaling::Args),
    /// Long and hard runs (1000 s, stiff cables, fine nets, slack cable, abrupt start) with their bounds.
    Stress(commands::stress::Args),
    /// Build the FMI 2.0 Co-Simulation archives cable_fmu.fmu and stewart_fmu.fmu.
    Package(commands::package::Args),
    /// Run a model's library in-process on an input table (the reference of the fmpy cross-checks).
    #[command(hide = true)]
    Replay(commands::replay::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Statics(args) => commands::statics::run(&args),
        Command::Modes(args) => commands::modes::run(&args),
        Command::Stewart(args) => commands::stewart::run(&args),
        Command::Run(args) => commands::run::run(&args),
        Command::Compare(args) => commands::compare::run(&args),
        Command::Bench(args) => commands::bench::run(&args),
        Command::Stability(args) => commands::stability::run(&args),
        Command::Sweep(args) => commands::sweep::run(&args),
        Command::Scaling(args) => commands::scaling::run(&args),
        Command::Stress(args) => commands::stress::run(&args),
        Command::Package(args) => commands::package::run(&args),
        Command::Replay(args) => commands::replay::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
