//! `master compare`: each scheme's error against the monolithic model at the same step.

use std::io::IsTerminal;
use std::path::PathBuf;

use feedcore::scene::Scene;
use master::simulate::simulate;
use master::table::Table;
use serde_json::json;

use super::CmdResult;
use super::run::plot_traces;
use super::scheme_args::{SCHEMES, SchemeOptions};

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub scene: PathBuf,
    /// Comma-separated methods to compare with `monolithic`.
    #[arg(long, default_value = "ijcsa,iqn-ils,iterative,gauss-seidel,jacobi,decoupled", long_help = format!("Comma-separated methods to compare with the monolithic reference: {SCHEMES}."))]
    pub schemes: String,
    /// Macro step (s) of every run; default: the scene's solver.dt_s.
    #[arg(long)]
    pub dt: Option<f64>,
    /// End time (s); default: the scene's solver.t_end_s.
    #[arg(long)]
    pub t_end: Option<f64>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Draw all displacement histories in one SVG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub options: SchemeOptions,
}

pub fn run(args: &Args) -> CmdResult {
    let scene = Scene::load(&args.scene)?;
    let dt = args.dt.unwrap_or(scene.solver.dt_s);
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    let quiet = args.quiet || args.json || !std::io::stderr().is_terminal();
    let reference = simulate(&scene, &args.scene, args.options.fixed_step().method("monolithic")?, dt, t_end, quiet)?;
    let peak = reference.peak_mm();
    let mut rows = Vec::new();
    let mut traces = vec![reference.clone()];
    for name in args.schemes.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let method = args.options.method(name)?;
        // a scheme that breaks down is a result, not a reason to stop the comparison
        match simulate(&scene, &args.scene, method, dt, t_end, quiet) {
            Ok(t) => {
                let (max, rms) = t.error_against(&reference);
                rows.push(json!({"scheme": name, "max_error_mm": max, "rms_error_mm": rms, "max_error_percent_of_peak": 100.0 * max / peak,
                    "mean_iterations": t.mean_iterations(), "wall_time_s": t.wall_time_s, "peak_disp_mm": t.peak_mm()}));
                traces.push(t);
            }
            Err(e) => rows.push(json!({"scheme": name, "failed": e.to_string()})),
        }
    }
    if let Some(p) = &args.plot {
        plot_traces(
            &traces.iter().collect::<Vec<_>>(),
            &format!("{}: cabin-centre response at h = {dt} s", scene.name),
            p,
        )?;
    }
    if args.json {
        let out = json!({"scene": scene.name, "dt": dt, "t_end": t_end, "monolithic": {"peak_disp_mm": peak,
            "wall_time_s": reference.wall_time_s, "mean_iterations": reference.mean_iterations()}, "schemes": rows});
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("{}: errors of the cabin-centre displacement against monolithic, h = {dt} s, {t_end} s", scene.name);
    println!(
        "monolithic: peak {peak:.4} mm, {:.2} Newton iterations per step, {:.2} s",
        reference.mean_iterations(),
        reference.wall_time_s
    );
    println!();
    let mut t =
        Table::new(["scheme", "max error mm", "RMS error mm", "max error % of peak", "iterations/step", "wall s"]);
    for r in &rows {
        let name = r["scheme"].as_str().unwrap_or("?").to_string();
        if let Some(f) = r.get("failed") {
            t.row([
                name,
                "failed".into(),
                "".into(),
                "".into(),
                "".into(),
                f.as_str().unwrap_or("").chars().take(60).collect(),
            ]);
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
    print!("{}", t.render());
    Ok(())
}
