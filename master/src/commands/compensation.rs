//! `master compensation`: the second level of a scene with `[control]` and a sampled sensor, in
//! the monolithic model (eq. 7 with the legs driven by the sensor's commands; IJCSA agrees with
//! it within 1e-3 of the peaks, master/tests/cli/feed.rs):
//!
//! * the cabin's motion against the feed's error, uncompensated (sensor off), compensated
//!   (coupled: the platform's reactions act on the cabin) and as a decoupled model predicts it
//!   (the same sensor and commands replayed on the cabin poses of the uncompensated run: the
//!   compensation's reactions never reach the cabin) — `compensation.csv`, `compensation.svg`;
//! * the feed error against the sensor's delay and sample rate, each case marked unstable when
//!   the run stops or its feed error keeps growing — `sweep.csv`, `sweep.svg`;
//! * the error budget: the scene run again without the instrument's noise, without its delay and
//!   with neither (what is left is the filter's lag and the sampling), against the decoupled
//!   prediction (what the coupling adds) — `budget.csv`.
//!
//! Every run is independent: they run in parallel. The study is the library's
//! ([`studies::compensation`]); this command names its files, keeps its journal and prints.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use studies::compensation::{self, Study};

use crate::journal::{self, Journal};
use crate::progress::Shown;

use super::args::{Resume, SceneFile, Workers};
use super::output::{Outputs, run_inputs};
use super::scheme_args::positive;
use super::{CmdResult, caps, fingerprint, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Directory for compensation.csv/.svg and sweep.csv/.svg.
    #[arg(long, default_value = "out/compensation")]
    pub(crate) out: PathBuf,
    /// Simulated time of the uncompensated, compensated and decoupled runs (s).
    #[arg(long, default_value_t = 60.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Simulated time of each run of the sweep (s).
    #[arg(long, default_value_t = 20.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) sweep_t_end: f64,
    /// Sensor delays of the sweep (s, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = studies::options::non_negative, allow_negative_numbers = true,
          default_value = "0,0.02,0.05,0.1,0.2,0.3")]
    pub(crate) delays: Vec<f64>,
    /// Sample rates of the sweep (Hz, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "10,25,50,100")]
    pub(crate) rates: Vec<f64>,
    /// The command filter's bandwidth for every run (Hz), instead of the scene's
    /// `control.bandwidth_hz`.
    #[arg(long, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) bandwidth: Option<f64>,
    #[command(flatten)]
    pub(crate) resume: Resume,
    #[command(flatten)]
    pub(crate) workers: Workers,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let settings = compensation::Settings {
        t_end: args.t_end,
        sweep_t_end: args.sweep_t_end,
        delays: args.delays.clone(),
        rates: args.rates.clone(),
        bandwidth: args.bandwidth,
        jobs: args.workers.jobs,
        limits: caps().run,
    };
    let study = Study::new(&scene, &args.file.scene.display().to_string(), settings.clone())?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let mut declare = |f: &str| outputs.declare("--out", &args.out.join(f), f.rsplit('.').next());
    let (csv_id, svg_id) = (declare("compensation.csv")?, declare("compensation.svg")?);
    let (sweep_csv_id, sweep_svg_id) = (declare("sweep.csv")?, declare("sweep.svg")?);
    let budget_id = declare("budget.csv")?;
    outputs.open()?;
    let s = &settings;
    let identity = format!(
        "compensation {} {:?} {:?} {:?} {:?}",
        fingerprint(study.scene()),
        s.rates,
        s.delays,
        s.sweep_t_end,
        s.t_end
    );
    let journal = Journal::open(&journal::path(&args.out, "sweep.csv"), &identity, args.resume.resume)?;
    let results = study.run(&journal, &Shown { lines: true, bars: false }).map_err(journal::resumable(&journal))?;
    for failure in &results.budget_failures {
        eprintln!("{failure}");
    }
    outputs.write(csv_id, |w| w.write_all(results.csv().as_bytes()))?;
    let svg = results.svg().context("drawing the compensation figure")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    outputs.write(sweep_csv_id, |w| w.write_all(results.sweep_csv().as_bytes()))?;
    let svg = results.sweep_svg().map_err(|e| anyhow::anyhow!("drawing the sweep figure: {e}"))?;
    outputs.write(sweep_svg_id, |w| w.write_all(svg.as_bytes()))?;
    outputs.write(budget_id, |w| w.write_all(results.budget_csv().as_bytes()))?;
    let paths: Vec<PathBuf> =
        [csv_id, svg_id, sweep_csv_id, sweep_svg_id, budget_id].iter().map(|&i| outputs.path(i).to_owned()).collect();
    outputs.commit()?;
    journal.finish()?;
    let mut out = std::io::stdout().lock();
    write!(out, "{}", results.text())?;
    writeln!(out, "\n{} written", paths.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))?;
    Ok(())
}
