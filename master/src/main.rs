//! `master`: the command-line tool of the feed-positioning co-simulation toolkit.
//!
//! Every subcommand lives in its own module under `commands/`; this file only parses the
//! command line, sets the global caps and reports errors with their whole chain of causes.

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use studies::limits::{Limits, MAX_STEPS};
use studies::options::MEMORY_MB;

mod commands;
mod interrupt;
mod journal;
mod progress;

#[derive(Parser)]
#[command(
    name = "master",
    version,
    about = "Co-simulation of a cable-suspended feed cabin with a Stewart platform (LT50m and FAST scenes)",
    long_about = "Co-simulation of a cable-suspended feed cabin with a Stewart platform.\n\n\
                  The commands read a scene file (see scenes/*.toml), `run --system` any SSP system \
                  of FMUs; they print readable tables (JSON with --json where offered) and write \
                  tables and figures to --out."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    #[command(flatten)]
    caps: CapFlags,
}

/// Caps that keep a mistyped number from running for days or exhausting memory; each can be
/// raised when the work is meant.
#[derive(clap::Args)]
struct CapFlags {
    /// Most macro steps one run may take.
    #[arg(long, global = true, default_value_t = MAX_STEPS, value_name = "N")]
    max_steps: u64,
    /// Memory one run may take, MB [default: what the machine has available]. The need is
    /// estimated from the scene before anything is built.
    #[arg(long, global = true, value_name = "MB", value_parser = commands::scheme_args::memory_mb)]
    max_memory_mb: Option<u64>,
    /// Largest scene file read, bytes.
    #[arg(long, global = true, default_value_t = feedcore::scene::MAX_SCENE_BYTES, value_name = "BYTES")]
    max_scene_bytes: u64,
}

#[derive(Subcommand)]
enum Command {
    /// Form-finding statics: unstretched cable lengths that hold the cabin at the scene's target pose.
    Statics(commands::statics::Args),
    /// Natural frequencies and mode shapes of the cable–cabin system about its static equilibrium.
    Modes(commands::modes::Args),
    /// Model updating: scene keys fitted to measured natural frequencies by least squares.
    Calibrate(commands::calibrate::Args),
    /// Stewart platform on a fixed cabin: added mass, static wrench, wrench range over one circle
    /// (the cabin held at the scene's target pose, the motion sampled every `solver.dt_s`).
    Stewart(commands::stewart::Args),
    /// Simulate a scene with a coupling scheme of its FMUs, the monolithic, decoupled or cable-only
    /// model, or any SSP system of FMUs (--system).
    Run(commands::run::Args),
    /// Compare coupling schemes against the monolithic model at the same step.
    Compare(commands::compare::Args),
    /// Run time against error: every scheme at several steps against a fine monolithic reference.
    Bench(commands::bench::Args),
    /// Stability map of the coupling schemes over the platform's mass and the macro step.
    Stability(commands::stability::Args),
    /// The second level: cabin motion against feed error (uncompensated, coupled, decoupled), the
    /// feed error against sensor delay and rate, and the error budget.
    Compensation(commands::compensation::Args),
    /// The second level's command filter (stages, bandwidth, prediction, notch, the fusion's
    /// noise model) chosen on coupled (or decoupled) runs in parallel, robust to the sensor's
    /// delay ±50 % and the platform's mass ±20 %; writes the tuned scene.
    Tune(commands::tune::Args),
    /// The second level's LQG controller designed on the linear model of the coupled system, and
    /// its H2 cost: the bound no linear time-invariant controller beats with the instruments.
    Design(commands::design::Args),
    /// Statics, first frequencies and short coupled runs over a grid of poses and parameters, on
    /// every core or in shards (--shard, joined by --merge).
    Sweep(commands::sweep::Args),
    /// Run time and peak memory against elements per cable, set-up and stepping apart.
    Scaling(commands::scaling::Args),
    /// Long and hard runs (1000 s, stiff cables, fine nets, slack cable, abrupt start) with their bounds.
    Stress(commands::stress::Args),
    /// The paper side by side: Table 2 and Figs. 4–6 against ours and every hypothesis (docs/reproduction.md).
    Reproduce(commands::reproduce::Args),
    /// Write the scene's co-simulated system (FMUs, connections, parameters) as an SSP 1.0 archive
    /// (with the FMUs' FMI 3.0 twins: --fmi 3).
    ExportSsp(commands::export_ssp::Args),
    /// Build every FMU of the workspace from the built libraries: cable_fmu, stewart_fmu, the test
    /// oscillator and the zoo (testfmus/), FMI 2.0 in --out and their FMI 3.0 twins in --out/fmi3.
    Package(commands::package::Args),
    /// Run a model's library in-process on an input table (the reference of the fmpy cross-checks).
    #[command(hide = true)]
    Replay(commands::replay::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    crate::interrupt::install();
    commands::set_caps(commands::Caps {
        run: Limits {
            max_steps: cli.caps.max_steps,
            max_memory_bytes: cli.caps.max_memory_mb.map(|mb| mb * MEMORY_MB),
        },
        scene_bytes: cli.caps.max_scene_bytes,
    });
    let result = match cli.command {
        Command::Statics(args) => commands::statics::run(&args),
        Command::Modes(args) => commands::modes::run(&args),
        Command::Calibrate(args) => commands::calibrate::run(&args),
        Command::Stewart(args) => commands::stewart::run(&args),
        Command::Run(args) => commands::run::run(&args),
        Command::Compare(args) => commands::compare::run(&args),
        Command::Bench(args) => commands::bench::run(&args),
        Command::Stability(args) => commands::stability::run(&args),
        Command::Compensation(args) => commands::compensation::run(&args),
        Command::Tune(args) => commands::tune::run(&args),
        Command::Design(args) => commands::design::run(&args),
        Command::Sweep(args) => commands::sweep::run(&args),
        Command::Scaling(args) => commands::scaling::run(&args),
        Command::Stress(args) => commands::stress::run(&args),
        Command::Reproduce(args) => commands::reproduce::run(&args),
        Command::ExportSsp(args) => commands::export_ssp::run(&args),
        Command::Package(args) => commands::boxed(commands::package::run(&args)),
        Command::Replay(args) => commands::replay::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`master statics | head -1`): nothing to report.
        Err(e) if broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            for line in error_lines(&e) {
                eprintln!("{line}");
            }
            if studies::cancel::requested() { ExitCode::from(crate::interrupt::EXIT_CODE) } else { ExitCode::FAILURE }
        }
    }
}

/// An error as printed: its message, then each cause the message before it does not already
/// end with (an error that quotes its cause, `component `x`: <cause>`, is not followed by it
/// again).
fn error_lines(e: &anyhow::Error) -> Vec<String> {
    let mut shown = e.to_string();
    let mut lines = vec![format!("error: {shown}")];
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !shown.ends_with(&text) {
            lines.push(format!("  caused by: {text}"));
            shown = text;
        }
    }
    lines
}

fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

#[cfg(test)]
mod tests {
    /// An error whose message quotes its cause, as `thiserror`'s `{source}` does.
    #[derive(Debug)]
    struct Quoting(std::io::Error);

    impl std::fmt::Display for Quoting {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "component `control`: {}", self.0)
        }
    }

    impl std::error::Error for Quoting {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn a_cause_the_message_quotes_is_printed_once() {
        let io = || std::io::Error::other("undefined symbol: _Py_NoneStruct");
        let quoted = anyhow::Error::new(Quoting(io())).context("the system");
        assert_eq!(
            super::error_lines(&quoted),
            ["error: the system", "  caused by: component `control`: undefined symbol: _Py_NoneStruct"]
        );
        let plain = anyhow::Error::new(io()).context("the system");
        assert_eq!(super::error_lines(&plain), ["error: the system", "  caused by: undefined symbol: _Py_NoneStruct"]);
    }
}
