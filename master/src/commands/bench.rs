//! `master bench`: run time against error. Every scheme at every macro step, the median wall time
//! of a few repetitions, and the error of the cabin-centre displacement against a fine-step
//! monolithic reference; a table, `bench.csv` and a log–log work–precision plot.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::{Context, bail};
use master::plot::{Precision, work_precision};
use master::simulate::{Run, RunError, Trace, write_variant};
use master::table::Table;

use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, positive};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Methods (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "monolithic,ijcsa,iterative,gauss-seidel,jacobi,decoupled"
    )]
    pub(crate) schemes: Vec<SchemeName>,
    /// Macro steps (s, comma-separated); the coarsest must be a whole multiple of each.
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.04,0.02,0.01,0.005,0.0025")]
    pub(crate) dts: Vec<f64>,
    /// Runs per scheme and step; the median wall time is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub(crate) repeats: u32,
    /// Simulated time (s); default: the scene's solver.t_end_s.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) t_end: Option<f64>,
    /// Step of the monolithic reference (s); default: the smallest step / 4.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) reference_dt: Option<f64>,
    /// Directory for bench.csv and work_precision.svg.
    #[arg(long, default_value = "out/bench")]
    pub(crate) out: PathBuf,
    /// No progress bars.
    #[arg(long)]
    pub(crate) quiet: bool,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
}

/// What a scheme at one step measured: median wall time, max and RMS error, iterations.
struct Measured {
    wall: f64,
    max: f64,
    rms: f64,
    iterations: f64,
}

/// One cell of the benchmark.
struct Cell {
    scheme: SchemeName,
    dt: f64,
    result: Result<Measured, String>,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let mut scene = load_scene(&args.scene)?;
    let dts = &args.dts;
    if dts.is_empty() {
        bail!("--dts: give at least one step");
    }
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    // one sampling for all runs: the coarsest step, so every trace has the same times
    let coarse = dts.iter().cloned().fold(0.0, f64::max);
    for d in dts {
        let ratio = coarse / d;
        if (ratio - ratio.round()).abs() > 1e-9 * ratio {
            bail!("--dts: {d} does not divide the coarsest step {coarse}");
        }
    }
    scene.outputs.sample_interval_s = coarse;
    let reference_dt = args.reference_dt.unwrap_or(dts.iter().cloned().fold(f64::INFINITY, f64::min) / 4.0);

    // every run is checked before the first one starts
    let (variant, file) = write_variant(&scene, &args.scene, &format!("bench-{}", scene.name))
        .context("writing the bench's copy of the scene")?;
    let limits = caps().run;
    let mut runs = Vec::new();
    for &name in &args.schemes {
        for &dt in dts {
            let run = Run::prepare(&variant, &file, args.options.method(name), dt, t_end, &limits)
                .with_context(|| format!("{} at h = {dt} s", name.as_str()))?;
            runs.push((name, dt, run));
        }
    }
    let reference =
        Run::prepare(&variant, &file, args.options.method(SchemeName::Monolithic), reference_dt, t_end, &limits)
            .context("the monolithic reference (--reference-dt)")?;
    let mut outputs = Outputs::new(run_inputs(&args.scene, &variant));
    let csv_id = outputs.declare("--out", &args.out.join("bench.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("work_precision.svg"), Some("svg"))?;
    outputs.open()?;

    let quiet = args.quiet || !std::io::stderr().is_terminal();
    eprintln!("reference: monolithic at h = {reference_dt} s …");
    let reference = reference.execute(quiet)?;
    let peak = reference.peak_mm();
    let percent = |m: f64| if peak > 0.0 { 100.0 * m / peak } else { f64::NAN };
    let mut cells = Vec::new();
    for (name, dt, run) in &runs {
        eprintln!("{} at h = {dt} s …", name.as_str());
        let mut walls = Vec::new();
        let mut last: Option<Trace> = None;
        let mut failure = None;
        for _ in 0..args.repeats {
            match run.execute(quiet) {
                Ok(t) => {
                    walls.push(t.wall_time_s);
                    last = Some(t);
                }
                // a scheme that breaks down is a result of the benchmark
                Err(e @ RunError::Stopped { .. }) => {
                    failure = Some(e.to_string());
                    break;
                }
                Err(e) => return Err(e).with_context(|| format!("{} at h = {dt} s", name.as_str())),
            }
        }
        let result = match (failure, last) {
            (Some(e), _) => Err(e),
            (None, Some(t)) => {
                walls.sort_by(f64::total_cmp);
                let (max, rms) = t.error_against(&reference);
                Ok(Measured { wall: walls[walls.len() / 2], max, rms, iterations: t.mean_iterations() })
            }
            (None, None) => Err("no run".into()),
        };
        cells.push(Cell { scheme: *name, dt: *dt, result });
    }

    let mut table =
        Table::new(["scheme", "h s", "wall s", "max error mm", "RMS error mm", "% of peak", "iter/step", "note"]);
    let mut csv = String::from(
        "scheme,dt_s,wall_time_s,max_error_mm,rms_error_mm,max_error_percent_of_peak,mean_iterations,failure\n",
    );
    for c in &cells {
        let name = c.scheme.as_str();
        match &c.result {
            Ok(m) => {
                let p = percent(m.max);
                let p_csv = if p.is_finite() { p.to_string() } else { String::new() };
                csv.push_str(&format!(
                    "{name},{},{},{:e},{:e},{p_csv},{},\n",
                    c.dt, m.wall, m.max, m.rms, m.iterations
                ));
                table.row([
                    name.to_string(),
                    c.dt.to_string(),
                    format!("{:.3}", m.wall),
                    format!("{:.3e}", m.max),
                    format!("{:.3e}", m.rms),
                    if p.is_finite() { format!("{p:.4}") } else { "—".into() },
                    format!("{:.2}", m.iterations),
                    String::new(),
                ]);
            }
            Err(e) => {
                let short = e.split(';').next().unwrap_or_default().to_string();
                csv.push_str(&format!("{name},{},,,,,,\"{}\"\n", c.dt, e.replace('"', "'")));
                let mut row = vec![name.to_string(), c.dt.to_string()];
                row.extend(std::iter::repeat_n(String::new(), 5));
                row.push(short);
                table.row(row);
            }
        }
    }
    outputs.write(csv_id, |w| w.write_all(csv.as_bytes()))?;

    let mut schemes: Vec<SchemeName> = cells.iter().map(|c| c.scheme).collect();
    schemes.dedup();
    // a zero error (a run identical to the reference) has no place on a log axis
    let lines: Vec<Precision> = schemes
        .iter()
        .map(|&name| Precision {
            name: name.as_str(),
            points: cells
                .iter()
                .filter(|c| c.scheme == name)
                .filter_map(|c| c.result.as_ref().ok().filter(|m| m.max > 0.0).map(|m| (m.wall, m.max)))
                .collect(),
        })
        .collect();
    let svg = work_precision(
        &format!("{}: work–precision, {t_end} s simulated (reference: monolithic at h = {reference_dt} s)", scene.name),
        "wall time (s)",
        "max error of the cabin-centre displacement (mm)",
        &lines,
        (peak > 0.0).then_some((0.01 * peak, "1 % of the peak")),
    )
    .context("drawing the work–precision plot")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    let (csv_path, svg_path) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {t_end} s simulated; reference monolithic at h = {reference_dt} s, peak {peak:.4} mm",
        scene.name
    )?;
    writeln!(out)?;
    write!(out, "{}", table.render())?;
    writeln!(out)?;
    // per scheme: the smallest error reached and the cheapest run within 1 % of the peak
    let mut summary = Table::new(["scheme", "smallest error mm", "at h s", "cheapest within 1 % of peak", "wall s"]);
    for &name in &schemes {
        let ok: Vec<(&Cell, &Measured)> =
            cells.iter().filter(|c| c.scheme == name).filter_map(|c| c.result.as_ref().ok().map(|m| (c, m))).collect();
        let best = ok.iter().min_by(|a, b| a.1.max.total_cmp(&b.1.max));
        let cheap = ok.iter().filter(|(_, m)| m.max <= 0.01 * peak).min_by(|a, b| a.1.wall.total_cmp(&b.1.wall));
        summary.row([
            name.as_str().to_string(),
            best.map_or("—".into(), |(_, m)| format!("{:.3e}", m.max)),
            best.map_or("—".into(), |(c, _)| c.dt.to_string()),
            cheap.map_or("not reached".into(), |(c, _)| format!("h = {} s", c.dt)),
            cheap.map_or("—".into(), |(_, m)| format!("{:.3}", m.wall)),
        ]);
    }
    write!(out, "{}", summary.render())?;
    writeln!(out)?;
    writeln!(out, "{} and {} written", csv_path.display(), svg_path.display())?;
    Ok(())
}
