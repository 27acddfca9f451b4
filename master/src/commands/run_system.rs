//! `master run --system FILE`: any system of FMI 2.0 Co-Simulation FMUs described in SSP 1.0
//! (an `.ssp` archive, or an `.ssd` with its FMUs beside it), run by a coupling scheme. The CSV
//! holds `time` and every output of every component as `<component>.<variable>`.

use std::path::Path;

use master::plot::Figure;
use master::simulate::Method;
use master::system::run_system;
use serde_json::json;

use super::CmdResult;
use super::run::{Args, create_parent};

pub fn run(args: &Args, file: &Path) -> CmdResult {
    let loaded = cosim::ssp::read::load(file)?;
    let (options, adaptive) = match args.options.method(&args.scheme)? {
        Method::Cosim(o) => (o, None),
        Method::CosimAdaptive(o, a) => (o, Some(a)),
        other => {
            return Err(format!(
                "--scheme {}: runs only the LT50m scene (--scene); a --system runs with a coupling scheme \
                 (jacobi, gauss-seidel, iterative, ijcsa, iqn-ils)",
                other.name()
            )
            .into());
        }
    };
    let dt = args.dt.ok_or("--dt: give the macro step of the system (s)")?;
    let start = loaded.start_time.unwrap_or(0.0);
    if start != 0.0 {
        return Err(format!("{}: DefaultExperiment startTime = {start}; the master starts at 0", file.display()).into());
    }
    let t_end = args
        .t_end
        .or(loaded.stop_time)
        .ok_or("--t-end: give the end time (the system description has no DefaultExperiment stopTime)")?;
    let quiet = args.quiet || args.json || !std::io::IsTerminal::is_terminal(&std::io::stderr());
    // the plot reads the time histories back from the CSV (a private one without --out)
    let scratch = std::env::temp_dir().join(format!("master-system-{}.csv", std::process::id()));
    let csv = args.out.clone().or_else(|| args.plot.as_ref().map(|_| scratch.clone()));
    if let Some(out) = &csv {
        create_parent(out)?;
    }
    let run = run_system(&loaded.spec, options, adaptive, dt, t_end, csv.as_deref(), quiet)?;
    if let Some((t, why)) = &run.stopped_early {
        eprintln!("note: the run ended early at t = {t} s: {why}");
    }
    if let (Some(p), Some(csv)) = (&args.plot, &csv) {
        plot_outputs(csv, p, &format!("{}: {} at h = {dt} s", file.display(), options.scheme.name()))?;
        if args.out.is_none() {
            let _ = std::fs::remove_file(csv);
        }
    }
    if args.json {
        let v = json!({
            "system": file.display().to_string(),
            "scheme": options.scheme.name(),
            "dt": dt,
            "t_end": t_end,
            "steps": run.steps,
            "rejected_steps": run.rejected_steps,
            "h_min_used": run.h_min_used,
            "h_max_used": run.h_max_used,
            "wall_time_s": run.wall_time_s,
            "mean_iterations": run.mean_iterations,
            "max_interface_residual": run.max_residual,
            "outputs": run.columns.len() - 1,
            "stopped_early": run.stopped_early.is_some(),
            "stopped_at": run.stopped_early.as_ref().map(|s| s.0),
            "note": run.stopped_early.as_ref().map(|s| s.1.clone()),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "{} — {} at h = {dt} s to {t_end} s: {} steps in {:.3} s, {:.2} iterations per step, largest interface residual {:.2e}",
        file.display(),
        options.scheme.name(),
        run.steps,
        run.wall_time_s,
        run.mean_iterations,
        run.max_residual
    );
    if adaptive.is_some() {
        println!(
            "adaptive step: {} rejected, h from {:.3e} to {:.3e} s",
            run.rejected_steps, run.h_min_used, run.h_max_used
        );
    }
    if let Some(out) = &args.out {
        println!("time histories of {} outputs: {}", run.columns.len() - 1, out.display());
    }
    Ok(())
}

/// Every numeric output of the CSV against time, one panel per component.
fn plot_outputs(csv: &Path, svg: &Path, title: &str) -> CmdResult {
    if svg.extension().and_then(|e| e.to_str()) != Some("svg") {
        return Err(format!("--plot {}: only SVG is written; name the file *.svg", svg.display()).into());
    }
    let text = std::fs::read_to_string(csv)?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let rows: Vec<Vec<f64>> =
        lines.map(|l| l.split(',').map(|x| x.parse::<f64>().unwrap_or(f64::NAN)).collect()).collect();
    let mut components: Vec<&str> = header.iter().skip(1).filter_map(|c| c.split('.').next()).collect();
    components.dedup();
    let t: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    create_parent(svg)?;
    let mut fig = Figure::new(900, 320 * components.len().max(1) as u32 + 60);
    fig.title(title);
    for comp in components {
        fig.panel(|p| {
            p.title(comp).x_label("time (s)");
            for (j, name) in header.iter().enumerate().skip(1) {
                if name.split('.').next() == Some(comp) {
                    let y: Vec<f64> = rows.iter().map(|r| r.get(j).copied().unwrap_or(f64::NAN)).collect();
                    if y.iter().all(|v| v.is_finite()) {
                        p.line(name, &t, &y);
                    }
                }
            }
            p
        });
    }
    fig.write_svg(svg)?;
    Ok(())
}
