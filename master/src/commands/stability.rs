//! `master stability`: where each coupling scheme is stable, over the mass ratio (the Stewart
//! platform's masses and inertias scaled) and the macro step; iterations per step where it
//! iterates. A table per scheme, `stability.csv` and a plot of maps.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::Context;
use studies::stability::{self, Stability};

use crate::journal::{self, Journal};
use crate::progress::Shown;

use super::args::{Quiet, Resume, SceneFile, Steps, Workers};
use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, named, positive};
use super::{CmdResult, caps, fingerprint, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    #[command(flatten)]
    pub(crate) steps: Steps,
    /// Coupling schemes (comma-separated).
    #[arg(
        long,
        value_parser = named::<SchemeName>(),
        value_delimiter = ',',
        default_value = "jacobi,gauss-seidel,gauss-seidel-reversed,iterative,ijcsa,iqn-ils"
    )]
    pub(crate) schemes: Vec<SchemeName>,
    /// Factors on every mass and inertia of the Stewart platform (1: the scene's platform).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.1,0.2,0.5,1,2,5,10")]
    pub(crate) ratios: Vec<f64>,
    /// Simulated time of every run (s).
    #[arg(long, default_value_t = 10.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Directory for stability.csv and stability.svg.
    #[arg(long, default_value = "out/stability")]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
    #[command(flatten)]
    pub(crate) quiet: Quiet,
    #[command(flatten)]
    pub(crate) resume: Resume,
    #[command(flatten)]
    pub(crate) workers: Workers,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let settings = stability::Settings {
        schemes: args.schemes.clone(),
        ratios: args.ratios.clone(),
        dts: args.steps.dts.clone(),
        t_end: args.t_end,
        options: args.options.options(),
        jobs: args.workers.jobs,
        limits: caps().run,
    };
    // every run is checked before the first one starts
    let map = Stability::new(&scene, &args.file.scene, settings.clone())?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let csv_id = outputs.declare("--out", &args.out.join("stability.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("stability.svg"), Some("svg"))?;
    outputs.open()?;
    // every input that decides the cells (not the threads, nor the caps)
    let s = &settings;
    let identity = format!(
        "stability {} {:?} {:?} {:?} {:?} {:?}",
        fingerprint(&scene),
        s.schemes,
        s.ratios,
        s.dts,
        s.t_end,
        s.options
    );
    let journal = Journal::open(&journal::path(&args.out, "stability.csv"), &identity, args.resume.resume)?;
    // the runs are independent: every one on its own core; progress bars only when one runs at
    // a time
    let quiet =
        args.quiet.quiet || !std::io::stderr().is_terminal() || studies::parallel::threads(args.workers.jobs) > 1;
    let map = map.run(&journal, &Shown { lines: true, bars: !quiet }).map_err(journal::resumable(&journal))?;
    outputs.write(csv_id, |w| w.write_all(map.csv().as_bytes()))?;
    let svg = map.svg().context("drawing the stability map")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    let (csv_path, svg_path) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;
    journal.finish()?;
    let mut out = std::io::stdout().lock();
    write!(out, "{}", map.text())?;
    writeln!(out)?;
    writeln!(out, "{} and {} written", csv_path.display(), svg_path.display())?;
    Ok(())
}
