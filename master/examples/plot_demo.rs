//! Draws one figure of each kind the master produces, from synthetic data, to look at:
//!
//! ```text
//! cargo run -p master --example plot_demo [OUT_DIR]     # default OUT_DIR: /tmp
//! ```
//!
//! Writes `plot_demo_history.svg` (Figs. 4–5 style, three stacked panels sharing the time
//! axis), `plot_demo_compare.svg` (several schemes on one axis, error on a log axis),
//! `plot_demo_work_precision.svg` (log–log, one line with markers per scheme) and
//! `plot_demo_stability.svg` (stable/unstable map with iteration counts). The data are made-up
//! curves shaped like the real ones, not simulation results.

use std::f64::consts::TAU;
use std::path::PathBuf;

use master::plot::{Color, Dash, Figure, Grid, Legend, Scale, Series};

fn main() -> std::io::Result<()> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "/tmp".into()));

    // 1. Time history: 100 s at h = 0.01 s, a long-period response carrying a small fast
    //    vibration (what the paper describes at point B).
    let t: Vec<f64> = (0..=10_000).map(|i| i as f64 * 0.01).collect();
    let slow = |t: f64, phase: f64| 0.68 * (TAU * t / 20.0 + phase).sin();
    let fast = |t: f64, f: f64| 0.06 * (TAU * f * t).sin() * (0.6 + 0.4 * (TAU * t / 33.0).cos());
    let dx: Vec<f64> = t.iter().map(|&t| slow(t, 0.0) + fast(t, 1.37)).collect();
    let dy: Vec<f64> = t.iter().map(|&t| slow(t, 1.571) + fast(t, 1.52)).collect();
    let dz: Vec<f64> = t.iter().map(|&t| 0.004 * (TAU * t / 10.0).sin() + 0.001 * (TAU * 2.9 * t).sin()).collect();
    let mut fig = Figure::new(900, 640);
    fig.title("Cabin-centre displacement at B (synthetic data)").share_x(true);
    for (axis, d) in [("X", &dx), ("Y", &dy), ("Z", &dz)] {
        fig.panel(|p| {
            p.y_label(&format!("Δ{} [mm]", axis.to_lowercase()))
                .x_label("t [s]")
                .x_range(0.0, 100.0)
                .legend(Legend::Hidden)
                .add(Series::line(axis, &t, d).width(1.0))
        });
    }
    let history = dir.join("plot_demo_history.svg");
    fig.write_svg(&history)?;

    // 2. Several schemes on one axis, and their difference from the reference on a log axis.
    let t20: Vec<f64> = t.iter().copied().take_while(|&t| t <= 20.0).collect();
    let reference: Vec<f64> = t20.iter().map(|&t| slow(t, 0.0) + fast(t, 1.37)).collect();
    let schemes: [(&str, f64, f64); 3] = [("ijcsa", 2e-4, 0.0), ("gauss-seidel", 6e-3, 0.02), ("jacobi", 2.5e-2, 0.05)];
    let mut fig = Figure::new(900, 560);
    fig.title("Schemes at h = 0.01 s against monolithic (synthetic data)").share_x(true);
    fig.panel(|p| {
        p.y_label("Δx [mm]").x_range(0.0, 20.0);
        p.add(Series::line("monolithic", &t20, &reference).color(Color::BLACK).width(2.0));
        for (k, &(name, amp, lag)) in schemes.iter().enumerate() {
            let y: Vec<f64> =
                t20.iter().map(|&t| slow(t - lag, 0.0) + (1.0 + amp * 20.0) * fast(t - lag, 1.37)).collect();
            p.add(Series::line(name, &t20, &y).dash([Dash::Dashed, Dash::DashDot, Dash::Dotted][k]));
        }
        p
    });
    fig.panel(|p| {
        p.y_label("|error| [mm]").x_label("t [s]").y_scale(Scale::Log10).legend(Legend::Hidden);
        // The monolithic line keeps the palette positions of the panel above.
        p.add(Series::line("", &[], &[]).color(Color::BLACK));
        for &(name, amp, lag) in &schemes {
            let y: Vec<f64> = t20
                .iter()
                .map(|&t| {
                    let s = slow(t - lag, 0.0) + (1.0 + amp * 20.0) * fast(t - lag, 1.37);
                    let e = (s - (slow(t, 0.0) + fast(t, 1.37))).abs();
                    if t == 0.0 { f64::NAN } else { e.max(amp * 1e-3) }
                })
                .collect();
            p.line(name, &t20, &y);
        }
        p
    });
    let compare = dir.join("plot_demo_compare.svg");
    fig.write_svg(&compare)?;

    // 3. Work–precision: error against wall time, log–log, one line with markers per scheme.
    let dts = [0.04, 0.02, 0.01, 0.005, 0.0025];
    let mut fig = Figure::new(760, 560);
    fig.panel(|p| {
        p.title("Work–precision at B (synthetic data)")
            .x_label("wall time [s]")
            .y_label("max |error| [mm]")
            .x_scale(Scale::Log10)
            .y_scale(Scale::Log10)
            .hline(0.0075, "1 % of peak");
        for (name, cost, err0, order) in [
            ("monolithic", 0.08, 3e-3, 2.0),
            ("ijcsa", 0.15, 4e-3, 2.0),
            ("gauss-seidel", 0.05, 8e-2, 1.0),
            ("jacobi", 0.045, 3e-1, 1.0),
        ] {
            let wall: Vec<f64> = dts.iter().map(|dt| cost * 0.01 / dt).collect();
            let err: Vec<f64> = dts.iter().map(|dt| err0 * (dt / 0.01f64).powf(order)).collect();
            p.add(Series::line(name, &wall, &err).auto_marker());
        }
        p
    });
    let work = dir.join("plot_demo_work_precision.svg");
    fig.write_svg(&work)?;

    // 4. Stability map: macro step × mass ratio, per scheme, with iteration counts.
    let ratios = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];
    let mut fig = Figure::new(1000, 720);
    fig.title("Stability over mass ratio and macro step (synthetic data)").columns(2);
    for (k, scheme) in ["jacobi", "gauss-seidel", "iterative", "ijcsa"].iter().enumerate() {
        let mut grid = Grid::new(&dts, &ratios)
            .category("stable", Color::SKY_BLUE)
            .category("unstable", Color::VERMILLION)
            .category("not converged", Color::ORANGE);
        for (ix, dt) in dts.iter().enumerate() {
            for (iy, ratio) in ratios.iter().enumerate() {
                let load = ratio * dt / 0.01 / (1.0 + 3.0 * k as f64);
                let (cat, text) = match k {
                    0 | 1 => (usize::from(load > 1.5), String::new()),
                    _ if load > 4.0 => (2, String::new()),
                    _ => (0, format!("{:.1}", 1.5 + load.sqrt() * if k == 2 { 3.0 } else { 1.0 })),
                };
                grid.set(ix, iy, cat, &text);
            }
        }
        fig.panel(|p| {
            p.title(scheme)
                .x_scale(Scale::Log10)
                .y_scale(Scale::Log10)
                .x_label("macro step h [s]")
                .y_label("mass ratio")
                .legend(if k == 1 { Legend::Right } else { Legend::Hidden })
                .grid(grid)
        });
    }
    let stability = dir.join("plot_demo_stability.svg");
    fig.write_svg(&stability)?;

    for path in [history, compare, work, stability] {
        let bytes = std::fs::metadata(&path)?.len();
        println!("{} ({:.1} kB)", path.display(), bytes as f64 / 1024.0);
    }
    Ok(())
}
