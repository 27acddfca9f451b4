//! `master run`: one simulation of the scene with the chosen method (or, with `--system`, of
//! any system of FMUs: [`super::run_system`]).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::{Context, bail};
use studies::limits::num;
use studies::plot::{History, time_history};
use studies::simulate::{Run, Trace};

use studies::vtk::RunSeries;

use super::args::Quiet;
use super::output::{OutputId, Outputs, run_inputs};
use super::scheme_args::{Compensation, SchemeName, SchemeOptions, named};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML), e.g. scenes/lt50m_C.toml. Its [system] section names the FMUs.
    #[arg(long, required_unless_present = "system", conflicts_with = "system")]
    pub(crate) scene: Option<PathBuf>,
    /// Any system of FMI 2.0 Co-Simulation FMUs in SSP 1.0: an `.ssp` archive, or an `.ssd` with
    /// the FMUs beside it. The CSV then holds `time` and every output as `<component>.<variable>`.
    #[arg(long)]
    pub(crate) system: Option<PathBuf>,
    /// Method.
    #[arg(long, value_parser = named::<SchemeName>())]
    pub(crate) scheme: SchemeName,
    /// Macro step (s); default: the scene's solver.dt_s. The end time must be a whole number of
    /// steps. Not with --adaptive.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) dt: Option<f64>,
    /// End time (s); default: the scene's solver.t_end_s.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) t_end: Option<f64>,
    /// Write the time histories as CSV: t, dx_mm, dy_mm, dz_mm (cabin-centre displacement from the
    /// static equilibrium), rx_mrad, ry_mrad, rz_mrad (rotation), fx_n … mz_nm (Stewart wrench) —
    /// the groups the scene's outputs.quantities ask for, at its outputs.sample_interval_s (with
    /// --adaptive: every accepted step, its size in an h_s column after t). With --system: time
    /// (and with --adaptive h_s), then every output of every component.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub(crate) json: bool,
    /// Draw the cabin-centre displacement (X, Y, Z panels, like the paper's Figs. 4–5) as SVG.
    #[arg(long)]
    pub(crate) plot: Option<PathBuf>,
    /// Write the net for ParaView into this folder (created if missing; --scheme monolithic or
    /// cable): `<scene>.pvd` and one `<scene>/<scene>_<k>.vtu` per written sample — the cables as lines
    /// with their element tensions, the displacement from the start at every point, the cabin,
    /// the platform with its legs, the feed point; docs/scenes.md.
    #[arg(long, value_name = "DIR")]
    pub(crate) vtk: Option<PathBuf>,
    /// With --vtk: write every K-th output sample (from the first).
    #[arg(long, value_name = "K", requires = "vtk", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub(crate) vtk_every: u64,
    /// The second level (scenes with [control]): `off` runs the same scene with its compensation
    /// switched off, the uncompensated reference of its feed error.
    #[arg(long, default_value = "on", value_parser = named::<Compensation>())]
    pub(crate) compensation: Compensation,
    /// The seed of the scene's wind record (`[wind] seed`), instead of the scene's: the same
    /// spectrum, another record.
    #[arg(long, value_parser = studies::options::seed, allow_negative_numbers = true)]
    pub(crate) wind_seed: Option<u64>,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
    #[command(flatten)]
    pub(crate) system_files: super::scheme_args::SystemFileArgs,
    #[command(flatten)]
    pub(crate) quiet: Quiet,
}

/// The displacement histories as three stacked panels, into output `id`.
pub(crate) fn plot_traces(outputs: &Outputs, id: OutputId, traces: &[&Trace], title: &str) -> CmdResult {
    let runs: Vec<History> = traces.iter().map(|t| History { name: &t.method, t: &t.t, disp_mm: &t.disp_mm }).collect();
    let svg = time_history(title, &runs).context("drawing the time histories")?;
    outputs.write(id, |w| w.write_all(svg.as_bytes()))
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene_file = match (&args.scene, &args.system) {
        (Some(f), _) => f,
        (None, Some(system)) => {
            if args.vtk.is_some() {
                bail!(
                    "--vtk writes the cable net of a scene's run (--scene with --scheme monolithic or cable); a system \
                     of FMUs has no net the master can see"
                );
            }
            return super::run_system::run(args, system);
        }
        (None, None) => bail!("give --scene or --system"),
    };
    if let Some(option) = args.system_files.files().given() {
        bail!("--{option} applies to --system (an SSP archive or .ssd); a --scene names its FMUs in [system]");
    }
    let scene = studies::options::with_wind_seed(&args.compensation.apply(&load_scene(scene_file)?)?, args.wind_seed)?;
    let method = args.options.method(args.scheme)?;
    studies::options::check_dt(args.options.adaptive, args.dt)?;
    let dt = args.dt.unwrap_or(scene.solver.dt_s);
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    let quiet = args.quiet.quiet || args.json || !std::io::stderr().is_terminal();
    // everything the run needs is checked before its first step
    let run = Run::prepare(&scene, scene_file, method, dt, t_end, &caps().run).with_context(|| {
        let from =
            |flag: bool, given: &str, key: &str| if flag { given.to_string() } else { format!("the scene's {key}") };
        let end = format!("end time {} s from {}", num(t_end), from(args.t_end.is_some(), "--t-end", "solver.t_end_s"));
        if args.options.adaptive {
            format!("adaptive steps within [{}, {}] s, {end}", num(args.options.h_min), num(args.options.h_max))
        } else {
            format!("h = {} s from {}, {end}", num(dt), from(args.dt.is_some(), "--dt", "solver.dt_s"))
        }
    })?;
    let mut outputs = Outputs::new(run_inputs(scene_file, &scene));
    let csv = args.out.as_ref().map(|p| outputs.declare("--out", p, None)).transpose()?;
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    let mut series = match &args.vtk {
        Some(dir) => {
            if let Some(reason) = run.method().net_refusal() {
                bail!("--vtk {}: {reason}", dir.display());
            }
            if let Some((flag, _)) = [("--out", &args.out), ("--plot", &args.plot)]
                .into_iter()
                .find(|(_, p)| p.as_deref() == Some(dir.as_path()))
            {
                bail!("--vtk {}: the same path as {flag}; give the VTK files a folder of their own", dir.display());
            }
            let layout = studies::net::Layout::of(&scene);
            Some(RunSeries::create(dir, &scene.name, &layout).with_context(|| format!("--vtk {}", dir.display()))?)
        }
        None => None,
    };
    outputs.open()?;

    let net = series.as_mut().map(|s| (s as &mut dyn studies::net::NetSink, args.vtk_every));
    let trace = run.execute_with_net(&mut crate::progress::Progress::new(quiet), net)?;
    let utilisation = studies::report::static_utilisation(&scene)?;
    if let Some(id) = csv {
        outputs.write(id, |w| trace.write_csv(w, &scene.outputs.quantities))?;
    }
    let steps = if trace.is_adaptive() {
        format!("the adaptive step (rtol {:e})", args.options.rtol)
    } else {
        format!("h = {dt} s")
    };
    if let Some(id) = svg {
        let title = format!("{}: cabin-centre response, {} at {steps}", scene.name, trace.method);
        plot_traces(&outputs, id, &[&trace], &title)?;
    }
    let vtk = match (series, &args.vtk) {
        (Some(series), Some(dir)) => {
            let files = series.series.len();
            Some((series.series.commit().with_context(|| format!("--vtk {}", dir.display()))?, files))
        }
        _ => None,
    };
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    if let Some(feed) = trace.feed.as_ref().filter(|f| !f.summary.events.is_empty()) {
        eprintln!(
            "warning: the platform reached a leg-stroke or actuator-force limit {} times (first: leg {} {} at t = {} s); \
             the run did not clip it — see the limit events",
            feed.summary.events.len(),
            feed.summary.events[0].leg,
            feed.summary.events[0].limit,
            instant(feed.summary.events[0].time_s)
        );
    }
    if let Some(u) = utilisation.as_ref().filter(|u| u.iter().any(|&x| x > 1.0)) {
        eprintln!(
            "warning: at the static equilibrium cables {:?} carry more than their breaking load (cables.breaking_load_n)",
            (0..u.len()).filter(|&i| u[i] > 1.0).collect::<Vec<_>>()
        );
    }
    if args.json {
        let s = studies::report::run_summary(&scene, &trace, utilisation.as_deref());
        writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
        return Ok(());
    }
    if let Some(u) = &utilisation {
        let list: Vec<String> = u.iter().map(|x| format!("{x:.3}")).collect();
        writeln!(out, "cable utilisation at the static equilibrium (tension / breaking load): {}", list.join(", "))?;
    }
    let m = trace.max_abs_disp_mm();
    writeln!(
        out,
        "{} — {} at {steps} to {t_end} s: {} steps in {:.3} s",
        scene.name, trace.method, trace.steps, trace.wall_time_s
    )?;
    if trace.is_adaptive() {
        let s = &trace.summary;
        writeln!(
            out,
            "adaptive step: {} tries rejected, h from {:.3e} to {:.3e} s",
            s.rejected_steps, s.h_min_used, s.h_max_used
        )?;
    }
    writeln!(
        out,
        "peak cabin-centre displacement {:.4} mm at t = {} s; |X| {:.4} mm, |Y| {:.4} mm, |Z| {:.4} mm",
        trace.peak_mm(),
        instant(trace.summary.peak_time_s),
        m[0],
        m[1],
        m[2]
    )?;
    match args.scheme {
        SchemeName::Monolithic => writeln!(
            out,
            "Newton iterations per step {:.2}, largest constraint residual {:.2e} m",
            trace.mean_iterations(),
            trace.constraint_residual()
        )?,
        SchemeName::Cable => writeln!(out, "Newton iterations per step {:.2}", trace.mean_iterations())?,
        _ => writeln!(
            out,
            "iterations per step {:.2}, largest interface residual {:.2e}",
            trace.mean_iterations(),
            trace.max_residual()
        )?,
    }
    if let Some(feed) = &trace.feed {
        let f = &feed.summary;
        writeln!(
            out,
            "feed error: RMS {:.4} mm, peak {:.4} mm at t = {} s; tilt RMS {:.4} mrad, peak {:.4} mrad",
            f.rms_mm,
            f.peak_mm,
            instant(f.peak_time_s),
            f.tilt_rms_mrad,
            f.tilt_peak_mrad
        )?;
        for e in &f.events {
            writeln!(
                out,
                "LIMIT REACHED: leg {} {} at t = {} s: {:.6} (limit {}) — not clipped",
                e.leg,
                e.limit,
                instant(e.time_s),
                e.value,
                e.bound
            )?;
        }
    }
    if let Some(p) = &args.out {
        writeln!(out, "time histories: {}", p.display())?;
    }
    if let Some(p) = &args.plot {
        writeln!(out, "plot: {}", p.display())?;
    }
    if let Some((index, files)) = &vtk {
        writeln!(out, "net for ParaView: {} ({files} files)", index.display())?;
    }
    Ok(())
}

/// An instant of the run as printed: to the nanosecond, without the noise of the sum of steps
/// that made it (32.23, not 32.230000000000004).
pub(crate) fn instant(t: f64) -> String {
    let fixed = format!("{t:.9}");
    if fixed.contains('.') { fixed.trim_end_matches('0').trim_end_matches('.').to_owned() } else { fixed }
}

#[cfg(test)]
mod tests {
    #[test]
    fn instants_print_without_the_sums_noise() {
        let printed = super::instant;
        assert_eq!(printed(32.230000000000004), "32.23");
        assert_eq!(printed(78.25), "78.25");
        assert_eq!(printed(100.0), "100");
        assert_eq!(printed(0.0), "0");
        assert_eq!(printed(0.0025), "0.0025");
        assert_eq!(printed(1e-10), "0");
        assert_eq!(printed(f64::NAN), "NaN");
    }
}
