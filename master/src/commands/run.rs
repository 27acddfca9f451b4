//! `master run`: one simulation of the scene with the chosen method.

use std::io::IsTerminal;
use std::path::PathBuf;

use feedcore::scene::Scene;
use master::plot::Figure;
use master::simulate::{Trace, simulate};
use serde_json::json;

use super::CmdResult;
use super::scheme_args::{SCHEMES, SchemeOptions};

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML), e.g. scenes/lt50m_C.toml. Its [system] section names the FMUs.
    #[arg(long, required_unless_present = "system", conflicts_with = "system")]
    pub scene: Option<PathBuf>,
    /// Any system of FMI 2.0 Co-Simulation FMUs in SSP 1.0: an `.ssp` archive, or an `.ssd` with
    /// the FMUs beside it. The CSV then holds `time` and every output as `<component>.<variable>`.
    #[arg(long)]
    pub system: Option<PathBuf>,
    /// Method: monolithic, jacobi, gauss-seidel, gauss-seidel-reversed, iterative, ijcsa, decoupled, cable.
    #[arg(long, long_help = format!("Method: {SCHEMES}."))]
    pub scheme: String,
    /// Macro step (s); default: the scene's solver.dt_s.
    #[arg(long)]
    pub dt: Option<f64>,
    /// End time (s); default: the scene's solver.t_end_s.
    #[arg(long)]
    pub t_end: Option<f64>,
    /// Write the time histories as CSV: t, dx_mm, dy_mm, dz_mm (cabin-centre displacement from the
    /// static equilibrium), rx_mrad, ry_mrad, rz_mrad (rotation), fx_n … mz_nm (Stewart wrench) —
    /// the groups the scene's outputs.quantities ask for, at its outputs.sample_interval_s.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
    /// Draw the cabin-centre displacement (X, Y, Z panels, like the paper's Figs. 4–5) as SVG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// No progress bar (it is also off when stderr is not a terminal).
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub options: SchemeOptions,
}

/// Creates the directory a result file goes to.
pub fn create_parent(path: &std::path::Path) -> std::io::Result<()> {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => std::fs::create_dir_all(d),
        _ => Ok(()),
    }
}

/// JSON summary of a trace.
pub fn summary(scene: &Scene, t: &Trace) -> serde_json::Value {
    json!({
        "scene": scene.name,
        "scheme": t.method,
        "dt": t.dt,
        "t_end": t.t_end,
        "steps": t.steps,
        "wall_time_s": t.wall_time_s,
        "max_abs_disp_mm": t.max_abs_disp_mm(),
        "peak_disp_mm": t.peak_mm(),
        "mean_iterations": t.mean_iterations(),
        "max_interface_residual": t.max_residual(),
        "max_constraint_residual_m": t.constraint_residual,
        "rejected_steps": t.rejected_steps,
        "h_min_used": t.h_min_used,
        "h_max_used": t.h_max_used,
    })
}

/// The displacement histories as three stacked panels.
pub fn plot_traces(traces: &[&Trace], title: &str, path: &PathBuf) -> CmdResult {
    if path.extension().and_then(|e| e.to_str()) != Some("svg") {
        return Err(format!("--plot {}: only SVG is written; name the file *.svg", path.display()).into());
    }
    create_parent(path)?;
    let mut fig = Figure::new(900, 780);
    fig.title(title).share_x(true);
    for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
        fig.panel(|p| {
            p.y_label(&format!("{axis} displacement (mm)")).x_label("time (s)");
            for t in traces {
                let y: Vec<f64> = t.disp_mm.iter().map(|d| d[k]).collect();
                p.line(&t.method, &t.t, &y);
            }
            p
        });
    }
    fig.write_svg(path)?;
    Ok(())
}

pub fn run(args: &Args) -> CmdResult {
    let scene_file = match (&args.scene, &args.system) {
        (Some(f), _) => f,
        (None, Some(system)) => return super::run_system::run(args, system),
        (None, None) => return Err("give --scene or --system".into()),
    };
    let scene = Scene::load(scene_file)?;
    let method = args.options.method(&args.scheme)?;
    let dt = args.dt.unwrap_or(scene.solver.dt_s);
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    let quiet = args.quiet || args.json || !std::io::stderr().is_terminal();
    let trace = simulate(&scene, scene_file, method, dt, t_end, quiet)?;
    if let Some(out) = &args.out {
        create_parent(out)?;
        trace.write_csv(out, &scene.outputs.quantities)?;
    }
    if let Some(p) = &args.plot {
        plot_traces(&[&trace], &format!("{}: cabin-centre response, {} at h = {dt} s", scene.name, trace.method), p)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary(&scene, &trace))?);
        return Ok(());
    }
    let m = trace.max_abs_disp_mm();
    println!(
        "{} — {} at h = {dt} s to {t_end} s: {} steps in {:.3} s",
        scene.name, trace.method, trace.steps, trace.wall_time_s
    );
    println!("peak cabin-centre displacement |X| {:.4} mm, |Y| {:.4} mm, |Z| {:.4} mm", m[0], m[1], m[2]);
    match trace.method.as_str() {
        "monolithic" => println!(
            "Newton iterations per step {:.2}, largest constraint residual {:.2e} m",
            trace.mean_iterations(),
            trace.constraint_residual
        ),
        "cable" => println!("Newton iterations per step {:.2}", trace.mean_iterations()),
        _ => println!(
            "iterations per step {:.2}, largest interface residual {:.2e}",
            trace.mean_iterations(),
            trace.max_residual()
        ),
    }
    if let Some(out) = &args.out {
        println!("time histories: {}", out.display());
    }
    if let Some(p) = &args.plot {
        println!("plot: {}", p.display());
    }
    Ok(())
}
