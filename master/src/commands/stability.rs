//! `master stability`: where each coupling scheme is stable, over the mass ratio (the Stewart
//! platform's masses and inertias scaled) and the macro step; iterations per step where it
//! iterates. A table per scheme, `stability.csv` and a plot of maps.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

use feedcore::scene::Scene;
use master::plot::{Color, Figure, Grid, Legend, Scale};
use master::simulate::{simulate, write_variant};
use master::table::Table;

use super::CmdResult;
use super::run::create_parent;
use super::scheme_args::SchemeOptions;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub scene: PathBuf,
    /// Comma-separated coupling schemes.
    #[arg(long, default_value = "jacobi,gauss-seidel,gauss-seidel-reversed,iterative,ijcsa")]
    pub schemes: String,
    /// Factors on every mass and inertia of the Stewart platform (1: the scene's platform).
    #[arg(long, default_value = "0.1,0.2,0.5,1,2,5,10")]
    pub ratios: String,
    /// Comma-separated macro steps (s).
    #[arg(long, default_value = "0.04,0.02,0.01,0.005,0.0025")]
    pub dts: String,
    /// Simulated time of every run (s).
    #[arg(long, default_value_t = 10.0)]
    pub t_end: f64,
    /// Directory for stability.csv and stability.svg.
    #[arg(long, default_value = "out/stability")]
    pub out: PathBuf,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Worker threads: the runs are independent (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    #[command(flatten)]
    pub options: SchemeOptions,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Stable,
    Unstable,
    NotConverged,
    /// The scaled platform cannot be held at the pose at all (a cable would have to push).
    Infeasible,
}

fn list(text: &str, what: &str) -> Result<Vec<f64>, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{what}: {e}"))?;
    if v.is_empty() || v.iter().any(|x| !(*x > 0.0)) {
        return Err(format!("{what}: positive numbers are needed"));
    }
    Ok(v)
}

pub fn run(args: &Args) -> CmdResult {
    let scene = Scene::load(&args.scene)?;
    let ratios = list(&args.ratios, "--ratios")?;
    let dts = list(&args.dts, "--dts")?;
    let quiet = args.quiet || !std::io::stderr().is_terminal();
    let schemes: Vec<&str> = args.schemes.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
    let mut cases = Vec::new(); // (scheme, ratio, dt, method, variant scene, its file)
    for (ir, &f) in ratios.iter().enumerate() {
        let (variant, file) = write_variant(
            &master::sweep::with_platform_mass_factor(&scene, f),
            &args.scene,
            &format!("stability-{}-{ir}", scene.name),
        )?;
        for name in &schemes {
            let method = args.options.method(name)?;
            for &dt in &dts {
                cases.push((name.to_string(), f, dt, method, variant.clone(), file.clone()));
            }
        }
    }
    // every case on its own core; progress bars only when one case runs at a time
    let jobs = args.jobs.map(usize::from);
    let quiet = quiet || master::parallel::threads(jobs) > 1;
    let rows = master::parallel::map_in_order(&cases, jobs, |_, (name, f, dt, method, variant, file)| {
        let (f, dt) = (*f, *dt);
        eprintln!("{name}, mass ×{f}, h = {dt} s …");
        let (verdict, iterations, note) = match simulate(variant, file, *method, dt, args.t_end, quiet) {
            Ok(t) => {
                // a run that ends but keeps growing is not stable either
                let n = t.disp_mm.len();
                let peak =
                    |r: std::ops::Range<usize>| t.disp_mm[r].iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                let (early, late) = (peak(0..n / 3), peak(2 * n / 3..n));
                if late > 10.0 * early.max(1e-9) {
                    (Verdict::Unstable, t.mean_iterations(), format!("growing: peak {early:.2e} → {late:.2e} mm"))
                } else {
                    (Verdict::Stable, t.mean_iterations(), String::new())
                }
            }
            Err(e) => {
                let e = e.to_string();
                let v = if e.contains("infeasible") {
                    Verdict::Infeasible
                } else if e.contains("did not converge in") && !e.contains("unstable") {
                    Verdict::NotConverged
                } else {
                    Verdict::Unstable
                };
                (v, f64::NAN, e)
            }
        };
        (name.clone(), f, dt, verdict, iterations, note)
    })?;
    std::fs::create_dir_all(&args.out)?;
    let csv_path = args.out.join("stability.csv");
    let mut csv = std::fs::File::create(&csv_path)?;
    writeln!(csv, "scheme,mass_factor,dt_s,verdict,mean_iterations,note")?;
    let label = |v: Verdict| match v {
        Verdict::Stable => "stable",
        Verdict::Unstable => "unstable",
        Verdict::NotConverged => "not converged",
        Verdict::Infeasible => "infeasible",
    };
    for (s, f, dt, v, it, note) in &rows {
        writeln!(
            csv,
            "{s},{f},{dt},{},{},\"{}\"",
            label(*v),
            if it.is_nan() { String::new() } else { format!("{it:.3}") },
            note.replace('"', "'")
        )?;
    }
    let svg = args.out.join("stability.svg");
    create_parent(&svg)?;
    let mut fig = Figure::new(1100, 330 * schemes.len().div_ceil(2) as u32 + 60);
    fig.title(&format!(
        "{}: stability over the platform's mass factor and the macro step ({} s runs)",
        scene.name, args.t_end
    ))
    .columns(2);
    println!(
        "{}: stable (S), unstable (U), not converged (N); iterations per step where the scheme iterates",
        scene.name
    );
    for (k, name) in schemes.iter().enumerate() {
        let mut grid = Grid::new(&dts, &ratios)
            .category("stable", Color::SKY_BLUE)
            .category("unstable", Color::VERMILLION)
            .category("not converged", Color::ORANGE)
            .category("infeasible pose", Color::LIGHT_GREY);
        let mut table =
            Table::new(std::iter::once("mass factor".to_string()).chain(dts.iter().map(|d| format!("h = {d}"))));
        for (iy, &f) in ratios.iter().enumerate() {
            let mut cells = vec![format!("×{f}")];
            for (ix, &dt) in dts.iter().enumerate() {
                let r = rows.iter().find(|r| &r.0 == name && r.1 == f && r.2 == dt).expect("every cell was run");
                let iterating = matches!(*name, "iterative" | "ijcsa");
                let text = if r.3 == Verdict::Stable && iterating { format!("{:.1}", r.4) } else { String::new() };
                grid.set(ix, iy, r.3 as usize, &text);
                cells.push(match r.3 {
                    Verdict::Stable if iterating => format!("S {:.1}", r.4),
                    Verdict::Stable => "S".into(),
                    Verdict::Unstable => "U".into(),
                    Verdict::NotConverged => "N".into(),
                    Verdict::Infeasible => "–".into(),
                });
            }
            table.row(cells);
        }
        fig.panel(|p| {
            p.title(name)
                .x_scale(Scale::Log10)
                .y_scale(Scale::Log10)
                .x_label("macro step h (s)")
                .y_label("platform mass factor")
                .legend(if k == 0 { Legend::Right } else { Legend::Hidden })
                .grid(grid)
        });
        println!();
        println!("{name}:");
        print!("{}", table.render());
    }
    fig.write_svg(&svg)?;
    println!();
    println!("{} and {} written", csv_path.display(), svg.display());
    Ok(())
}
