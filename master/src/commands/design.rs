//! `master design`: the second level's LQG design of a scene (`studies::lqg`); writes the scene
//! with `law = "lqg"`, a report and, with `--rates`, the bound against the fixes' rate and delay.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use studies::lqg::{self, Designing, MAX_WIND_SECTIONS};

use super::output::{Outputs, run_inputs};
use super::scheme_args::positive;
use super::{CmdResult, caps, load_scene};
use crate::progress::Shown;

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML) with [wind], a sampled sensor and [control.imu].
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Directory for <name>_lqg.toml and design.md (and bound.csv with --rates).
    #[arg(long, default_value = "out/design")]
    pub(crate) out: PathBuf,
    /// The lowest modes computed (platform locked).
    #[arg(long, default_value_t = 90, value_parser = clap::value_parser!(u32).range(1..=feedcore::scene::MAX_DESIGN_MODES as i64))]
    pub(crate) modes: u32,
    /// Every mode up to this frequency is kept (Hz): the band the design model answers for.
    #[arg(long, default_value_t = 3.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) keep_below: f64,
    /// Above it a mode is kept when the cabin carries at least this share of its kinetic energy
    /// (the others, as the cabin's static compliance they leave, become pseudo-modes at 20 Hz).
    #[arg(long, default_value_t = 0.02, value_parser = share)]
    pub(crate) min_cabin_share: f64,
    /// Poles of the wind's rational filter.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=MAX_WIND_SECTIONS as i64))]
    pub(crate) wind_sections: u32,
    /// Length of the comparison of the linear and the nonlinear model that measures the model's
    /// error (s; its first 10 s left out).
    #[arg(long, default_value_t = 100.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) error_t_end: f64,
    /// The weight of the feed's rotation against its position (m per rad).
    #[arg(long, default_value_t = 1.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) tilt_weight: f64,
    /// The bound against the fixes' rate (Hz, comma-separated; each the unit's rate divided by a
    /// whole number) and delay (--delays): bound.csv.
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true)]
    pub(crate) rates: Vec<f64>,
    /// Delays of the bound's sweep (s, comma-separated).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_value = "0,0.02,0.05,0.1,0.2,0.3")]
    pub(crate) delays: Vec<f64>,
    /// Wind seeds (comma-separated) on which to run the designed scene, the scene as given and
    /// uncompensated in the monolithic model (the design measures its model's error on the
    /// scene's own seed: give others).
    #[arg(long, value_delimiter = ',')]
    pub(crate) evaluate: Vec<u64>,
    /// Simulated time of each evaluation run (s).
    #[arg(long, default_value_t = 300.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Worker threads of the evaluation (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) jobs: Option<u16>,
    /// Print JSON.
    #[arg(long)]
    pub(crate) json: bool,
}

fn share(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if (0.0..=1.0).contains(&x) => Ok(x),
        Ok(x) => Err(format!("{x} is not a share in [0, 1]")),
        Err(e) => Err(format!("`{text}`: {e}")),
    }
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let shown = args.scene.display().to_string();
    let settings = lqg::Settings {
        modes: args.modes as usize,
        keep_below_hz: args.keep_below,
        min_cabin_share: args.min_cabin_share,
        wind_sections: args.wind_sections as usize,
        error_t_end: args.error_t_end,
        tilt_weight_m: args.tilt_weight,
        rates: args.rates.clone(),
        delays: args.delays.clone(),
        evaluate: args.evaluate.clone(),
        t_end: args.t_end,
        jobs: args.jobs.map(usize::from),
        limits: caps().run,
    };
    let designing = Designing::new(&scene, &shown, settings)?;
    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
    let scene_id = outputs.declare("--out", &args.out.join(format!("{}_lqg.toml", scene.name)), Some("toml"))?;
    let report_id = outputs.declare("--out", &args.out.join("design.md"), Some("md"))?;
    let sweep_ids = if args.rates.is_empty() {
        None
    } else {
        Some((
            outputs.declare("--out", &args.out.join("bound.csv"), Some("csv"))?,
            outputs.declare("--out", &args.out.join("bound.svg"), Some("svg"))?,
        ))
    };
    outputs.open()?;
    let results = designing.run(&args.scene, &Shown { lines: true, bars: false })?;

    let designed = results.designed.clone();
    designed.clone().validated(&outputs.path(scene_id).display().to_string()).context("the designed scene")?;
    let header = format!("# `master design --scene {shown}`: the second level's LQG controller; see design.md.\n");
    outputs.write(scene_id, |w| w.write_all((header + &designed.to_toml()).as_bytes()))?;
    let report = results.report();
    outputs.write(report_id, |w| w.write_all(report.as_bytes()))?;
    if let Some((csv_id, svg_id)) = sweep_ids {
        let svg = results.bound_svg()?;
        outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
        outputs.write(csv_id, |w| w.write_all(results.bound_csv().as_bytes()))?;
    }
    let mut ids = vec![scene_id, report_id];
    ids.extend(sweep_ids.iter().flat_map(|(a, b)| [*a, *b]));
    let paths: Vec<String> = ids.iter().map(|&i| outputs.path(i).display().to_string()).collect();
    outputs.commit()?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&results.json(&paths))?)?;
    } else {
        write!(out, "{report}")?;
        writeln!(out, "\nwritten: {}", paths.join(", "))?;
    }
    Ok(())
}
