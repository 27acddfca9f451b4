//! `master scaling`: run time and peak memory against the number of elements per cable, set-up
//! and stepping apart. Every measurement is a separate `master run` process, timed from here and
//! run under GNU time (`/usr/bin/time`) for its largest resident set: a run of one step gives
//! the set-up (process start, scene, FMUs, statics, modes, the first step), a full run minus it
//! the stepping. Medians over repeats. Writes scaling.csv and scaling.svg, prints a
//! Markdown table. Every run is checked (steps, caps, memory, what the method needs) before the
//! first one starts.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use feedcore::scene::ValidScene;
use plotters::prelude::*;
use studies::plot::{PALETTE, PlotError};
use studies::simulate::Run;

use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, named, positive};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene of the coupled runs (its cable count and pose); its elements per cable are replaced.
    #[arg(long, default_value = "scenes/lt50m_C.toml")]
    pub(crate) scene: PathBuf,
    /// Scene of the `cable` runs (the cable–cabin model alone).
    #[arg(long, default_value = "scenes/lt50m_C_cable_only.toml")]
    pub(crate) cable_scene: PathBuf,
    /// Elements per cable.
    #[arg(long, value_delimiter = ',', default_value = "20,40,80,160,320",
          value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub(crate) elements: Vec<u32>,
    /// Methods (as `master run --scheme`, default options).
    #[arg(long, value_parser = named::<SchemeName>(), value_delimiter = ',', default_value = "cable,monolithic,ijcsa")]
    pub(crate) schemes: Vec<SchemeName>,
    /// Simulated time of the full runs (s).
    #[arg(long, default_value_t = 100.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Runs per measurement (the median is kept).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub(crate) repeats: u32,
    /// Output directory for scaling.csv and scaling.svg.
    #[arg(long, default_value = "out/scaling")]
    pub(crate) out: PathBuf,
}

/// A directory removed with everything in it when dropped.
struct RemovedOnDrop(PathBuf);

impl Drop for RemovedOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Writes `scene` (a variant of the one read from `scene_file`) to `path` for a run in another
/// process, the FMU paths of its `[system]` made absolute; returns the scene as written.
fn write_case_scene(scene: &ValidScene, scene_file: &Path, path: &Path) -> anyhow::Result<ValidScene> {
    let mut s = scene.to_scene();
    if let Some(sys) = s.system.as_mut() {
        let base = scene_file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        for f in &mut sys.fmus {
            let p = Path::new(&f.path);
            if !p.is_absolute() {
                f.path = std::fs::canonicalize(base)?.join(p).display().to_string();
            }
        }
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, s.to_toml())?;
    Ok(s.validated(&path.display().to_string())?)
}

/// GNU time, which reports the peak resident memory of a process.
const GNU_TIME: &str = "/usr/bin/time";

/// One process: wall time (s), peak resident memory (MB) and CPU time (user + system, s; on a
/// busy machine closer to the program's own cost than the wall time).
fn measure(exe: &Path, args: &[String]) -> anyhow::Result<(f64, f64, f64)> {
    let start = std::time::Instant::now();
    let out = Command::new(GNU_TIME)
        .arg("-f")
        .arg("scaling: %M %U %S")
        .arg(exe)
        .args(args)
        .output()
        .with_context(|| format!("cannot run {GNU_TIME} (GNU time; Debian package `time`)"))?;
    let wall = start.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("`master {}` failed: {}", args.join(" "), err.trim());
    }
    let line = err.lines().rev().find_map(|l| l.strip_prefix("scaling: ")).context("no GNU time report")?;
    let v: Vec<f64> = line.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    match v.as_slice() {
        [kb, user, system] => Ok((wall, kb / 1024.0, user + system)),
        _ => bail!("cannot read GNU time's report `{line}`"),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// A measured row: scheme, elements, set-up s, set-up MB, stepping s, peak MB, set-up CPU s,
/// stepping CPU s.
type Row = (&'static str, u32, f64, f64, f64, f64, f64, f64);

/// One measurement: a scheme on the scene with `elements` per cable, its variant file.
struct Case {
    scheme: SchemeName,
    elements: u32,
    file: PathBuf,
    dt: f64,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    if !Path::new(GNU_TIME).is_file() {
        bail!("{GNU_TIME} not found: the peak memory comes from GNU time (Debian package `time`)");
    }
    let exe = std::env::current_exe().context("locating the master executable")?;
    let limits = caps().run;
    let options = studies::options::SchemeOptions::default();
    // every run is checked before the first one starts; each is a process of its own, which
    // reads its scene from a file of this command's, removed when it ends
    let case_scenes = RemovedOnDrop(std::env::temp_dir().join(format!("master-scaling-{}", std::process::id())));
    let mut inputs = Vec::new();
    let mut cases = Vec::new();
    for &scheme in &args.schemes {
        let file = if scheme == SchemeName::Cable { &args.cable_scene } else { &args.scene };
        let base = load_scene(file)?;
        inputs.extend(run_inputs(file, &base));
        let method = options.method(scheme)?;
        for &n in &args.elements {
            let s = base.edited(|s| s.cables.elements = n as usize)?;
            let path = case_scenes.0.join(format!("{}-{n}.toml", scheme.as_str()));
            let variant = write_case_scene(&s, file, &path)
                .with_context(|| format!("{}: writing the scene of a case", path.display()))?;
            let dt = variant.solver.dt_s;
            for t_end in [dt, args.t_end] {
                Run::prepare(&variant, &path, method.clone(), dt, t_end, &limits).with_context(|| {
                    format!("{} with {n} elements per cable, {} s", scheme.as_str(), studies::limits::num(t_end))
                })?;
            }
            cases.push(Case { scheme, elements: n, file: path, dt });
        }
    }
    let mut outputs = Outputs::new(inputs);
    let csv_id = outputs.declare("--out", &args.out.join("scaling.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("scaling.svg"), Some("svg"))?;
    outputs.open()?;

    // the children obey the caps this command was given
    let mut caps_args = vec!["--max-steps".to_string(), limits.max_steps.to_string()];
    if let Some(b) = limits.max_memory_bytes {
        caps_args.extend(["--max-memory-mb".to_string(), (b / 1_000_000).to_string()]);
    }
    let mut rows: Vec<Row> = Vec::new();
    for case in &cases {
        let run = |t_end: f64| -> Vec<String> {
            let v = case.file.display().to_string();
            let mut a: Vec<String> = ["run", "--scene", &v, "--scheme", case.scheme.as_str(), "--quiet", "--t-end"]
                .map(String::from)
                .to_vec();
            a.push(t_end.to_string());
            a.extend(caps_args.iter().cloned());
            a
        };
        let (mut setup, mut full) = (Vec::new(), Vec::new());
        for _ in 0..args.repeats {
            setup.push(measure(&exe, &run(case.dt))?);
            full.push(measure(&exe, &run(args.t_end))?);
        }
        let med = |v: &[(f64, f64, f64)], f: fn(&(f64, f64, f64)) -> f64| median(v.iter().map(f).collect());
        let (ts, ms, cs) = (med(&setup, |x| x.0), med(&setup, |x| x.1), med(&setup, |x| x.2));
        let (tf, mf, cf) = (med(&full, |x| x.0), med(&full, |x| x.1), med(&full, |x| x.2));
        let (name, n) = (case.scheme.as_str(), case.elements);
        eprintln!("{name}, {n} elements per cable: set-up {ts:.2} s ({ms:.0} MB), full {tf:.2} s ({mf:.0} MB)");
        rows.push((name, n, ts, ms, (tf - ts).max(0.0), mf, cs, (cf - cs).max(0.0)));
    }
    let mut text =
        String::from("scheme,elements_per_cable,setup_s,setup_mb,stepping_s,peak_mb,setup_cpu_s,stepping_cpu_s\n");
    for (s, n, ts, ms, st, mf, cs, cst) in &rows {
        text += &format!("{s},{n},{ts},{ms},{st},{mf},{cs},{cst}\n");
    }
    outputs.write(csv_id, |w| w.write_all(text.as_bytes()))?;
    let names: Vec<&str> = args.schemes.iter().map(|s| s.as_str()).collect();
    let svg = draw(&rows, &names).context("drawing the scaling plot")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    let (csv, svg) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "Median of {} runs each; stepping: {} s simulated (full run minus a one-step run).",
        args.repeats, args.t_end
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| method | elements per cable | set-up (s) | set-up CPU (s) | set-up memory (MB) | stepping (s) | stepping CPU (s) | peak memory (MB) |"
    )?;
    writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|")?;
    for (s, n, ts, ms, st, mf, cs, cst) in &rows {
        writeln!(out, "| {s} | {n} | {ts:.2} | {cs:.2} | {ms:.0} | {st:.2} | {cst:.2} | {mf:.0} |")?;
    }
    writeln!(out)?;
    writeln!(out, "{} and {} written", csv.display(), svg.display())?;
    Ok(())
}

/// Log–log: time (set-up dashed, stepping solid) and peak memory against elements per cable.
fn draw(rows: &[Row], schemes: &[&str]) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 450)).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled("Cost against mesh size (median wall time, whole process)", ("sans-serif", 18))?;
        let (left, right) = root.split_horizontally(550);
        let ns: Vec<f64> = rows.iter().map(|r| r.1 as f64).collect();
        let (n0, n1) = ns.iter().fold((f64::INFINITY, 0.0f64), |(a, b), n| (a.min(*n), b.max(*n)));
        let bounds = |v: Vec<f64>| {
            v.iter().filter(|x| **x > 0.0).fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)))
        };
        let (t0, t1) = bounds(rows.iter().flat_map(|r| [r.2, r.4]).collect());
        let mut c = ChartBuilder::on(&left)
            .caption("wall time (s): set-up dashed, stepping solid", ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d((n0 * 0.8..n1 * 1.25).log_scale(), (t0 * 0.7..t1 * 1.5).log_scale())?;
        c.configure_mesh().x_desc("elements per cable").y_desc("s").label_style(("sans-serif", 13)).draw()?;
        for (k, s) in schemes.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let pts =
                |f: fn(&Row) -> f64| rows.iter().filter(|r| r.0 == *s).map(|r| (r.1 as f64, f(r))).collect::<Vec<_>>();
            c.draw_series(LineSeries::new(pts(|r| r.4), color.stroke_width(2)))?
                .label(*s)
                .legend(studies::plot::line_key(color.stroke_width(2)));
            c.draw_series(DashedLineSeries::new(pts(|r| r.2), 6, 4, color.stroke_width(2)))?;
            c.draw_series(pts(|r| r.4).into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
        }
        c.configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .label_font(("sans-serif", 13))
            .draw()?;
        let (m0, m1) = bounds(rows.iter().map(|r| r.5).collect());
        let mut c = ChartBuilder::on(&right)
            .caption("peak memory (MB)", ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d((n0 * 0.8..n1 * 1.25).log_scale(), (m0 * 0.7..m1 * 1.5).log_scale())?;
        c.configure_mesh().x_desc("elements per cable").y_desc("MB").label_style(("sans-serif", 13)).draw()?;
        for (k, s) in schemes.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let pts: Vec<(f64, f64)> = rows.iter().filter(|r| r.0 == *s).map(|r| (r.1 as f64, r.5)).collect();
            c.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?;
            c.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
        }
        root.present()?;
    }
    Ok(svg)
}
