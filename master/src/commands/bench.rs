//! `master bench`: run time against error. Every scheme at every macro step, the median wall time
//! of a few repetitions, and the error of the cabin-centre displacement against a fine-step
//! monolithic reference; a table, `bench.csv` and a log–log work–precision plot.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use feedcore::scene::Scene;
use master::plot::{Figure, Scale, Series};
use master::simulate::{Trace, simulate, write_variant};
use master::table::Table;

use super::CmdResult;
use super::run::create_parent;
use super::scheme_args::{SCHEMES, SchemeOptions};

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub scene: PathBuf,
    /// Comma-separated methods.
    #[arg(long, default_value = "monolithic,ijcsa,iqn-ils,iterative,gauss-seidel,jacobi,decoupled", long_help = format!("Comma-separated methods: {SCHEMES}."))]
    pub schemes: String,
    /// Comma-separated macro steps (s).
    #[arg(long, default_value = "0.04,0.02,0.01,0.005,0.0025")]
    pub dts: String,
    /// Runs per scheme and step; the median wall time is reported.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Simulated time (s); default: the scene's solver.t_end_s.
    #[arg(long)]
    pub t_end: Option<f64>,
    /// Step of the monolithic reference (s); default: the smallest step / 4.
    #[arg(long)]
    pub reference_dt: Option<f64>,
    /// Also run every implicit scheme of --schemes with the adaptive step at these relative
    /// tolerances (comma-separated, e.g. 1e-3), each against the cheapest fixed step of the same
    /// scheme that reaches its error.
    #[arg(long)]
    pub adaptive_rtols: Option<String>,
    /// Directory for bench.csv and work_precision.svg.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub options: SchemeOptions,
}

/// One cell of the benchmark.
struct Cell {
    scheme: String,
    dt: f64,
    result: Result<(f64, f64, f64, f64), String>, // wall (median), max error, RMS error, iterations
}

pub fn run(args: &Args) -> CmdResult {
    let mut scene = Scene::load(&args.scene)?;
    let dts: Vec<f64> = args
        .dts
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("--dts: {e}"))?;
    if dts.is_empty() || dts.iter().any(|d| !(*d > 0.0)) || args.repeats == 0 {
        return Err("--dts needs positive steps and --repeats at least 1".into());
    }
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    // one sampling for all runs: the coarsest step, so every trace has the same times
    let coarse = dts.iter().cloned().fold(0.0, f64::max);
    for d in &dts {
        let ratio = coarse / d;
        if (ratio - ratio.round()).abs() > 1e-9 {
            return Err(format!("--dts: {d} does not divide the coarsest step {coarse}").into());
        }
    }
    scene.outputs.sample_interval_s = coarse;
    let (scene, file) = write_variant(&scene, &args.scene, &format!("bench-{}", scene.name))?;
    let quiet = args.quiet || !std::io::stderr().is_terminal();
    let reference_dt = args.reference_dt.unwrap_or(dts.iter().cloned().fold(f64::INFINITY, f64::min) / 4.0);
    let rtols: Vec<f64> = match &args.adaptive_rtols {
        None => Vec::new(),
        Some(text) => text
            .split(',')
            .map(|x| x.trim().parse::<f64>().map_err(|e| format!("--adaptive-rtols: `{x}`: {e}")))
            .collect::<Result<_, _>>()?,
    };
    // adaptive runs sample every accepted step: compare them with a reference sampled at its step
    let (reference_scene, reference_file) = if rtols.is_empty() {
        (scene.clone(), file.clone())
    } else {
        let mut fine = scene.clone();
        fine.outputs.sample_interval_s = reference_dt;
        write_variant(&fine, &file, &format!("bench-reference-{}", scene.name))?
    };
    eprintln!("reference: monolithic at h = {reference_dt} s …");
    let reference = simulate(
        &reference_scene,
        &reference_file,
        args.options.fixed_step().method("monolithic")?,
        reference_dt,
        t_end,
        quiet,
    )?;
    let peak = reference.peak_mm();
    let mut cells = Vec::new();
    for name in args.schemes.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let method = args.options.method(name)?;
        for &dt in &dts {
            eprintln!("{name} at h = {dt} s …");
            let result =
                repeated(args.repeats, || simulate(&scene, &file, method, dt, t_end, quiet)).map(|(wall, t)| {
                    let (max, rms) = t.error_against(&reference);
                    (wall, max, rms, t.mean_iterations())
                });
            cells.push(Cell { scheme: name.to_string(), dt, result });
        }
    }
    // adaptive runs: (scheme, rtol, wall, max error, steps, rejected, h_min, h_max) or a failure
    let mut adaptive_rows = Vec::new();
    for &rtol in &rtols {
        for name in args.schemes.split(',').map(str::trim).filter(|s| matches!(*s, "iterative" | "ijcsa" | "iqn-ils")) {
            let mut o = args.options.clone();
            o.adaptive = true;
            o.rtol = rtol;
            let method = o.method(name)?;
            eprintln!("{name} adaptive at rtol = {rtol} …");
            let result =
                repeated(args.repeats, || simulate(&scene, &file, method, dts[0], t_end, quiet)).map(|(wall, t)| {
                    (wall, t.error_against(&reference).0, t.steps, t.rejected_steps, t.h_min_used, t.h_max_used)
                });
            adaptive_rows.push((name.to_string(), rtol, result));
        }
    }
    std::fs::create_dir_all(&args.out)?;
    let csv_path = args.out.join("bench.csv");
    let mut csv = std::fs::File::create(&csv_path)?;
    writeln!(
        csv,
        "scheme,dt_s,wall_time_s,max_error_mm,rms_error_mm,max_error_percent_of_peak,mean_iterations,failure"
    )?;
    let mut table =
        Table::new(["scheme", "h s", "wall s", "max error mm", "RMS error mm", "% of peak", "iter/step", "note"]);
    for c in &cells {
        match &c.result {
            Ok((w, m, r, it)) => {
                writeln!(csv, "{},{},{w},{m:e},{r:e},{},{it},", c.scheme, c.dt, 100.0 * m / peak)?;
                table.row([
                    c.scheme.clone(),
                    c.dt.to_string(),
                    format!("{w:.3}"),
                    format!("{m:.3e}"),
                    format!("{r:.3e}"),
                    format!("{:.4}", 100.0 * m / peak),
                    format!("{it:.2}"),
                    String::new(),
                ]);
            }
            Err(e) => {
                let short: String = e.split(':').take(2).collect::<Vec<_>>().join(":");
                writeln!(csv, "{},{},,,,,,\"{}\"", c.scheme, c.dt, e.replace('"', "'"))?;
                table.row([
                    c.scheme.clone(),
                    c.dt.to_string(),
                    "".into(),
                    "".into(),
                    "".into(),
                    "".into(),
                    "".into(),
                    short,
                ]);
            }
        }
    }
    let svg = args.out.join("work_precision.svg");
    create_parent(&svg)?;
    let mut fig = Figure::new(900, 600);
    fig.title(&format!(
        "{}: work–precision, {t_end} s simulated (reference: monolithic at h = {reference_dt} s)",
        scene.name
    ));
    fig.panel(|p| {
        p.x_label("wall time (s)")
            .y_label("max error of the cabin-centre displacement (mm)")
            .x_scale(Scale::Log10)
            .y_scale(Scale::Log10);
        let mut names: Vec<&str> = cells.iter().map(|c| c.scheme.as_str()).collect();
        names.dedup();
        for name in names {
            let pts: Vec<(f64, f64)> = cells
                .iter()
                .filter(|c| c.scheme == name)
                .filter_map(|c| c.result.as_ref().ok().filter(|r| r.1 > 0.0).map(|r| (r.0, r.1)))
                .collect();
            if !pts.is_empty() {
                let (x, y): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
                p.add(Series::line(name, &x, &y).auto_marker());
            }
        }
        p.hline(0.01 * peak, "1 % of the peak");
        p
    });
    fig.write_svg(&svg)?;
    println!("{}: {t_end} s simulated; reference monolithic at h = {reference_dt} s, peak {peak:.4} mm", scene.name);
    println!();
    print!("{}", table.render());
    println!();
    // per scheme: the smallest error reached and the cheapest run within 1 % of the peak
    let mut summary = Table::new(["scheme", "smallest error mm", "at h s", "cheapest within 1 % of peak", "wall s"]);
    let mut names: Vec<&str> = cells.iter().map(|c| c.scheme.as_str()).collect();
    names.dedup();
    for name in names {
        let ok: Vec<(&Cell, &_)> =
            cells.iter().filter(|c| c.scheme == name).filter_map(|c| c.result.as_ref().ok().map(|r| (c, r))).collect();
        let best = ok.iter().min_by(|a, b| a.1.1.total_cmp(&b.1.1));
        let cheap = ok.iter().filter(|(_, r)| r.1 <= 0.01 * peak).min_by(|a, b| a.1.0.total_cmp(&b.1.0));
        summary.row([
            name.to_string(),
            best.map_or("—".into(), |(_, r)| format!("{:.3e}", r.1)),
            best.map_or("—".into(), |(c, _)| c.dt.to_string()),
            cheap.map_or("not reached".into(), |(c, _)| format!("h = {} s", c.dt)),
            cheap.map_or("—".into(), |(_, r)| format!("{:.3}", r.0)),
        ]);
    }
    print!("{}", summary.render());
    println!();
    if !adaptive_rows.is_empty() {
        let mut t = Table::new([
            "adaptive",
            "rtol",
            "wall s",
            "max error mm",
            "% of peak",
            "steps",
            "rejected",
            "h min … max s",
            "cheapest fixed h reaching it",
            "its wall s",
            "cost ratio",
        ]);
        let mut lines = vec!["scheme,rtol,wall_time_s,max_error_mm,max_error_percent_of_peak,steps,rejected_steps,h_min_used,h_max_used,fixed_dt_s,fixed_wall_time_s,cost_ratio,failure".to_string()];
        for (name, rtol, r) in &adaptive_rows {
            match r {
                Ok((wall, err, steps, rejected, hmin, hmax)) => {
                    let fixed = cells
                        .iter()
                        .filter(|c| &c.scheme == name)
                        .filter_map(|c| c.result.as_ref().ok().filter(|x| x.1 <= *err).map(|x| (c.dt, x.0)))
                        .min_by(|a, b| a.1.total_cmp(&b.1));
                    t.row([
                        name.clone(),
                        format!("{rtol:e}"),
                        format!("{wall:.3}"),
                        format!("{err:.3e}"),
                        format!("{:.4}", 100.0 * err / peak),
                        steps.to_string(),
                        rejected.to_string(),
                        format!("{hmin:.1e} … {hmax:.1e}"),
                        fixed.map_or("none in --dts".into(), |f| format!("h = {}", f.0)),
                        fixed.map_or("—".into(), |f| format!("{:.3}", f.1)),
                        fixed.map_or("—".into(), |f| format!("{:.2}", wall / f.1)),
                    ]);
                    lines.push(format!(
                        "{name},{rtol:e},{wall},{err:e},{},{steps},{rejected},{hmin},{hmax},{},{},{},",
                        100.0 * err / peak,
                        fixed.map_or(String::new(), |f| f.0.to_string()),
                        fixed.map_or(String::new(), |f| f.1.to_string()),
                        fixed.map_or(String::new(), |f| (wall / f.1).to_string())
                    ));
                }
                Err(e) => {
                    t.row([
                        name.clone(),
                        format!("{rtol:e}"),
                        "failed".into(),
                        "".into(),
                        "".into(),
                        "".into(),
                        "".into(),
                        "".into(),
                        "".into(),
                        "".into(),
                        e.chars().take(60).collect(),
                    ]);
                    lines.push(format!("{name},{rtol:e},,,,,,,,,,,\"{}\"", e.replace('"', "'")));
                }
            }
        }
        print!("{}", t.render());
        println!();
        let adaptive_csv = args.out.join("bench_adaptive.csv");
        std::fs::write(&adaptive_csv, lines.join("\n") + "\n")?;
        println!("{} written", adaptive_csv.display());
    }
    println!("{} and {} written", csv_path.display(), svg.display());
    Ok(())
}

/// Runs `run` `repeats` times: the median wall time and the last trace, or the first failure.
fn repeated(
    repeats: usize,
    mut run: impl FnMut() -> Result<Trace, Box<dyn std::error::Error>>,
) -> Result<(f64, Trace), String> {
    let mut walls = Vec::with_capacity(repeats);
    let mut last = None;
    for _ in 0..repeats {
        let t = run().map_err(|e| e.to_string())?;
        walls.push(t.wall_time_s);
        last = Some(t);
    }
    walls.sort_by(f64::total_cmp);
    let trace = last.ok_or("no run")?;
    Ok((walls[walls.len() / 2], trace))
}
