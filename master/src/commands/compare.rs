//! `master compare`: each scheme's error against the monolithic model at the same step.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::Context;
use serde_json::json;
use studies::simulate::{Run, RunError};
use studies::table::Table;

use super::output::{Outputs, run_inputs};
use super::run::plot_traces;
use super::scheme_args::{SchemeName, SchemeOptions, named};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub(crate) scene: PathBuf,
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
    /// No progress bars.
    #[arg(long)]
    pub(crate) quiet: bool,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let dt = args.dt.unwrap_or(scene.solver.dt_s);
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    let quiet = args.quiet || args.json || !std::io::stderr().is_terminal();
    // errors at every step: every run samples every step
    let sampled = scene.edited(|s| s.outputs.sample_interval_s = dt).context("--dt")?;
    let limits = caps().run;
    let prepare = |options: &SchemeOptions, name: SchemeName| -> anyhow::Result<Run> {
        Ok(Run::prepare(&sampled, &args.scene, options.method(name)?, dt, t_end, &limits)?)
    };
    // the reference at the fixed step even when the schemes take the adaptive one
    let reference = prepare(&args.options.fixed_step(), SchemeName::Monolithic)?;
    let runs: Vec<(SchemeName, Run)> =
        args.schemes.iter().map(|&name| Ok((name, prepare(&args.options, name)?))).collect::<anyhow::Result<_>>()?;
    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    outputs.open()?;

    let reference = reference.execute_watched(&mut crate::progress::Progress::new(quiet))?;
    let peak = reference.peak_mm();
    let mut rows = Vec::new();
    let mut traces = vec![reference.clone()];
    for (name, run) in &runs {
        let name = name.as_str();
        match run.execute_watched(&mut crate::progress::Progress::new(quiet)) {
            Ok(t) => {
                let (max, rms) = t.error_against(&reference);
                rows.push(json!({"scheme": name, "max_error_mm": max, "rms_error_mm": rms, "max_error_percent_of_peak": 100.0 * max / peak,
                    "mean_iterations": t.mean_iterations(), "wall_time_s": t.wall_time_s, "peak_disp_mm": t.peak_mm()}));
                traces.push(t);
            }
            // a scheme that breaks down is a result, not a reason to stop the comparison
            Err(e @ RunError::Stopped { .. }) => rows.push(json!({"scheme": name, "failed": e.to_string()})),
            Err(e) => return Err(e.into()),
        }
    }
    if let Some(id) = svg {
        let title = format!("{}: cabin-centre response at h = {dt} s", scene.name);
        plot_traces(&outputs, id, &traces.iter().collect::<Vec<_>>(), &title)?;
    }
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    if args.json {
        let all = json!({"scene": scene.name, "dt": dt, "t_end": t_end, "monolithic": {"peak_disp_mm": peak,
            "wall_time_s": reference.wall_time_s, "mean_iterations": reference.mean_iterations()}, "schemes": rows});
        writeln!(out, "{}", serde_json::to_string_pretty(&all)?)?;
        return Ok(());
    }
    writeln!(out, "{}: errors of the cabin-centre displacement against monolithic, h = {dt} s, {t_end} s", scene.name)?;
    writeln!(
        out,
        "monolithic: peak {peak:.4} mm, {:.2} Newton iterations per step, {:.2} s",
        reference.mean_iterations(),
        reference.wall_time_s
    )?;
    writeln!(out)?;
    let mut t =
        Table::new(["scheme", "max error mm", "RMS error mm", "max error % of peak", "iterations/step", "wall s"]);
    for r in &rows {
        let name = r["scheme"].as_str().unwrap_or("?").to_string();
        if let Some(f) = r.get("failed") {
            let reason: String = f.as_str().unwrap_or("").chars().take(60).collect();
            t.row([name, "failed".into(), "".into(), "".into(), "".into(), reason]);
            continue;
        }
        let g = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        t.row([
            name,
            format!("{:.3e}", g("max_error_mm")),
            format!("{:.3e}", g("rms_error_mm")),
            format!("{:.3}", g("max_error_percent_of_peak")),
            format!("{:.2}", g("mean_iterations")),
            format!("{:.2}", g("wall_time_s")),
        ]);
    }
    write!(out, "{}", t.render())?;
    Ok(())
}
