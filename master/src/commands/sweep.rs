//! `master sweep`: statics, first frequencies and (optionally) a short coupled run at every
//! point of a grid over the workspace and the parameters, on every core; `--shard i/n` runs one
//! of n disjoint parts (a cluster job array), `--merge` joins them. Writes `sweep.csv` and the
//! maps `sweep.svg` (tension margin and first frequency).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use feedcore::scene::Scene;
use master::parallel;
use master::sweep::table::{self, Table};
use master::sweep::{self, Grid, Placement, Request, Shard, Surface};
use master::table::Table as TextTable;

use super::CmdResult;
use super::run::create_parent;
use super::scheme_args::SchemeOptions;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML): the base of every point.
    #[arg(long, required_unless_present = "merge")]
    pub scene: Option<PathBuf>,
    /// One axis of the grid (repeat for more): `name=start:stop:count` (both ends included) or
    /// `name=v1,v2,...`. Names: x, y, z (m, world position of the cabin centre point), mass
    /// (factor on every mass and inertia of the Stewart platform), dt (s, step of the coupled
    /// run). Points are all combinations, the first axis varying slowest.
    #[arg(long = "grid", value_name = "AXIS")]
    pub grid: Vec<String>,
    /// The cabin centre follows the lower half of the sphere `cx,cy,cz,r` (m): z from x and y
    /// (FAST's focal surface: 0,0,300,160).
    #[arg(long)]
    pub surface: Option<String>,
    /// With --surface: tilt the cabin towards the sphere's axis by this share of the point's
    /// angle from the axis (FAST's cables take 14° of 40°: 0.35). Default: the scene's orientation.
    #[arg(long, requires = "surface")]
    pub tilt_share: Option<f64>,
    /// Natural frequencies per point (0: none).
    #[arg(long, default_value_t = 3)]
    pub modes: usize,
    /// A short coupled run at every point with this scheme (e.g. monolithic, ijcsa); it reports
    /// the peak cabin displacement, iterations per step and run time.
    #[arg(long)]
    pub run: Option<String>,
    /// Simulated time of each coupled run (s).
    #[arg(long, default_value_t = 2.0)]
    pub t_end: f64,
    /// Run part i of n only (0 ≤ i < n; points i, i + n, ...) and write sweep.part-i-of-n.csv.
    #[arg(long, value_name = "i/n")]
    pub shard: Option<String>,
    /// Join shard files (or directories holding sweep.part-*.csv) into sweep.csv and sweep.svg.
    #[arg(long, num_args = 1.., value_name = "PART", conflicts_with_all = ["scene", "grid", "shard", "run"])]
    pub merge: Vec<PathBuf>,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    /// Output directory.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
    /// No progress lines.
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub options: SchemeOptions,
}

/// FNV-1a of the scene as parsed: parts of one sweep must share it.
fn fingerprint(scene: &Scene) -> String {
    let hash =
        scene.to_toml().bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3));
    format!("{hash:016x}")
}

pub fn run(args: &Args) -> CmdResult {
    std::fs::create_dir_all(&args.out)?;
    if !args.merge.is_empty() {
        return merge(args);
    }
    let scene_file = args.scene.as_ref().expect("clap requires --scene without --merge");
    let scene = Scene::load(scene_file)?;
    let grid = Grid::parse(&args.grid)?;
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?.unwrap_or(Shard::ALL);
    let surface = args.surface.as_deref().map(Surface::parse).transpose()?;
    if let Some(s) = args.tilt_share
        && !s.is_finite()
    {
        return Err(format!("--tilt-share {s}: must be a finite number").into());
    }
    if !(args.t_end > 0.0 && args.t_end.is_finite()) {
        return Err(format!("--t-end {}: must be positive", args.t_end).into());
    }
    let placement = Placement { surface, tilt_share: args.tilt_share };
    let method = args.run.as_deref().map(|s| args.options.method(s)).transpose()?;
    let request = Request { modes: args.modes, run: method.map(|m| (m, args.t_end)) };
    let jobs = args.jobs.map(usize::from);
    let points: Vec<usize> = (0..grid.len()).filter(|i| shard.contains(*i)).collect();
    let quiet = args.quiet || !std::io::stderr().is_terminal();
    eprintln!(
        "{}: {} of {} points (shard {shard}) on {} threads",
        scene.name,
        points.len(),
        grid.len(),
        parallel::threads(jobs)
    );
    let done = std::sync::atomic::AtomicUsize::new(0);
    let start = Instant::now();
    let rows = parallel::map_in_order(&points, jobs, |_, &index| {
        let values = grid.point(index);
        let outcome = sweep::evaluate(&scene, scene_file, &placement, &request, index, &values);
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if !quiet {
            eprintln!("[{k}/{}] point {index}: {}", points.len(), brief(&outcome));
        }
        (index, sweep::cells(index, &values, &request, &outcome))
    })?;
    let wall = start.elapsed().as_secs_f64();
    let run_text = match (&args.run, &request.run) {
        (Some(name), Some((_, t))) => format!("{name} for {t} s"),
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
    let t = Table { header, columns: sweep::columns(&grid, &request), rows: rows.into_iter().collect() };
    let csv = table::file_name(&args.out, shard);
    refuse_input(&csv, &[scene_file.as_path()])?;
    t.write(&csv)?;
    println!(
        "{}: {} points in {wall:.2} s on {} threads ({:.3} s per point)",
        scene.name,
        points.len(),
        parallel::threads(jobs),
        wall / points.len().max(1) as f64
    );
    if shard == Shard::ALL {
        finish(&t, &args.out)?;
    } else {
        println!("{} written; join the parts with `master sweep --merge {}`", csv.display(), args.out.display());
    }
    Ok(())
}

fn merge(args: &Args) -> CmdResult {
    let files = table::part_files(&args.merge)?;
    let parts: Vec<(PathBuf, Table)> =
        files.iter().map(|f| Table::read(f).map(|t| (f.clone(), t))).collect::<Result<_, _>>()?;
    let merged = table::merge(&parts)?;
    let csv = table::file_name(&args.out, Shard::ALL);
    refuse_input(&csv, &files.iter().map(PathBuf::as_path).collect::<Vec<_>>())?;
    merged.write(&csv)?;
    println!("{} parts joined: {} points", parts.len(), merged.rows.len());
    finish(&merged, &args.out)
}

/// Never write over an input.
fn refuse_input(out: &Path, inputs: &[&Path]) -> CmdResult {
    let same = |a: &Path, b: &Path| match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if let Some(i) = inputs.iter().find(|i| same(out, i)) {
        return Err(format!("{} is an input; choose another --out", i.display()).into());
    }
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

/// The summary and the maps of a whole sweep.
fn finish(t: &Table, out: &Path) -> CmdResult {
    let csv = table::file_name(out, Shard::ALL);
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
    println!("{} of {} points feasible", feasible.len(), t.rows.len());
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
        print!("{}", summary.render());
    }
    let svg = out.join("sweep.svg");
    create_parent(&svg)?;
    if master::sweep::map::draw(t, &svg)? {
        println!("{} and {} written", csv.display(), svg.display());
    } else {
        println!("{} written (no axis varies: no map)", csv.display());
    }
    Ok(())
}
