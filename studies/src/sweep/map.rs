//! Maps of a sweep (SVG, plotters): the tension margin — the smallest cable tension, how far
//! the nearest cable is from going slack — and the first natural frequency, over the first two
//! axes that vary (the others held at their first value); grey where the pose cannot be held
//! (or only on a deep-sag branch, see [`super::DEEP_SAG`]).
//! With one varying axis the two quantities are drawn as lines against it.

use std::path::Path;

use plotters::prelude::*;

use super::table::Table;
use super::{Axis, Grid, SweepError};

/// One quantity on the map.
struct Layer {
    title: &'static str,
    unit: &'static str,
    column: &'static str,
    scale: f64,
}

const LAYERS: [Layer; 2] = [
    Layer { title: "tension margin: smallest cable tension", unit: "kN", column: "min_tension_n", scale: 1e-3 },
    Layer { title: "first natural frequency", unit: "Hz", column: "f1_hz", scale: 1.0 },
];

fn plot_err(path: &Path, e: impl std::fmt::Display) -> SweepError {
    SweepError::Table { file: path.display().to_string(), reason: format!("cannot draw the map: {e}") }
}

/// A point of the plotted slice: its coordinates on the varying axes and its cells.
struct Sample<'a> {
    coords: Vec<f64>,
    row: &'a [String],
}

/// Whether a sweep over `grid` has a map: some axis varies.
pub fn has_map(grid: &Grid) -> bool {
    grid.axes.iter().any(|a| a.values.len() > 1)
}

/// The maps of `table` (a whole sweep) as SVG; `path`: where they go (for messages). `None`
/// when no axis varies.
pub fn draw(table: &Table, path: &Path) -> Result<Option<String>, SweepError> {
    let grid_spec = table.get("grid").unwrap_or_default();
    let grid = Grid::parse(&grid_spec.split(' ').filter(|s| !s.is_empty()).map(String::from).collect::<Vec<_>>())?;
    let varying: Vec<usize> = (0..grid.axes.len()).filter(|&k| grid.axes[k].values.len() > 1).collect();
    if varying.is_empty() {
        return Ok(None);
    }
    let shown: Vec<usize> = varying.iter().take(2).copied().collect();
    let col = |name: &str| table.column(name);
    let axis_cols: Vec<usize> =
        grid.axes.iter().map(|a| col(a.axis.column()).expect("the grid's axes are columns")).collect();
    let feasible_col = col("feasible").ok_or_else(|| plot_err(path, "no `feasible` column"))?;
    // the slice: every axis not shown at its first value
    let samples: Vec<Sample> = table
        .rows
        .values()
        .filter(|row| {
            (0..grid.axes.len())
                .filter(|k| !shown.contains(k))
                .all(|k| row[axis_cols[k]].parse::<f64>().ok() == Some(grid.axes[k].values[0]))
        })
        .map(|row| Sample {
            coords: shown.iter().map(|&k| row[axis_cols[k]].parse().unwrap_or(f64::NAN)).collect(),
            row,
        })
        .collect();
    let held: Vec<String> = (0..grid.axes.len())
        .filter(|k| !shown.contains(k) && grid.axes[*k].values.len() > 1)
        .map(|k| format!("{} = {}", grid.axes[k].axis.name(), grid.axes[k].values[0]))
        .collect();
    let title = format!(
        "{}: sweep over {}{}",
        table.get("scene_name").unwrap_or("scene"),
        shown.iter().map(|&k| grid.axes[k].axis.name()).collect::<Vec<_>>().join(" × "),
        if held.is_empty() { String::new() } else { format!(" ({})", held.join(", ")) }
    );
    let layers: Vec<(&Layer, usize)> = LAYERS.iter().filter_map(|l| col(l.column).map(|c| (l, c))).collect();
    let value = |s: &Sample, c: usize, l: &Layer| -> Option<f64> {
        if s.row[feasible_col] != "true" {
            return None;
        }
        s.row[c].parse::<f64>().ok().filter(|v| v.is_finite()).map(|v| v * l.scale)
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (560 * layers.len().max(1) as u32, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
        let root = root.titled(&title, ("sans-serif", 18)).map_err(|e| plot_err(path, e))?;
        let panels = root.split_evenly((1, layers.len().max(1)));
        for ((layer, c), area) in layers.iter().zip(panels.iter()) {
            let values: Vec<Option<f64>> = samples.iter().map(|s| value(s, *c, layer)).collect();
            let (lo, hi) =
                values.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
            let caption = format!("{} ({})", layer.title, layer.unit);
            if shown.len() == 2 {
                heat_map(area, &grid, &shown, &samples, &values, (lo, hi), &caption).map_err(|e| plot_err(path, e))?;
            } else {
                line(area, grid.axes[shown[0]].axis, &samples, &values, &caption, layer.unit)
                    .map_err(|e| plot_err(path, e))?;
            }
        }
        root.present().map_err(|e| plot_err(path, e))?;
    }
    Ok(Some(svg))
}

/// Cell edges around sorted values: midpoints, and half a spacing beyond the ends.
fn edges(values: &[f64]) -> Vec<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let half = |a: f64, b: f64| 0.5 * (a + b);
    let step0 = if v.len() > 1 { v[1] - v[0] } else { 1.0 };
    let step1 = if v.len() > 1 { v[v.len() - 1] - v[v.len() - 2] } else { 1.0 };
    let mut e = vec![v[0] - 0.5 * step0];
    e.extend(v.windows(2).map(|w| half(w[0], w[1])));
    e.push(v[v.len() - 1] + 0.5 * step1);
    e
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

fn heat_map(
    area: &Area,
    grid: &Grid,
    shown: &[usize],
    samples: &[Sample],
    values: &[Option<f64>],
    (lo, hi): (f64, f64),
    caption: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let (ax, ay) = (&grid.axes[shown[0]], &grid.axes[shown[1]]);
    let (ex, ey) = (edges(&ax.values), edges(&ay.values));
    let (map_area, bar_area) = area.split_horizontally(area.dim_in_pixel().0 - 90);
    let mut chart = ChartBuilder::on(&map_area)
        .caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(ex[0]..ex[ex.len() - 1], ey[0]..ey[ey.len() - 1])?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(ax.axis.label())
        .y_desc(ay.axis.label())
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    let cell = |v: f64, values: &[f64], e: &[f64]| {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let i = sorted.iter().position(|x| *x == v).unwrap_or(0);
        (e[i], e[i + 1])
    };
    let span = if hi > lo { (lo, hi) } else { (lo - 0.5, lo + 0.5) };
    chart.draw_series(samples.iter().zip(values).map(|(s, v)| {
        let (x0, x1) = cell(s.coords[0], &ax.values, &ex);
        let (y0, y1) = cell(s.coords[1], &ay.values, &ey);
        let color = match v {
            Some(v) => ViridisRGB.get_color_normalized(*v, span.0, span.1),
            None => RGBColor(200, 200, 200),
        };
        Rectangle::new([(x0, y0), (x1, y1)], color.filled())
    }))?;
    // colour bar
    if lo.is_finite() {
        let mut bar = ChartBuilder::on(&bar_area)
            .margin_top(40)
            .margin_bottom(48)
            .margin_right(8)
            .y_label_area_size(52)
            .build_cartesian_2d(0.0..1.0, span.0..span.1)?;
        bar.configure_mesh().disable_mesh().disable_x_axis().y_labels(6).label_style(("sans-serif", 13)).draw()?;
        let n = 64;
        bar.draw_series((0..n).map(|k| {
            let a = span.0 + (span.1 - span.0) * k as f64 / n as f64;
            let b = span.0 + (span.1 - span.0) * (k + 1) as f64 / n as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                ViridisRGB.get_color_normalized(0.5 * (a + b), span.0, span.1).filled(),
            )
        }))?;
    }
    Ok(())
}

fn line(
    area: &Area,
    axis: Axis,
    samples: &[Sample],
    values: &[Option<f64>],
    caption: &str,
    unit: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut pts: Vec<(f64, f64)> =
        samples.iter().zip(values).filter_map(|(s, v)| v.map(|v| (s.coords[0], v))).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let xs: Vec<f64> = samples.iter().map(|s| s.coords[0]).collect();
    let (x0, x1) = xs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(*x), b.max(*x)));
    let (y0, y1) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let pad = |a: f64, b: f64| if b > a { 0.05 * (b - a) } else { 0.5 * a.abs().max(1.0) };
    let (y0, y1) = if y0.is_finite() { (y0 - pad(y0, y1), y1 + pad(y0, y1)) } else { (0.0, 1.0) };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0 - pad(x0, x1)..x1 + pad(x0, x1), y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(axis.label())
        .y_desc(unit)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    chart.draw_series(LineSeries::new(pts.iter().copied(), BLUE.stroke_width(2)))?;
    chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, BLUE.filled())))?;
    Ok(())
}
