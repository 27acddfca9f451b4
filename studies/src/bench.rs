//! Run time against error: every method at every macro step, the median wall time of a few
//! repetitions, and the error of the cabin-centre displacement against a fine-step monolithic
//! reference; with adaptive tolerances, the methods that iterate also with the adaptive step at
//! each, against the cheapest fixed step of the same method that is as accurate, and against the
//! fixed step that would be exactly as accurate, interpolated between the grid's steps. The
//! table, its CSV, the adaptive runs' CSV and a log–log work–precision plot.

use std::path::Path;

use anyhow::{Context, bail};
use feedcore::scene::ValidScene;

use crate::limits::Limits;
use crate::observe::Observer;
use crate::options::{SchemeName, SchemeOptions};
use crate::plot::{PlotError, Precision, work_precision};
use crate::points::Store;
use crate::simulate::{Run, RunError, Trace};
use crate::table::Table;

/// What is measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub schemes: Vec<SchemeName>,
    /// Macro steps, s; the coarsest a whole multiple of each.
    pub dts: Vec<f64>,
    /// Runs per method and step (the median wall time is reported).
    pub repeats: u32,
    /// Simulated time, s (`None`: the scene's `solver.t_end_s`).
    pub t_end: Option<f64>,
    /// Step of the monolithic reference, s (`None`: the smallest step / 4).
    pub reference_dt: Option<f64>,
    /// The adaptive step's relative tolerances for the methods that iterate.
    pub adaptive_rtols: Vec<f64>,
    pub options: SchemeOptions,
    pub limits: Limits,
}

impl Default for Settings {
    fn default() -> Self {
        use SchemeName::*;
        Settings {
            schemes: vec![Monolithic, Ijcsa, IqnIls, Iterative, GaussSeidel, Jacobi, Decoupled],
            dts: vec![0.04, 0.02, 0.01, 0.005, 0.0025],
            repeats: 3,
            t_end: None,
            reference_dt: None,
            adaptive_rtols: Vec::new(),
            options: SchemeOptions::default(),
            limits: Limits::default(),
        }
    }
}

/// What a method at one step measured: median wall time, max and RMS error, iterations.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    pub wall: f64,
    pub max: f64,
    pub rms: f64,
    pub iterations: f64,
}

/// One cell of the benchmark: a method at a step, or why it broke down.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub scheme: SchemeName,
    pub dt: f64,
    pub result: Result<Measured, String>,
}

/// What an adaptive run measured: median wall time, max error, and its steps.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveMeasured {
    pub wall: f64,
    pub max: f64,
    pub steps: u64,
    pub rejected: u64,
    pub h_min: f64,
    pub h_max: f64,
}

/// A method with the adaptive step at one tolerance.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveCell {
    pub scheme: SchemeName,
    pub rtol: f64,
    pub result: Result<AdaptiveMeasured, String>,
}

/// A benchmark ready to run: the scene sampled at the coarsest step, every run checked.
pub struct Bench<'a> {
    file: &'a Path,
    scene: ValidScene,
    /// The reference's scene (sampled at its own step when adaptive runs are compared with it).
    reference_scene: ValidScene,
    settings: Settings,
    pub t_end: f64,
    pub reference_dt: f64,
}

/// The benchmark's results.
#[derive(Clone, Debug)]
pub struct Results {
    pub scene: String,
    pub t_end: f64,
    pub reference_dt: f64,
    /// The reference's largest cabin-centre displacement, mm.
    pub peak: f64,
    pub cells: Vec<Cell>,
    pub adaptive: Vec<AdaptiveCell>,
}

/// A measurement as a store keeps it: `ok` and its numbers (exactly), or `failed` and why.
fn to_cells(result: &Result<Vec<f64>, String>) -> Vec<String> {
    match result {
        Ok(numbers) => std::iter::once("ok".to_owned()).chain(numbers.iter().map(|x| format!("{x:?}"))).collect(),
        Err(why) => vec!["failed".to_owned(), why.clone()],
    }
}

/// The measurement a store's cells give, if a run can give it: `count` numbers, each finite and
/// not negative (times, errors, counts, steps), or why the run failed.
fn from_cells(cells: &[String], count: usize) -> anyhow::Result<Result<Vec<f64>, String>> {
    let number = |x: &String| -> anyhow::Result<f64> {
        let v: f64 = x.parse().with_context(|| format!("a number `{x}`"))?;
        anyhow::ensure!(v.is_finite() && v >= 0.0, "a number `{x}`");
        Ok(v)
    };
    match cells {
        [ok, numbers @ ..] if ok == "ok" && numbers.len() == count => {
            Ok(Ok(numbers.iter().map(number).collect::<anyhow::Result<_>>()?))
        }
        [failed, why] if failed == "failed" => Ok(Err(why.clone())),
        _ => anyhow::bail!("a measurement of {} fields", cells.len()),
    }
}

/// Runs `run` `repeats` times: the median wall time and the last trace; a run that stops (a
/// method breaking down) is a result of the benchmark, given as its message.
fn repeated(run: &Run, repeats: u32, observer: &dyn Observer) -> anyhow::Result<Result<(f64, Trace), String>> {
    let mut walls = Vec::new();
    let mut last = None;
    for _ in 0..repeats {
        match run.execute_watched(&mut *observer.watch()) {
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

impl<'a> Bench<'a> {
    /// The benchmark on `scene` (read from `file`), every run checked before any starts.
    pub fn new(scene: &ValidScene, file: &'a Path, settings: Settings) -> anyhow::Result<Bench<'a>> {
        let dts = &settings.dts;
        if dts.is_empty() {
            bail!("--dts: give at least one step");
        }
        if settings.options.adaptive {
            bail!(
                "--adaptive: the grid of --dts runs at fixed steps; give the adaptive runs' tolerances with \
                 --adaptive-rtols"
            );
        }
        let o = &settings.options;
        if (!o.watch.is_empty() || o.estimate.is_some()) && settings.adaptive_rtols.is_empty() {
            bail!("--watch and --estimate are for the adaptive runs: give their tolerances with --adaptive-rtols");
        }
        let t_end = settings.t_end.unwrap_or(scene.solver.t_end_s);
        // one sampling for all runs: the coarsest step, so every trace has the same times
        let coarse = dts.iter().cloned().fold(0.0, f64::max);
        for d in dts {
            let ratio = coarse / d;
            if (ratio - ratio.round()).abs() > 1e-9 * ratio {
                bail!("--dts: {d} does not divide the coarsest step {coarse}");
            }
        }
        let scene = scene.edited(|s| s.outputs.sample_interval_s = coarse).context("--dts")?;
        let reference_dt = settings.reference_dt.unwrap_or(dts.iter().cloned().fold(f64::INFINITY, f64::min) / 4.0);
        // adaptive runs sample every accepted step: they are compared with a reference sampled
        // at its own step (interpolated between its samples)
        let reference_scene = if settings.adaptive_rtols.is_empty() {
            scene.clone()
        } else {
            scene.edited(|s| s.outputs.sample_interval_s = reference_dt).context("--reference-dt")?
        };
        let bench = Bench { file, scene, reference_scene, settings, t_end, reference_dt };
        bench.runs()?;
        bench.reference()?;
        bench.adaptive_runs()?;
        Ok(bench)
    }

    /// The grid's runs at fixed steps.
    fn runs(&self) -> anyhow::Result<Vec<(SchemeName, f64, Run<'_>)>> {
        let fixed = self.settings.options.fixed_step();
        let mut runs = Vec::new();
        for &name in &self.settings.schemes {
            for &dt in &self.settings.dts {
                let context = || format!("{} at h = {dt} s", name.as_str());
                let method = fixed.method(name).with_context(context)?;
                let run = Run::prepare(&self.scene, self.file, method, dt, self.t_end, &self.settings.limits);
                runs.push((name, dt, run.with_context(context)?));
            }
        }
        Ok(runs)
    }

    fn reference(&self) -> anyhow::Result<Run<'_>> {
        let method = self.settings.options.fixed_step().method(SchemeName::Monolithic)?;
        let (scene, limits) = (&self.reference_scene, &self.settings.limits);
        Run::prepare(scene, self.file, method, self.reference_dt, self.t_end, limits)
            .context("the monolithic reference (--reference-dt)")
    }

    fn adaptive_runs(&self) -> anyhow::Result<Vec<(SchemeName, f64, Run<'_>)>> {
        let s = &self.settings;
        let mut runs = Vec::new();
        for &rtol in &s.adaptive_rtols {
            for &name in s.schemes.iter().filter(|s| s.has_adaptive_step()) {
                let options = SchemeOptions { adaptive: true, rtol, ..s.options.clone() };
                let context = || format!("{} with the adaptive step at rtol {rtol:e}", name.as_str());
                let method = options.method(name).with_context(context)?;
                let run = Run::prepare(&self.scene, self.file, method, s.dts[0], self.t_end, &s.limits);
                runs.push((name, rtol, run.with_context(context)?));
            }
        }
        Ok(runs)
    }

    /// Whether there are adaptive runs (and so a table of them).
    pub fn has_adaptive_runs(&self) -> bool {
        !self.settings.adaptive_rtols.is_empty() && self.settings.schemes.iter().any(|s| s.has_adaptive_step())
    }

    /// Runs the reference, then every measurement `store` does not hold from an earlier run,
    /// keeping each there as it is taken (a run's label is its key).
    pub fn run(&self, store: &dyn Store, observer: &dyn Observer) -> anyhow::Result<Results> {
        let (runs, adaptive_runs) = (self.runs()?, self.adaptive_runs()?);
        observer.begin(&format!("reference: monolithic at h = {} s", self.reference_dt));
        let reference = self.reference()?.execute_watched(&mut *observer.watch())?;
        let labels: Vec<(String, usize)> = runs
            .iter()
            .map(|(name, dt, _)| (format!("{} at h = {dt} s", name.as_str()), 4))
            .chain(
                adaptive_runs.iter().map(|(name, rtol, _)| (format!("{} adaptive at rtol {rtol:e}", name.as_str()), 6)),
            )
            .collect();
        let mut earlier: Vec<_> = labels
            .iter()
            .enumerate()
            .map(|(i, (label, count))| crate::points::earlier(store, i, label, |cells| from_cells(cells, *count)))
            .collect();
        store.looked_up();
        // a measurement: from the store where an earlier run took it, else taken and kept
        let mut measure = |i: usize, run: &Run, numbers: &dyn Fn(f64, &Trace) -> Vec<f64>| {
            if let Some(done) = earlier[i].take() {
                return anyhow::Ok(done);
            }
            crate::cancel::check()?;
            let label = &labels[i].0;
            observer.begin(label);
            let taken = repeated(run, self.settings.repeats, observer)
                .with_context(|| label.clone())?
                .map(|(wall, t)| numbers(wall, &t));
            store.record(i, label, &to_cells(&taken))?;
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
        let mut adaptive = Vec::new();
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
            adaptive.push(AdaptiveCell { scheme: *name, rtol: *rtol, result });
        }
        Ok(Results {
            scene: self.scene.name.clone(),
            t_end: self.t_end,
            reference_dt: self.reference_dt,
            peak: reference.peak_mm(),
            cells,
            adaptive,
        })
    }
}

impl Results {
    fn percent(&self, m: f64) -> f64 {
        if self.peak > 0.0 { 100.0 * m / self.peak } else { f64::NAN }
    }

    /// The methods in the order measured.
    fn schemes(&self) -> Vec<SchemeName> {
        let mut schemes: Vec<SchemeName> = self.cells.iter().map(|c| c.scheme).collect();
        schemes.dedup();
        schemes
    }

    /// The grid as a table and as `bench.csv`.
    pub fn grid(&self) -> (Table, String) {
        let mut table =
            Table::new(["scheme", "h s", "wall s", "max error mm", "RMS error mm", "% of peak", "iter/step", "note"]);
        let mut csv = String::from(
            "scheme,dt_s,wall_time_s,max_error_mm,rms_error_mm,max_error_percent_of_peak,mean_iterations,failure\n",
        );
        for c in &self.cells {
            let name = c.scheme.as_str();
            match &c.result {
                Ok(m) => {
                    let p = self.percent(m.max);
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
        (table, csv)
    }

    /// Per method: the smallest error reached and the cheapest run within 1 % of the peak.
    pub fn summary(&self) -> Table {
        let mut summary =
            Table::new(["scheme", "smallest error mm", "at h s", "cheapest within 1 % of peak", "wall s"]);
        for name in self.schemes() {
            let ok: Vec<(&Cell, &Measured)> = self
                .cells
                .iter()
                .filter(|c| c.scheme == name)
                .filter_map(|c| c.result.as_ref().ok().map(|m| (c, m)))
                .collect();
            let best = ok.iter().min_by(|a, b| a.1.max.total_cmp(&b.1.max));
            let cheap =
                ok.iter().filter(|(_, m)| m.max <= 0.01 * self.peak).min_by(|a, b| a.1.wall.total_cmp(&b.1.wall));
            summary.row([
                name.as_str().to_string(),
                best.map_or("—".into(), |(_, m)| format!("{:.3e}", m.max)),
                best.map_or("—".into(), |(c, _)| c.dt.to_string()),
                cheap.map_or("not reached".into(), |(c, _)| format!("h = {} s", c.dt)),
                cheap.map_or("—".into(), |(_, m)| format!("{:.3}", m.wall)),
            ]);
        }
        summary
    }

    /// The adaptive runs as a table and as `bench_adaptive.csv`.
    pub fn adaptive(&self) -> (Table, String) {
        adaptive_results(&self.adaptive, &self.cells, self.peak)
    }

    /// `work_precision.svg`: error against wall time, a line per method, the adaptive runs as rings.
    pub fn svg(&self) -> Result<String, PlotError> {
        // a zero error (a run identical to the reference) has no place on a log axis
        let lines: Vec<Precision> = self
            .schemes()
            .iter()
            .map(|&name| Precision {
                name: name.as_str(),
                points: self
                    .cells
                    .iter()
                    .filter(|c| c.scheme == name)
                    .filter_map(|c| c.result.as_ref().ok().filter(|m| m.max > 0.0).map(|m| (m.wall, m.max)))
                    .collect(),
                adaptive: self
                    .adaptive
                    .iter()
                    .filter(|a| a.scheme == name)
                    .filter_map(|a| a.result.as_ref().ok().filter(|m| m.max > 0.0).map(|m| (m.wall, m.max)))
                    .collect(),
            })
            .collect();
        work_precision(
            &format!(
                "{}: work–precision, {} s simulated (reference: monolithic at h = {} s)",
                self.scene, self.t_end, self.reference_dt
            ),
            "wall time (s)",
            "max error of the cabin-centre displacement (mm)",
            &lines,
            (self.peak > 0.0).then_some((0.01 * self.peak, "1 % of the peak")),
        )
    }
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
fn adaptive_results(adaptive: &[AdaptiveCell], cells: &[Cell], peak: f64) -> (Table, String) {
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
    for AdaptiveCell { scheme: name, rtol, result } in adaptive {
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
    fn only_a_measurement_a_run_can_give_reads_back_from_a_store() {
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
