//! `master bench`: run time against error. Every scheme at every macro step, the median wall time
//! of a few repetitions, and the error of the cabin-centre displacement against a fine-step
//! monolithic reference; a table, `bench.csv` and a log–log work–precision plot. With
//! `--adaptive-rtols`, the schemes that iterate also with the adaptive step at each tolerance,
//! each against the cheapest fixed step of the same scheme that is as accurate, and against the
//! fixed step that would be exactly as accurate, interpolated between the grid's steps
//! (`bench_adaptive.csv`).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use anyhow::{Context, bail};
use master::journal::{self, Journal};
use master::plot::{Precision, work_precision};
use master::simulate::{Run, RunError, Trace};
use master::table::Table;

use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, positive, tolerance};
use super::{CmdResult, caps, fingerprint, load_scene};

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
        default_value = "monolithic,ijcsa,iqn-ils,iterative,gauss-seidel,jacobi,decoupled"
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
    /// Also run every scheme of --schemes that iterates with the adaptive step at these
    /// relative tolerances (comma-separated, e.g. 1e-3,1e-2), each against the cheapest fixed
    /// step of the same scheme that reaches its error.
    #[arg(long, value_delimiter = ',', value_parser = tolerance)]
    pub(crate) adaptive_rtols: Vec<f64>,
    /// Directory for bench.csv, work_precision.svg (and bench_adaptive.csv).
    #[arg(long, default_value = "out/bench")]
    pub(crate) out: PathBuf,
    /// No progress bars.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Continue a bench that was interrupted or killed: the measurements its journal in --out
    /// (`bench.csv.partial`, written as each finishes) holds are not taken again (the reference
    /// run is); they keep their wall times.
    #[arg(long)]
    pub(crate) resume: bool,
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

/// What an adaptive run measured: median wall time, max error, and its steps.
struct AdaptiveMeasured {
    wall: f64,
    max: f64,
    steps: u64,
    rejected: u64,
    h_min: f64,
    h_max: f64,
}

/// A measurement as a journal keeps it: `ok` and its numbers (exactly), or `failed` and why.
fn to_cells(result: &Result<Vec<f64>, String>) -> Vec<String> {
    match result {
        Ok(numbers) => std::iter::once("ok".to_owned()).chain(numbers.iter().map(|x| format!("{x:?}"))).collect(),
        Err(why) => vec!["failed".to_owned(), why.clone()],
    }
}

/// The measurement a journal line gives, if a run can give it: `count` numbers, each finite
/// and not negative (times, errors, counts, steps), or why the run failed.
fn from_cells(cells: &[String], count: usize) -> anyhow::Result<Result<Vec<f64>, String>> {
    let number = |x: &String| -> anyhow::Result<f64> {
        let v: f64 = x.parse().with_context(|| format!("a journal number `{x}`"))?;
        anyhow::ensure!(v.is_finite() && v >= 0.0, "a journal number `{x}`");
        Ok(v)
    };
    match cells {
        [ok, numbers @ ..] if ok == "ok" && numbers.len() == count => {
            Ok(Ok(numbers.iter().map(number).collect::<anyhow::Result<_>>()?))
        }
        [failed, why] if failed == "failed" => Ok(Err(why.clone())),
        _ => anyhow::bail!("a journal measurement of {} fields", cells.len()),
    }
}

/// Runs `run` `repeats` times: the median wall time and the last trace; a run that stops (a
/// scheme breaking down) is a result of the benchmark, given as its message.
fn repeated(run: &Run, repeats: u32, quiet: bool) -> anyhow::Result<Result<(f64, Trace), String>> {
    let mut walls = Vec::new();
    let mut last = None;
    for _ in 0..repeats {
        match run.execute(quiet) {
            Ok(t) => {
                walls.push(t.wall_time_s);
                last = Some(t);
            }
            Err(e @ RunError::Stopped { .. }) => return Ok(Err(e.to_string())),
            Err(e) => return Err(e.into()),
        }
    }
    walls.sort_by(f64::total_cmp);
    Ok(last.map(|t| (walls[walls.len() / 2], t)).ok_or_else(|| "no run".to_string()))
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let mut scene = load_scene(&args.scene)?;
    let dts = &args.dts;
    if dts.is_empty() {
        bail!("--dts: give at least one step");
    }
    if args.options.adaptive {
        bail!(
            "--adaptive: the grid of --dts runs at fixed steps; give the adaptive runs' tolerances with --adaptive-rtols"
        );
    }
    if (!args.options.watch.is_empty() || args.options.estimate.is_some()) && args.adaptive_rtols.is_empty() {
        bail!("--watch and --estimate are for the adaptive runs: give their tolerances with --adaptive-rtols");
    }
    // the grid and the reference at fixed steps
    let fixed = args.options.fixed_step();
    let t_end = args.t_end.unwrap_or(scene.solver.t_end_s);
    // one sampling for all runs: the coarsest step, so every trace has the same times
    let coarse = dts.iter().cloned().fold(0.0, f64::max);
    for d in dts {
        let ratio = coarse / d;
        if (ratio - ratio.round()).abs() > 1e-9 * ratio {
            bail!("--dts: {d} does not divide the coarsest step {coarse}");
        }
    }
    scene = scene.edited(|s| s.outputs.sample_interval_s = coarse).context("--dts")?;
    let reference_dt = args.reference_dt.unwrap_or(dts.iter().cloned().fold(f64::INFINITY, f64::min) / 4.0);

    // every run is checked before the first one starts
    let (variant, file) = (scene.clone(), args.scene.clone());
    let limits = caps().run;
    let mut runs = Vec::new();
    for &name in &args.schemes {
        for &dt in dts {
            let context = || format!("{} at h = {dt} s", name.as_str());
            let method = fixed.method(name).with_context(context)?;
            runs.push((name, dt, Run::prepare(&variant, &file, method, dt, t_end, &limits).with_context(context)?));
        }
    }
    // adaptive runs sample every accepted step: they are compared with a reference sampled at
    // its own step (interpolated between its samples)
    let (reference_scene, reference_file) = if args.adaptive_rtols.is_empty() {
        (variant.clone(), file.clone())
    } else {
        let fine = variant.edited(|s| s.outputs.sample_interval_s = reference_dt).context("--reference-dt")?;
        (fine, file.clone())
    };
    let reference = Run::prepare(
        &reference_scene,
        &reference_file,
        fixed.method(SchemeName::Monolithic)?,
        reference_dt,
        t_end,
        &limits,
    )
    .context("the monolithic reference (--reference-dt)")?;
    let mut adaptive_runs = Vec::new();
    for &rtol in &args.adaptive_rtols {
        for &name in args.schemes.iter().filter(|s| s.has_adaptive_step()) {
            let options = SchemeOptions { adaptive: true, rtol, ..args.options.clone() };
            let context = || format!("{} with the adaptive step at rtol {rtol:e}", name.as_str());
            let method = options.method(name).with_context(context)?;
            adaptive_runs.push((
                name,
                rtol,
                Run::prepare(&variant, &file, method, dts[0], t_end, &limits).with_context(context)?,
            ));
        }
    }
    let mut outputs = Outputs::new(run_inputs(&args.scene, &variant));
    let csv_id = outputs.declare("--out", &args.out.join("bench.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("work_precision.svg"), Some("svg"))?;
    let adaptive_id = (!adaptive_runs.is_empty())
        .then(|| outputs.declare("--out", &args.out.join("bench_adaptive.csv"), Some("csv")))
        .transpose()?;
    outputs.open()?;

    let identity = format!(
        "bench {} {:?} {:?} {} {:?} {reference_dt:?} {:?} {:?}",
        fingerprint(&variant),
        args.schemes.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
        dts,
        args.repeats,
        t_end,
        args.adaptive_rtols,
        args.options
    );
    let journal = Journal::open(&journal::path(&args.out, "bench.csv"), &identity, args.resume)?;
    let quiet = args.quiet || !std::io::stderr().is_terminal();
    eprintln!("reference: monolithic at h = {reference_dt} s …");
    let reference = reference.execute(quiet)?;
    let peak = reference.peak_mm();
    let percent = |m: f64| if peak > 0.0 { 100.0 * m / peak } else { f64::NAN };
    // the measurements an earlier run took: a run's label is its key in the journal
    let labels: Vec<(String, usize)> = runs
        .iter()
        .map(|(name, dt, _)| (format!("{} at h = {dt} s", name.as_str()), 4))
        .chain(adaptive_runs.iter().map(|(name, rtol, _)| (format!("{} adaptive at rtol {rtol:e}", name.as_str()), 6)))
        .collect();
    let mut earlier: Vec<_> = labels
        .iter()
        .enumerate()
        .map(|(i, (label, count))| journal.take(i, label, |cells| from_cells(cells, *count)))
        .collect();
    journal.say_dropped();
    // a measurement: from the journal where an earlier run took it, else taken and journaled
    let mut measure = |i: usize, run: &Run, numbers: &dyn Fn(f64, &Trace) -> Vec<f64>| {
        if let Some(done) = earlier[i].take() {
            return anyhow::Ok(done);
        }
        let label = &labels[i].0;
        eprintln!("{label} …");
        let taken =
            repeated(run, args.repeats, quiet).with_context(|| label.clone())?.map(|(wall, t)| numbers(wall, &t));
        journal.record(i, label, &to_cells(&taken))?;
        Ok(taken)
    };
    let mut cells = Vec::new();
    for (i, (name, dt, run)) in runs.iter().enumerate() {
        let numbers = measure(i, run, &|wall, t| {
            let (max, rms) = t.error_against(&reference);
            vec![wall, max, rms, t.mean_iterations()]
        })?;
        let result = numbers.map(|m| Measured { wall: m[0], max: m[1], rms: m[2], iterations: m[3] });
        cells.push(Cell { scheme: *name, dt: *dt, result });
    }
    let mut adaptive_cells = Vec::new();
    for (k, (name, rtol, run)) in adaptive_runs.iter().enumerate() {
        let numbers = measure(runs.len() + k, run, &|wall, t| {
            let s = &t.summary;
            let max = t.error_against(&reference).0;
            vec![wall, max, s.steps as f64, s.rejected_steps as f64, s.h_min_used, s.h_max_used]
        })?;
        let result = numbers.map(|m| AdaptiveMeasured {
            wall: m[0],
            max: m[1],
            steps: m[2] as u64,
            rejected: m[3] as u64,
            h_min: m[4],
            h_max: m[5],
        });
        adaptive_cells.push((*name, *rtol, result));
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
            adaptive: adaptive_cells
                .iter()
                .filter(|a| a.0 == name)
                .filter_map(|a| a.2.as_ref().ok().filter(|m| m.max > 0.0).map(|m| (m.wall, m.max)))
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
    let adaptive_table = match adaptive_id {
        Some(id) => {
            let (table, csv) = adaptive_results(&adaptive_cells, &cells, peak);
            outputs.write(id, |w| w.write_all(csv.as_bytes()))?;
            Some((table, outputs.path(id).to_owned()))
        }
        None => None,
    };
    let (csv_path, svg_path) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;
    journal.finish()?;

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
    if let Some((table, path)) = adaptive_table {
        write!(out, "{}", table.render())?;
        writeln!(out)?;
        writeln!(out, "{} written", path.display())?;
    }
    writeln!(out, "{} and {} written", csv_path.display(), svg_path.display())?;
    Ok(())
}

/// The fixed step `(h, wall time)` that would reach `error` exactly, from `grid` (`(h, error,
/// wall time)` of one scheme): interpolated log–log between the two neighbouring steps whose
/// errors bracket it (error and cost are near powers of h); `None` outside the grid.
fn as_accurate(grid: &[(f64, f64, f64)], error: f64) -> Option<(f64, f64)> {
    let mut sorted = grid.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    sorted.windows(2).find_map(|w| {
        let ((h0, e0, c0), (h1, e1, c1)) = (w[0], w[1]);
        if !(e0 > 0.0 && e0 <= error && error <= e1 && e0 < e1) {
            return None;
        }
        let s = (error / e0).ln() / (e1 / e0).ln();
        Some((h0 * (h1 / h0).powf(s), c0 * (c1 / c0).powf(s)))
    })
}

/// The adaptive runs as a table and as CSV: each with the cheapest fixed step of its scheme in
/// the grid that is as accurate, the fixed step interpolated to be exactly as accurate, and the
/// cost ratios.
fn adaptive_results(
    adaptive: &[(SchemeName, f64, Result<AdaptiveMeasured, String>)],
    cells: &[Cell],
    peak: f64,
) -> (Table, String) {
    let mut table = Table::new([
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
        "h as accurate (interpolated)",
        "cost ratio to it",
    ]);
    let mut csv = String::from(
        "scheme,rtol,wall_time_s,max_error_mm,max_error_percent_of_peak,steps,rejected_steps,h_min_used,h_max_used,\
         fixed_dt_s,fixed_wall_time_s,cost_ratio,interpolated_dt_s,interpolated_wall_time_s,interpolated_cost_ratio,\
         failure\n",
    );
    let percent = |m: f64| if peak > 0.0 { 100.0 * m / peak } else { f64::NAN };
    for (name, rtol, result) in adaptive {
        let scheme = name.as_str();
        match result {
            Ok(m) => {
                let fixed = cells
                    .iter()
                    .filter(|c| c.scheme == *name)
                    .filter_map(|c| c.result.as_ref().ok().filter(|x| x.max <= m.max).map(|x| (c.dt, x.wall)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let grid: Vec<(f64, f64, f64)> = cells
                    .iter()
                    .filter(|c| c.scheme == *name)
                    .filter_map(|c| c.result.as_ref().ok().map(|x| (c.dt, x.max, x.wall)))
                    .collect();
                let exact = as_accurate(&grid, m.max);
                let p = percent(m.max);
                let given = |f: &dyn Fn((f64, f64)) -> String| fixed.map_or(String::new(), f);
                let interpolated = |f: &dyn Fn((f64, f64)) -> String| exact.map_or(String::new(), f);
                table.row([
                    scheme.to_string(),
                    format!("{rtol:e}"),
                    format!("{:.3}", m.wall),
                    format!("{:.3e}", m.max),
                    if p.is_finite() { format!("{p:.4}") } else { "—".into() },
                    m.steps.to_string(),
                    m.rejected.to_string(),
                    format!("{:.1e} … {:.1e}", m.h_min, m.h_max),
                    fixed.map_or("none in --dts".into(), |f| format!("h = {}", f.0)),
                    fixed.map_or("—".into(), |f| format!("{:.3}", f.1)),
                    fixed.map_or("—".into(), |f| format!("{:.2}", m.wall / f.1)),
                    exact.map_or("outside --dts".into(), |f| format!("h = {:.4}", f.0)),
                    exact.map_or("—".into(), |f| format!("{:.2}", m.wall / f.1)),
                ]);
                csv.push_str(&format!(
                    "{scheme},{rtol:e},{},{:e},{},{},{},{},{},{},{},{},{},{},{},\n",
                    m.wall,
                    m.max,
                    if p.is_finite() { p.to_string() } else { String::new() },
                    m.steps,
                    m.rejected,
                    m.h_min,
                    m.h_max,
                    given(&|f| f.0.to_string()),
                    given(&|f| f.1.to_string()),
                    given(&|f| (m.wall / f.1).to_string()),
                    interpolated(&|f| f.0.to_string()),
                    interpolated(&|f| f.1.to_string()),
                    interpolated(&|f| (m.wall / f.1).to_string()),
                ));
            }
            Err(e) => {
                let short = e.split(';').next().unwrap_or_default().to_string();
                let mut row = vec![scheme.to_string(), format!("{rtol:e}"), "failed".into()];
                row.extend(std::iter::repeat_n(String::new(), 9));
                row.push(short);
                table.row(row);
                csv.push_str(&format!("{scheme},{rtol:e},,,,,,,,,,,,,,\"{}\"\n", e.replace('"', "'")));
            }
        }
    }
    (table, csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A measurement reads back as written; one with a number that is not finite or negative,
    /// too few or too many numbers, or of another shape does not.
    #[test]
    fn only_a_measurement_a_run_can_give_reads_back_from_the_journal() {
        let taken: Result<Vec<f64>, String> = Ok(vec![0.236, 1.1e-4, 3e-5, 2.02]);
        let failed: Result<Vec<f64>, String> = Err("unstable at t = 0.3 s".into());
        for m in [&taken, &failed] {
            assert_eq!(&from_cells(&to_cells(m), 4).unwrap(), m);
        }
        let cells = |x: &[&str]| x.iter().map(|c| c.to_string()).collect::<Vec<_>>();
        for bad in [
            cells(&["ok", "0.2", "NaN", "3e-5", "2"]),
            cells(&["ok", "0.2", "inf", "3e-5", "2"]),
            cells(&["ok", "-0.2", "1e-4", "3e-5", "2"]),
            cells(&["ok", "0.2", "1e-4", "3e-5"]),
            cells(&["ok", "0.2", "1e-4", "3e-5", "2", "2"]),
            cells(&["failed"]),
            cells(&["maybe", "0.2"]),
        ] {
            assert!(from_cells(&bad, 4).is_err(), "{bad:?}");
        }
    }
}
