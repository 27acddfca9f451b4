//! `master sweep`: statics, first frequencies and (optionally) a short coupled run at every
//! point of a grid over the workspace and the parameters, on every core; `--shard i/n` runs one
//! of n disjoint parts (a cluster job array), `--merge` joins them. Writes `sweep.csv` and the
//! maps `sweep.svg` (tension margin and first frequency).
//!
//! Everything is checked before the first point: the grid, the shard, the surface, the run's
//! steps and caps, the memory of the models on every worker, and the output files.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Instant;

use crate::journal::{self, Journal};
use anyhow::Context;
use cable::model::CableCabin;
use studies::limits::{Footprint, check_memory_of};
use studies::parallel;
use studies::points::Codec;
use studies::simulate::Run;
use studies::sweep::table::{self, Table};
use studies::sweep::{self, Grid, Placement, Request, Shard, Surface, map};
use studies::table::Table as TextTable;

use super::args::{Quiet, Workers};
use super::output::{OutputId, Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, named, positive};
use super::{CmdResult, caps, fingerprint, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML): the base of every point.
    #[arg(long, required_unless_present = "merge")]
    pub(crate) scene: Option<PathBuf>,
    /// One axis of the grid (repeat for more): `name=start:stop:count` (both ends included) or
    /// `name=v1,v2,...`. Names: x, y, z (m, world position of the cabin centre point), mass
    /// (factor on every mass and inertia of the Stewart platform), dt (s, step of the coupled
    /// run). Points are all combinations, the first axis varying slowest.
    #[arg(long = "grid", value_name = "AXIS")]
    pub(crate) grid: Vec<String>,
    /// The cabin centre follows the lower half of the sphere `cx,cy,cz,r` (m): z from x and y
    /// (FAST's focal surface: 0,0,300,160).
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) surface: Option<String>,
    /// With --surface: tilt the cabin towards the sphere's axis by this share of the point's
    /// angle from the axis (FAST's cables take 14° of 40°: 0.35). Default: the scene's orientation.
    #[arg(long, requires = "surface", value_parser = studies::options::finite, allow_negative_numbers = true)]
    pub(crate) tilt_share: Option<f64>,
    /// Natural frequencies per point (0: none).
    #[arg(long, default_value_t = sweep::DEFAULT_MODES, value_parser = sweep::mode_count)]
    pub(crate) modes: usize,
    /// A short coupled run at every point with this method; it reports the peak cabin
    /// displacement, iterations per step and run time.
    #[arg(long, value_parser = named::<SchemeName>())]
    pub(crate) run: Option<SchemeName>,
    /// Simulated time of each coupled run (s); a whole number of every step swept.
    #[arg(long, default_value_t = sweep::DEFAULT_RUN_S, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Run part i of n only (0 ≤ i < n; points i, i + n, ...) and write sweep.part-i-of-n.csv.
    #[arg(long, value_name = "i/n")]
    pub(crate) shard: Option<String>,
    /// Join shard files (or directories holding sweep.part-*.csv) into sweep.csv and sweep.svg.
    #[arg(long, num_args = 1.., value_name = "PART", conflicts_with_all = ["scene", "grid", "shard", "run"])]
    pub(crate) merge: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out/sweep")]
    pub(crate) out: PathBuf,
    /// Continue a sweep that was interrupted or killed: the points its journal in --out
    /// (`sweep.csv.partial`, written as each point finishes) holds are not computed again, and
    /// the table is the uninterrupted one (but for wall times).
    #[arg(long, conflicts_with = "merge")]
    pub(crate) resume: bool,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
    #[command(flatten)]
    pub(crate) quiet: Quiet,
    #[command(flatten)]
    pub(crate) workers: Workers,
}

/// A finite number.
pub(crate) fn run(args: &Args) -> CmdResult {
    if !args.merge.is_empty() {
        return merge(args);
    }
    let scene_file = args.scene.as_ref().context("give --scene (or --merge with the parts to join)")?;
    let scene = load_scene(scene_file)?;
    let grid = Grid::parse(&args.grid)?;
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?.unwrap_or(Shard::ALL);
    let surface = args.surface.as_deref().map(Surface::parse).transpose()?;
    let placement = Placement { surface, tilt_share: args.tilt_share };
    let method = args.run.map(|s| args.options.method(s)).transpose()?;
    let limits = caps().run;
    let request = Request {
        modes: args.modes,
        run: method.clone().map(|m| (m, args.t_end)),
        limits,
        utilisation: scene.cables.breaking_load_n.is_some(),
    };
    let jobs = args.workers.jobs;
    let points: Vec<usize> = (0..grid.len()).filter(|i| shard.contains(*i)).collect();
    // every run's steps and what its method needs, at every step swept (the points differ
    // from the scene only in pose and masses)
    if let (Some(method), Some(name)) = (method, args.run) {
        for dt in grid.steps(scene.solver.dt_s) {
            Run::prepare(&scene, scene_file, method.clone(), dt, args.t_end, &limits)
                .with_context(|| format!("--run {} at h = {dt} s, --t-end {} s", name.as_str(), args.t_end))?;
        }
    }
    // the models of every worker at once
    let workers = parallel::threads(jobs).min(points.len()).max(1);
    let footprint = match args.run {
        Some(SchemeName::Cable) | None => Footprint::CableModel,
        Some(_) => Footprint::Coupled,
    };
    check_memory_of(&scene, footprint, CableCabin::modes_built(&scene, request.modes), workers as u64, &limits)
        .with_context(|| format!("{}: the sweep cannot start", scene_file.display()))?;
    let mut outputs = Outputs::new(run_inputs(scene_file, &scene));
    let csv_id = outputs.declare("--out", &table::file_name(&args.out, shard), Some("csv"))?;
    let svg_id = (shard == Shard::ALL && map::has_map(&grid))
        .then(|| outputs.declare("--out", &args.out.join("sweep.svg"), Some("svg")))
        .transpose()?;
    outputs.open()?;

    let run_text = match (args.run, &request.run) {
        (Some(name), Some((_, t))) => format!("{} for {t} s", name.as_str()),
        _ => "none".into(),
    };
    let header = vec![
        ("sweep".to_string(), "master sweep".to_string()),
        ("scene".into(), scene_file.file_name().map_or(String::new(), |n| n.to_string_lossy().into())),
        ("scene_name".into(), scene.name.clone()),
        ("scene_fingerprint".into(), fingerprint(&scene)),
        ("grid".into(), grid.describe()),
        ("surface".into(), surface.map_or("none".into(), |s| s.describe())),
        ("tilt_share".into(), args.tilt_share.map_or("none".into(), |s| format!("{s:?}"))),
        ("modes".into(), args.modes.to_string()),
        ("run".into(), run_text),
        ("points".into(), grid.len().to_string()),
        ("shard".into(), shard.to_string()),
    ];
    let columns = sweep::columns(&grid, &request);
    // every input that decides the rows: a journal of other work is refused
    let identity = format!("{header:?} {columns:?} {:?}", args.options);
    let csv_path = outputs.path(csv_id).to_owned();
    let csv_name = csv_path.file_name().map_or("sweep.csv".into(), |n| n.to_string_lossy().into_owned());
    let journal = Journal::open(&journal::path(&args.out, &csv_name), &identity, args.resume)?;

    let quiet = args.quiet.quiet || !std::io::stderr().is_terminal();
    eprintln!(
        "{}: {} of {} points (shard {shard}) on {workers} threads{}",
        scene.name,
        points.len(),
        grid.len(),
        if journal.resumed() > 0 { format!(", {} done before", journal.resumed()) } else { String::new() }
    );
    let done = std::sync::atomic::AtomicUsize::new(0);
    let start = Instant::now();
    let cost = |&index: &usize| grid.cost(index);
    let codec = Codec {
        key: |&index: &usize| sweep::point_key(index, &grid.point(index)),
        encode: |cells: &Vec<String>| cells.clone(),
        decode: |&index: &usize, cells: &[String]| {
            sweep::check_cells(&columns, index, &grid.point(index), cells).map_err(anyhow::Error::msg)?;
            Ok(cells.to_vec())
        },
    };
    let cells = studies::points::map(&points, jobs, cost, &journal, codec, |_, &index| {
        let values = grid.point(index);
        let outcome = sweep::evaluate(&scene, scene_file, &placement, &request, &values);
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if !quiet {
            eprintln!("[{k}/{}] point {index}: {}", points.len(), brief(&outcome));
        }
        Ok(sweep::cells(index, &values, &request, &outcome))
    })
    .map_err(journal::resumable(&journal))?;
    let rows: Vec<(usize, Vec<String>)> = points.iter().copied().zip(cells).collect();
    let wall = start.elapsed().as_secs_f64();
    let t = Table { header, columns, rows: rows.into_iter().collect() };
    let summary = finish(&t, &outputs, csv_id, svg_id)?;
    let csv = csv_path;
    outputs.commit()?;
    journal.finish()?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {} points in {wall:.2} s on {workers} threads ({:.3} s per point)",
        scene.name,
        points.len(),
        wall / points.len().max(1) as f64
    )?;
    if shard == Shard::ALL {
        write!(out, "{summary}")?;
    } else {
        writeln!(out, "{} written; join the parts with `master sweep --merge {}`", csv.display(), args.out.display())?;
    }
    Ok(())
}

fn merge(args: &Args) -> CmdResult {
    let files = table::part_files(&args.merge)?;
    let parts: Vec<(PathBuf, Table)> =
        files.iter().map(|f| Table::read(f).map(|t| (f.clone(), t))).collect::<Result<_, _>>()?;
    let merged = table::merge(&parts)?;
    let grid_spec = merged.get("grid").unwrap_or_default();
    let grid = Grid::parse(&grid_spec.split(' ').filter(|s| !s.is_empty()).map(String::from).collect::<Vec<_>>())
        .context("the parts' `grid` header")?;
    let mut outputs = Outputs::new(files.iter().cloned());
    let csv_id = outputs.declare("--out", &table::file_name(&args.out, Shard::ALL), Some("csv"))?;
    let svg_id =
        map::has_map(&grid).then(|| outputs.declare("--out", &args.out.join("sweep.svg"), Some("svg"))).transpose()?;
    outputs.open()?;
    let summary = finish(&merged, &outputs, csv_id, svg_id)?;
    outputs.commit()?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{} parts joined: {} points", parts.len(), merged.rows.len())?;
    write!(out, "{summary}")?;
    Ok(())
}

/// One line about a point for the progress log.
fn brief(o: &sweep::Outcome) -> String {
    if !o.feasible {
        return format!("infeasible ({})", o.note);
    }
    let mut s = format!("tensions {:.1}–{:.1} kN", o.min_tension_n * 1e-3, o.max_tension_n * 1e-3);
    if let Some(f) = o.frequencies_hz.first() {
        s += &format!(", f1 = {f:.4} Hz");
    }
    if let Some(r) = &o.run {
        s += &format!(", run peak {:.3} mm in {:.2} s", r.peak_mm, r.wall_s);
    }
    if !o.note.is_empty() {
        s += &format!(" ({})", o.note);
    }
    s
}

/// Writes the table and (a whole sweep's) maps into the outputs; returns the summary to print.
fn finish(t: &Table, outputs: &Outputs, csv_id: OutputId, svg_id: Option<OutputId>) -> anyhow::Result<String> {
    outputs.write(csv_id, |w| t.write_to(w))?;
    let csv = outputs.path(csv_id);
    let mut text = String::new();
    if t.get("shard") != Some(&Shard::ALL.to_string()) {
        return Ok(text);
    }
    let col = |n: &str| t.column(n);
    let num = |row: &[String], n: &str| col(n).and_then(|c| row[c].parse::<f64>().ok());
    let feasible: Vec<&Vec<String>> =
        t.rows.values().filter(|r| col("feasible").is_some_and(|c| r[c] == "true")).collect();
    let range = |n: &str| {
        feasible
            .iter()
            .filter_map(|r| num(r, n))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
    };
    text += &format!("{} of {} points feasible\n", feasible.len(), t.rows.len());
    if !feasible.is_empty() {
        let mut summary = TextTable::new(["quantity", "smallest", "largest"]);
        let (lo, hi) = range("min_tension_n");
        summary.row(["smallest cable tension (kN)".into(), format!("{:.2}", lo * 1e-3), format!("{:.2}", hi * 1e-3)]);
        let (lo, hi) = range("max_tension_n");
        summary.row(["largest cable tension (kN)".into(), format!("{:.2}", lo * 1e-3), format!("{:.2}", hi * 1e-3)]);
        if col("f1_hz").is_some() {
            let (lo, hi) = range("f1_hz");
            summary.row(["first frequency (Hz)".into(), format!("{lo:.4}"), format!("{hi:.4}")]);
        }
        if col("run_peak_mm").is_some() {
            let (lo, hi) = range("run_peak_mm");
            summary.row(["run: peak displacement (mm)".into(), format!("{lo:.3}"), format!("{hi:.3}")]);
            let (lo, hi) = range("run_wall_s");
            summary.row(["run: wall time (s)".into(), format!("{lo:.3}"), format!("{hi:.3}")]);
        }
        text += &summary.render();
    }
    match svg_id {
        Some(id) => {
            let svg = map::draw(t, outputs.path(id))?.context("a grid with a varying axis has a map")?;
            outputs.write(id, |w| w.write_all(svg.as_bytes()))?;
            text += &format!("{} and {} written\n", csv.display(), outputs.path(id).display());
        }
        None => text += &format!("{} written (no axis varies: no map)\n", csv.display()),
    }
    Ok(text)
}
