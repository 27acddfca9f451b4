//! `master scaling`: run time and peak memory against the number of elements per cable, set-up
//! and stepping apart. Every measurement is a separate `master run` process, timed from here and
//! run under GNU time (`/usr/bin/time`) for its largest resident set: a run of one step gives
//! the set-up (process start, scene, FMUs, statics, modes, the first step), a full run minus it
//! the stepping. Medians over repeats. Writes scaling.csv and scaling.svg, prints a
//! Markdown table.

use std::path::{Path, PathBuf};
use std::process::Command;

use feedcore::scene::Scene;
use master::simulate::write_variant;
use plotters::prelude::*;

use super::CmdResult;

#[derive(clap::Args)]
pub struct Args {
    /// Scene of the coupled runs (its cable count and pose); its elements per cable are replaced.
    #[arg(long, default_value = "scenes/lt50m_C.toml")]
    pub scene: PathBuf,
    /// Scene of the `cable` runs (the cable–cabin model alone).
    #[arg(long, default_value = "scenes/lt50m_C_cable_only.toml")]
    pub cable_scene: PathBuf,
    /// Elements per cable.
    #[arg(long, value_delimiter = ',', default_value = "20,40,80,160,320")]
    pub elements: Vec<usize>,
    /// Methods (as `master run --scheme`).
    #[arg(long, value_delimiter = ',', default_value = "cable,monolithic,ijcsa")]
    pub schemes: Vec<String>,
    /// Simulated time of the full runs (s).
    #[arg(long, default_value_t = 100.0)]
    pub t_end: f64,
    /// Runs per measurement (the median is kept).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Output directory for scaling.csv and scaling.svg.
    #[arg(long, default_value = "out/scaling")]
    pub out: PathBuf,
}

/// One process: wall time (s), peak resident memory (MB) and CPU time (user + system, s; on a
/// busy machine closer to the program's own cost than the wall time).
fn measure(exe: &Path, args: &[String]) -> Result<(f64, f64, f64), String> {
    let start = std::time::Instant::now();
    let out = Command::new("/usr/bin/time")
        .arg("-f")
        .arg("scaling: %M %U %S")
        .arg(exe)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run /usr/bin/time (GNU time; Debian package `time`): {e}"))?;
    let wall = start.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("`master {}` failed: {}", args.join(" "), err.trim()));
    }
    let line = err.lines().rev().find_map(|l| l.strip_prefix("scaling: ")).ok_or("no GNU time report")?;
    let v: Vec<f64> = line.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    match v.as_slice() {
        [kb, user, system] => Ok((wall, kb / 1024.0, user + system)),
        _ => Err(format!("cannot read GNU time's report `{line}`")),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// A measured row: scheme, elements, set-up s, set-up MB, stepping s, peak MB, set-up CPU s,
/// stepping CPU s.
type Row = (String, usize, f64, f64, f64, f64, f64, f64);

pub fn run(args: &Args) -> CmdResult {
    if args.repeats == 0 || args.elements.is_empty() || !(args.t_end > 0.0) {
        return Err("need --repeats ≥ 1, some --elements and a positive --t-end".into());
    }
    let exe = std::env::current_exe()?;
    std::fs::create_dir_all(&args.out)?;
    let mut rows: Vec<Row> = Vec::new();
    for scheme in &args.schemes {
        let file = if scheme == "cable" { &args.cable_scene } else { &args.scene };
        let base = Scene::load(file)?;
        for &n in &args.elements {
            let mut s = base.clone();
            s.cables.elements = n;
            let (_, variant) = write_variant(&s, file, &format!("scaling-{scheme}-{n}"))?;
            let run = |t_end: f64| -> Vec<String> {
                let v = variant.display().to_string();
                ["run", "--scene", &v, "--scheme", scheme, "--quiet", "--t-end", &t_end.to_string()]
                    .map(String::from)
                    .to_vec()
            };
            let (mut setup, mut full) = (Vec::new(), Vec::new());
            for _ in 0..args.repeats {
                setup.push(measure(&exe, &run(s.solver.dt_s))?);
                full.push(measure(&exe, &run(args.t_end))?);
            }
            let med = |v: &[(f64, f64, f64)], f: fn(&(f64, f64, f64)) -> f64| median(v.iter().map(f).collect());
            let (ts, ms, cs) = (med(&setup, |x| x.0), med(&setup, |x| x.1), med(&setup, |x| x.2));
            let (tf, mf, cf) = (med(&full, |x| x.0), med(&full, |x| x.1), med(&full, |x| x.2));
            eprintln!("{scheme}, {n} elements per cable: set-up {ts:.2} s ({ms:.0} MB), full {tf:.2} s ({mf:.0} MB)");
            rows.push((scheme.clone(), n, ts, ms, (tf - ts).max(0.0), mf, cs, (cf - cs).max(0.0)));
        }
    }
    let csv = args.out.join("scaling.csv");
    let mut text =
        String::from("scheme,elements_per_cable,setup_s,setup_mb,stepping_s,peak_mb,setup_cpu_s,stepping_cpu_s\n");
    for (s, n, ts, ms, st, mf, cs, cst) in &rows {
        text += &format!("{s},{n},{ts},{ms},{st},{mf},{cs},{cst}\n");
    }
    std::fs::write(&csv, text)?;
    println!(
        "Median of {} runs each; stepping: {} s simulated (full run minus a one-step run).",
        args.repeats, args.t_end
    );
    println!();
    println!(
        "| method | elements per cable | set-up (s) | set-up CPU (s) | set-up memory (MB) | stepping (s) | stepping CPU (s) | peak memory (MB) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (s, n, ts, ms, st, mf, cs, cst) in &rows {
        println!("| {s} | {n} | {ts:.2} | {cs:.2} | {ms:.0} | {st:.2} | {cst:.2} | {mf:.0} |");
    }
    let svg = args.out.join("scaling.svg");
    draw(&rows, &args.schemes, &svg).map_err(|e| format!("{}: cannot draw: {e}", svg.display()))?;
    println!();
    println!("{} and {} written", csv.display(), svg.display());
    Ok(())
}

/// Log–log: time (set-up dashed, stepping solid) and peak memory against elements per cable.
fn draw(rows: &[Row], schemes: &[String], path: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1100, 450)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled("Cost against mesh size (median wall time, whole process)", ("sans-serif", 18))?;
    let (left, right) = root.split_horizontally(550);
    let ns: Vec<f64> = rows.iter().map(|r| r.1 as f64).collect();
    let (n0, n1) = ns.iter().fold((f64::INFINITY, 0.0f64), |(a, b), n| (a.min(*n), b.max(*n)));
    let bounds =
        |v: Vec<f64>| v.iter().filter(|x| **x > 0.0).fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(*x), b.max(*x)));
    let palette = [RGBColor(0, 114, 178), RGBColor(213, 94, 0), RGBColor(0, 158, 115), RGBColor(204, 121, 167)];
    let (t0, t1) = bounds(rows.iter().flat_map(|r| [r.2, r.4]).collect());
    let mut c = ChartBuilder::on(&left)
        .caption("wall time (s): set-up dashed, stepping solid", ("sans-serif", 15))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d((n0 * 0.8..n1 * 1.25).log_scale(), (t0 * 0.7..t1 * 1.5).log_scale())?;
    c.configure_mesh().x_desc("elements per cable").y_desc("s").label_style(("sans-serif", 13)).draw()?;
    for (k, s) in schemes.iter().enumerate() {
        let color = palette[k % palette.len()];
        let pts =
            |f: fn(&Row) -> f64| rows.iter().filter(|r| &r.0 == s).map(|r| (r.1 as f64, f(r))).collect::<Vec<_>>();
        c.draw_series(LineSeries::new(pts(|r| r.4), color.stroke_width(2)))?
            .label(s.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
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
        let color = palette[k % palette.len()];
        let pts: Vec<(f64, f64)> = rows.iter().filter(|r| &r.0 == s).map(|r| (r.1 as f64, r.5)).collect();
        c.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?;
        c.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
    }
    root.present()?;
    Ok(())
}
