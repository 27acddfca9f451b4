//! `master bench`: run time against error. Every scheme at every macro step, the median wall time
//! of a few repetitions, and the error of the cabin-centre displacement against a fine-step
//! monolithic reference; a table, `bench.csv` and a log–log work–precision plot. With
//! `--adaptive-rtols`, the schemes that iterate also with the adaptive step at each tolerance,
//! each against the cheapest fixed step of the same scheme that is as accurate, and against the
//! fixed step that would be exactly as accurate, interpolated between the grid's steps
//! (`bench_adaptive.csv`).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::Context;
use studies::bench::{self, Bench};

use crate::journal::{self, Journal};
use crate::progress::Shown;

use super::args::{Quiet, Resume, SceneFile, Steps};
use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, named, tolerance};
use super::{CmdResult, caps, fingerprint, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    #[command(flatten)]
    pub(crate) steps: Steps,
    /// Methods (comma-separated).
    #[arg(
        long,
        value_parser = named::<SchemeName>(),
        value_delimiter = ',',
        default_value = "monolithic,ijcsa,iqn-ils,iterative,gauss-seidel,jacobi,decoupled"
    )]
    pub(crate) schemes: Vec<SchemeName>,
    /// Runs per scheme and step; the median wall time is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub(crate) repeats: u32,
    /// Simulated time (s); default: the scene's solver.t_end_s.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) t_end: Option<f64>,
    /// Step of the monolithic reference (s); default: the smallest step / 4.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) reference_dt: Option<f64>,
    /// Also run every scheme of --schemes that iterates with the adaptive step at these
    /// relative tolerances (comma-separated, e.g. 1e-3,1e-2), each against the cheapest fixed
    /// step of the same scheme that reaches its error.
    #[arg(long, value_delimiter = ',', value_parser = tolerance)]
    pub(crate) adaptive_rtols: Vec<f64>,
    /// Directory for bench.csv, work_precision.svg (and bench_adaptive.csv).
    #[arg(long, default_value = "out/bench")]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
    #[command(flatten)]
    pub(crate) quiet: Quiet,
    #[command(flatten)]
    pub(crate) resume: Resume,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let settings = bench::Settings {
        schemes: args.schemes.clone(),
        dts: args.steps.dts.clone(),
        repeats: args.repeats,
        t_end: args.t_end,
        reference_dt: args.reference_dt,
        adaptive_rtols: args.adaptive_rtols.clone(),
        options: args.options.options(),
        limits: caps().run,
    };
    // every run is checked before the first one starts
    let bench = Bench::new(&scene, &args.file.scene, settings.clone())?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let csv_id = outputs.declare("--out", &args.out.join("bench.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("work_precision.svg"), Some("svg"))?;
    let adaptive_id = bench
        .has_adaptive_runs()
        .then(|| outputs.declare("--out", &args.out.join("bench_adaptive.csv"), Some("csv")))
        .transpose()?;
    outputs.open()?;
    let s = &settings;
    let identity = format!(
        "bench {} {:?} {:?} {} {:?} {:?} {:?} {:?}",
        fingerprint(&scene),
        s.schemes,
        s.dts,
        s.repeats,
        bench.t_end,
        bench.reference_dt,
        s.adaptive_rtols,
        s.options
    );
    let journal = Journal::open(&journal::path(&args.out, "bench.csv"), &identity, args.resume.resume)?;
    let quiet = args.quiet.quiet || !std::io::stderr().is_terminal();
    let results = bench.run(&journal, &Shown { lines: true, bars: !quiet }).map_err(journal::resumable(&journal))?;
    let (table, csv) = results.grid();
    outputs.write(csv_id, |w| w.write_all(csv.as_bytes()))?;
    let svg = results.svg().context("drawing the work–precision plot")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    let adaptive_table = match adaptive_id {
        Some(id) => {
            let (table, csv) = results.adaptive();
            outputs.write(id, |w| w.write_all(csv.as_bytes()))?;
            Some((table, outputs.path(id).to_owned()))
        }
        None => None,
    };
    let (csv_path, svg_path) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;
    journal.finish()?;

    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {} s simulated; reference monolithic at h = {} s, peak {:.4} mm",
        results.scene, results.t_end, results.reference_dt, results.peak
    )?;
    writeln!(out)?;
    write!(out, "{}", table.render())?;
    writeln!(out)?;
    write!(out, "{}", results.summary().render())?;
    writeln!(out)?;
    if let Some((table, path)) = adaptive_table {
        write!(out, "{}", table.render())?;
        writeln!(out)?;
        writeln!(out, "{} written", path.display())?;
    }
    writeln!(out, "{} and {} written", csv_path.display(), svg_path.display())?;
    Ok(())
}
