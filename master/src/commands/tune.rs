//! `master tune`: the second level's command filter chosen on runs of minutes, in parallel.
//!
//! Every candidate (a filter bandwidth; with an inertial unit a prediction horizon as a share of
//! the filter's lag (2τ, or 3τ with three stages); with a notch frequency the notch's quality) is run three ways: on the coupled (monolithic) model, on the
//! decoupled one (its commands replayed on the uncompensated run's cabin poses: the platform's
//! reactions never reach the cabin), and on the coupled model with the sensor's delay ×0.5 and
//! ×1.5 and the platform's mass ×0.8 and ×1.2. The design model (`--design`) picks: the lowest
//! feed error RMS among the candidates it calls stable — the coupled model every run of a
//! candidate stable (`master compensation`'s verdict: no stop, no growing error, the cabin's
//! peak within twice the uncompensated), the decoupled model cannot see instability. Written:
//! the scene with the chosen filter, `tune.csv` (every candidate, every run) and `tune.md` (the
//! choice, and what the decoupled model's choice does on the coupled one).
//! The tuning is the library's ([`studies::tune`]); this command names its files and prints.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use studies::options::Named;
use studies::tune::{self, Design, Tuning, tuned_scene};

use crate::progress::Shown;

use super::args::{SceneFile, Workers};
use super::output::{Outputs, run_inputs};
use super::scheme_args::{named, positive};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Directory for tuned.toml, tune.csv and tune.md.
    #[arg(long, default_value = "out/tune")]
    pub(crate) out: PathBuf,
    /// The model the choice is made on.
    #[arg(long, default_value = "coupled", value_parser = named::<Design>())]
    pub(crate) design: Design,
    /// Simulated time of every run (s): long enough for a lightly damped mode pumped slowly to
    /// show (at C the 0.83 Hz cable–cabin mode takes minutes to double).
    #[arg(long, default_value_t = 300.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Filter bandwidths tried (Hz, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.25,0.5,1,1.5,2,2.5,3,4,5")]
    pub(crate) bandwidths: Vec<f64>,
    /// Numbers of filter stages tried, 2 or 3 (comma-separated; default: the scene's
    /// `filter_stages`): three keep the platform's acceleration continuous, at one more τ of lag.
    #[arg(long, value_delimiter = ',')]
    pub(crate) filter_stages: Vec<u32>,
    /// With [control.imu]: prediction horizons tried, as shares of the filter's lag (2τ; 3τ with three stages)
    /// (comma-separated; ignored without an inertial unit).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_value = "0,0.25,0.5")]
    pub(crate) predictions: Vec<f64>,
    /// With [control.imu]: scales of the noise the fusion filter assumes of the unit (its noise
    /// densities and bias walks; 1: the instrument's own figures) tried (comma-separated; ignored
    /// without an inertial unit). Above 1 the filter leans on the fixes, below on the unit.
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true, default_value = "1")]
    pub(crate) fusion_scales: Vec<f64>,
    /// A notch in the commands at this frequency (Hz; default: the scene's `notch_hz`, if any),
    /// e.g. the cable–cabin mode the loop pumps (`master modes`).
    #[arg(long, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) notch_hz: Option<f64>,
    /// With a notch: its qualities tried (comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "2,4,8")]
    pub(crate) notch_qs: Vec<f64>,
    #[command(flatten)]
    pub(crate) workers: Workers,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let shown = args.file.scene.display().to_string();
    let settings = tune::Settings {
        design: args.design,
        t_end: args.t_end,
        bandwidths: args.bandwidths.clone(),
        filter_stages: args.filter_stages.clone(),
        predictions: args.predictions.clone(),
        fusion_scales: args.fusion_scales.clone(),
        notch_hz: args.notch_hz,
        notch_qs: args.notch_qs.clone(),
        jobs: args.workers.jobs,
        limits: caps().run,
    };
    let tuning = Tuning::new(&scene, &shown, settings)?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let mut declare = |f: &str| outputs.declare("--out", &args.out.join(f), f.rsplit('.').next());
    let (scene_id, csv_id, report_id) = (declare("tuned.toml")?, declare("tune.csv")?, declare("tune.md")?);
    outputs.open()?;
    let results = tuning.run(&Shown { lines: true, bars: false })?;

    let tuned = tuned_scene(&scene, &args.file.scene, results.chosen());
    let tuned_text = format!(
        "# `master tune --design {}` on {} (t_end {} s): the chosen command filter; see tune.md.\n{}",
        args.design.name(),
        shown,
        args.t_end,
        tuned.to_toml()
    );
    tuned.validated(&outputs.path(scene_id).display().to_string()).context("the tuned scene")?;
    outputs.write(scene_id, |w| w.write_all(tuned_text.as_bytes()))?;
    outputs.write(csv_id, |w| w.write_all(results.csv().as_bytes()))?;
    outputs.write(report_id, |w| w.write_all(results.report().as_bytes()))?;
    let paths: Vec<String> =
        [scene_id, csv_id, report_id].iter().map(|&i| outputs.path(i).display().to_string()).collect();
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    writeln!(out, "{}: {} s per run; uncompensated feed error RMS {:.3} mm", scene.name, args.t_end, results.off_rms)?;
    write!(out, "{}", results.choices().render())?;
    writeln!(
        out,
        "chosen ({} design): {}\n{} written",
        args.design.name(),
        results.describe(results.chosen),
        paths.join(", ")
    )?;
    Ok(())
}
