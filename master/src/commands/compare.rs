//! `master compare`: each scheme's error against the monolithic model at the same step.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use studies::compare;

use crate::progress::Shown;

use super::args::{Quiet, SceneFile};
use super::output::{Outputs, run_inputs};
use super::run::plot_traces;
use super::scheme_args::{SchemeName, SchemeOptions, named};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Methods to compare with the monolithic reference (comma-separated).
    #[arg(
        long,
        value_parser = named::<SchemeName>(),
        value_delimiter = ',',
        default_value = "ijcsa,iqn-ils,iterative,gauss-seidel,jacobi,decoupled"
    )]
    pub(crate) schemes: Vec<SchemeName>,
    /// Macro step (s) of every run; default: the scene's solver.dt_s.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) dt: Option<f64>,
    /// End time (s); default: the scene's solver.t_end_s.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) t_end: Option<f64>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
    /// Draw all displacement histories in one SVG.
    #[arg(long)]
    pub(crate) plot: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
    #[command(flatten)]
    pub(crate) quiet: Quiet,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let quiet = args.quiet.quiet || args.json || !std::io::stderr().is_terminal();
    let settings = compare::Settings {
        schemes: args.schemes.clone(),
        dt: args.dt,
        t_end: args.t_end,
        options: args.options.options(),
        limits: caps().run,
    };
    let comparison = compare::Comparison::new(&scene, &args.file.scene, settings)?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    outputs.open()?;
    let compared = comparison.run(&Shown { lines: false, bars: !quiet })?;
    if let Some(id) = svg {
        let title = format!("{}: cabin-centre response at h = {} s", scene.name, compared.dt);
        plot_traces(&outputs, id, &compared.traces(), &title)?;
    }
    outputs.commit()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&compared.json())?)?;
    } else {
        write!(out, "{}", compared.text())?;
    }
    Ok(())
}
