//! The master's figures as SVG, drawn with plotters:
//!
//! * [`time_history`]: cabin-centre displacement X, Y, Z in three stacked panels over time, one
//!   line per run (like the paper's Figs. 4–5); [`stacked`]: any time histories so (e.g. the
//!   outputs of a system, a panel per component);
//! * [`work_precision`]: wall time against error on log–log axes, one line with markers per
//!   scheme, and a dashed reference line (e.g. 1 % of the peak);
//! * [`stability_map`]: one panel per scheme, cells over the macro step (x) and a mass factor
//!   (y), both logarithmic, coloured by category (stable, unstable, …) and annotated.
//!
//! Lines with more points than the plot has pixel columns are decimated per column, keeping
//! each column's first, last, lowest and highest point (see `decimate_columns`): a 10⁴-step run
//! stays small on disk and still shows every peak. Non-finite points leave a gap.

use plotters::coord::Shift;
use plotters::prelude::*;

/// Colours of the series, in order: Okabe & Ito's set, which stays distinct under the common
/// forms of colour blindness (yellow left out: it vanishes on white).
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
];

/// Cell colours of the stability map's categories, in this order:
/// stable (sky blue), unstable (vermillion), not converged (orange), infeasible (light grey).
pub const CATEGORY_COLORS: [RGBColor; 4] =
    [RGBColor(86, 180, 233), RGBColor(213, 94, 0), RGBColor(230, 159, 0), RGBColor(215, 215, 215)];

const FONT: &str = "sans-serif";

/// A figure that could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("drawing the figure: {0}")]
    Draw(String),
    #[error("{0}")]
    Data(String),
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        PlotError::Draw(e.to_string())
    }
}

/// The points of a line thinned to what `columns` pixel columns over `[x0, x1]` can show: per
/// column the first, lowest, highest and last point, in their original order. Returns the
/// line's finite stretches (a non-finite point ends one).
fn decimate_columns(x: &[f64], y: &[f64], (x0, x1): (f64, f64), columns: usize) -> Vec<Vec<(f64, f64)>> {
    let columns = columns.max(1);
    let width = x1 - x0;
    let column = |v: f64| {
        if width > 0.0 {
            (((v - x0) / width * columns as f64).floor().clamp(0.0, columns as f64 - 1.0)) as i64
        } else {
            0
        }
    };
    let mut segments = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    // indices into `current` of the open column's first, lowest, highest, last point
    let mut open: Option<(i64, [(f64, f64); 4])> = None;
    let flush = |open: &mut Option<(i64, [(f64, f64); 4])>, out: &mut Vec<(f64, f64)>| {
        if let Some((_, pts)) = open.take() {
            let [first, low, high, last] = pts;
            let mut keep = [first, low, high, last];
            keep.sort_by(|a, b| a.0.total_cmp(&b.0));
            for p in keep {
                if out.last() != Some(&p) {
                    out.push(p);
                }
            }
        }
    };
    for (&xi, &yi) in x.iter().zip(y) {
        if !(xi.is_finite() && yi.is_finite()) {
            flush(&mut open, &mut current);
            if !current.is_empty() {
                segments.push(std::mem::take(&mut current));
            }
            continue;
        }
        let c = column(xi);
        let p = (xi, yi);
        match &mut open {
            Some((oc, pts)) if *oc == c => {
                if yi < pts[1].1 {
                    pts[1] = p;
                }
                if yi > pts[2].1 {
                    pts[2] = p;
                }
                pts[3] = p;
            }
            _ => {
                flush(&mut open, &mut current);
                open = Some((c, [p; 4]));
            }
        }
    }
    flush(&mut open, &mut current);
    if !current.is_empty() {
        segments.push(current);
    }
    segments
}

/// Range of finite values with 4 % padding each side; constant data get ±10 % (±1 around 0),
/// no data [0, 1].
fn padded_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) =
        values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()) {
        let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        return (lo - d, hi + d);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Whole decades around the positive finite values (at least one decade), for a log axis.
fn decade_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (0.1, 1.0);
    }
    let (a, b) = (lo.log10().floor(), hi.log10().ceil());
    let b = if b > a { b } else { a + 1.0 };
    // a hair wider, so that the end decades get their ticks despite round-off
    (10f64.powf(a) * (1.0 - 1e-9), 10f64.powf(b) * (1.0 + 1e-9))
}

fn draw_error<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    e.into()
}

/// A legend's key for a line: a short stroke in the line's style.
pub fn line_key(style: ShapeStyle) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style)
}

/// Line `i` of a figure: a thin stroke in the `i`-th colour of [`PALETTE`], keyed `name` in the
/// legend with a thicker one (how the reproduction's figures draw their runs).
pub fn palette_line<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    i: usize,
    points: Vec<(X::ValueType, Y::ValueType)>,
    name: &str,
) -> Result<(), PlotError>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged,
    Y: Ranged,
    X::ValueType: Clone + 'static,
    Y::ValueType: Clone + 'static,
{
    let color = PALETTE[i % PALETTE.len()];
    chart
        .draw_series(LineSeries::new(points, color.stroke_width(1)))
        .map_err(draw_error)?
        .label(name)
        .legend(line_key(color.stroke_width(2)));
    Ok(())
}

/// The legend of a chart as every figure here draws it: upper right, on a translucent white box
/// with a grey frame, labels at `font_size`.
pub fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    font_size: u32,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, font_size))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .draw()
        .map_err(draw_error)
}

/// One run's displacement history: its name, the sample times (s) and the displacement (mm).
pub struct History<'a> {
    pub name: &'a str,
    pub t: &'a [f64],
    pub disp_mm: &'a [[f64; 3]],
}

/// The cabin-centre displacement X, Y, Z as three stacked panels sharing the time axis.
pub fn time_history(title: &str, runs: &[History<'_>]) -> Result<String, PlotError> {
    let panels: Vec<Panel> = ["X", "Y", "Z"]
        .iter()
        .enumerate()
        .map(|(k, axis)| Panel {
            y_label: format!("{axis} displacement (mm)"),
            // one legend, in the top panel
            legend: k == 0,
            lines: runs
                .iter()
                .map(|r| Line { name: r.name, t: r.t, y: r.disp_mm.iter().map(|d| d[k]).collect() })
                .collect(),
        })
        .collect();
    stacked(title, &panels, 260)
}

/// One time history of a panel.
pub struct Line<'a> {
    pub name: &'a str,
    pub t: &'a [f64],
    pub y: Vec<f64>,
}

/// One of the stacked panels: its lines, the label of its value axis, whether it shows a legend.
pub struct Panel<'a> {
    pub y_label: String,
    pub legend: bool,
    pub lines: Vec<Line<'a>>,
}

/// Any time histories as stacked panels sharing the time axis (e.g. every output of each
/// component of a system, a panel per component), `panel_height` pixels each.
pub fn stacked(title: &str, panels: &[Panel<'_>], panel_height: u32) -> Result<String, PlotError> {
    for line in panels.iter().flat_map(|p| &p.lines) {
        if line.t.len() != line.y.len() {
            return Err(PlotError::Data(format!(
                "line `{}`: {} times but {} values",
                line.name,
                line.t.len(),
                line.y.len()
            )));
        }
    }
    let n = panels.len().max(1);
    let (w, h) = (900u32, panel_height.saturating_mul(n as u32));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let root = root.titled(title, (FONT, 20)).map_err(draw_error)?;
        // time runs edge to edge: from the first to the last sample
        let (t0, t1) = panels
            .iter()
            .flat_map(|p| &p.lines)
            .flat_map(|l| l.t.iter().copied().filter(|v| v.is_finite()))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        let x_range = if t1 > t0 { (t0, t1) } else { padded_range([t0, t1].into_iter()) };
        let areas = root.split_evenly((n, 1));
        for (k, (area, panel)) in areas.iter().zip(panels).enumerate() {
            let last = k + 1 == panels.len();
            let y_range = padded_range(panel.lines.iter().flat_map(|l| l.y.iter().copied()));
            let mut chart = ChartBuilder::on(area)
                .margin_left(10)
                .margin_right(20)
                .margin_top(6)
                .x_label_area_size(if last { 40 } else { 24 })
                .y_label_area_size(70)
                .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
                .map_err(draw_error)?;
            let mut mesh = chart.configure_mesh();
            mesh.y_desc(panel.y_label.as_str())
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 15))
                .light_line_style(RGBColor(248, 248, 248))
                .bold_line_style(RGBColor(215, 215, 215));
            if last {
                mesh.x_desc("time (s)");
            }
            mesh.draw().map_err(draw_error)?;
            let columns = chart.plotting_area().dim_in_pixel().0 as usize;
            for (i, line) in panel.lines.iter().enumerate() {
                let color = PALETTE[i % PALETTE.len()];
                let segments = decimate_columns(line.t, &line.y, x_range, columns);
                let style = color.stroke_width(2);
                let mut labelled = !panel.legend;
                for seg in segments.into_iter().chain(std::iter::once(Vec::new())) {
                    if seg.is_empty() && labelled {
                        continue;
                    }
                    let drawn = chart.draw_series(LineSeries::new(seg, style)).map_err(draw_error)?;
                    if !labelled {
                        drawn.label(line.name).legend(line_key(style));
                        labelled = true;
                    }
                }
            }
            if panel.legend && !panel.lines.is_empty() {
                legend(&mut chart, 13)?;
            }
        }
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

/// One scheme of a work–precision plot: (wall time s, error) points in the order of the steps.
pub struct Precision<'a> {
    pub name: &'a str,
    /// The fixed steps' runs, joined by a line.
    pub points: Vec<(f64, f64)>,
    /// The adaptive step's runs (each tolerance), drawn apart as rings in the scheme's colour.
    pub adaptive: Vec<(f64, f64)>,
}

/// Radius of the ring an adaptive run is drawn as (the fixed steps' markers are 4–5).
const ADAPTIVE_RING: i32 = 8;

/// What a legend entry of the work–precision plot shows beside its name.
#[derive(Clone, Copy)]
enum Mark {
    /// A scheme's line and its marker (by its index).
    Scheme(usize),
    /// The adaptive step's ring.
    Ring,
    /// The reference's dashed line.
    Dashed,
}

/// Wall time against error on log–log axes; `reference`: a dashed horizontal line at this error
/// with its label. Points with a non-positive or non-finite coordinate cannot be shown on a log
/// axis and are refused.
pub fn work_precision(
    title: &str,
    x_label: &str,
    y_label: &str,
    schemes: &[Precision<'_>],
    reference: Option<(f64, &str)>,
) -> Result<String, PlotError> {
    for s in schemes {
        let all = || s.points.iter().chain(&s.adaptive);
        if let Some(p) = all().find(|p| !(p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())) {
            return Err(PlotError::Data(format!(
                "scheme `{}`: the point ({}, {}) cannot be shown on logarithmic axes (values must be positive)",
                s.name, p.0, p.1
            )));
        }
    }
    let xs = || schemes.iter().flat_map(|s| s.points.iter().chain(&s.adaptive).map(|p| p.0));
    let ys =
        || schemes.iter().flat_map(|s| s.points.iter().chain(&s.adaptive).map(|p| p.1)).chain(reference.map(|r| r.0));
    let (x0, x1) = decade_range(xs());
    let (y0, y1) = decade_range(ys());
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, (FONT, 18))
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(draw_error)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 15))
            .x_label_formatter(&|v| format!("{v:e}"))
            .y_label_formatter(&|v| format!("{v:e}"))
            .light_line_style(RGBColor(248, 248, 248))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()
            .map_err(draw_error)?;
        for (i, s) in schemes.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let style = color.stroke_width(2);
            chart.draw_series(LineSeries::new(s.points.iter().copied(), style)).map_err(draw_error)?;
            // a marker shape per scheme, so that they stay apart in black-and-white print too
            let points = s.points.iter().copied();
            match i % 5 {
                0 => chart.draw_series(points.map(|p| Circle::new(p, 4, color.filled()))),
                1 => chart.draw_series(points.map(|p| TriangleMarker::new(p, 5, color.filled()))),
                2 => chart.draw_series(points.map(|p| Cross::new(p, 4, color.stroke_width(2)))),
                3 => chart.draw_series(
                    points.map(|p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], color.filled())),
                ),
                _ => chart.draw_series(points.map(|p| Circle::new(p, 4, color.stroke_width(2)))),
            }
            .map_err(draw_error)?;
            // the adaptive runs: rings larger than any fixed-step marker
            chart
                .draw_series(s.adaptive.iter().map(|&p| Circle::new(p, ADAPTIVE_RING, color.stroke_width(2))))
                .map_err(draw_error)?;
        }
        let grey = RGBColor(90, 90, 90);
        if let Some((y, _)) = reference {
            chart
                .draw_series(DashedLineSeries::new(vec![(x0, y), (x1, y)], 8, 5, grey.stroke_width(1)))
                .map_err(draw_error)?;
        }
        // the legend, top right inside the plot: a line and the scheme's marker per entry
        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let mut entries: Vec<(String, RGBColor, Mark)> = schemes
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let name = if s.points.is_empty() { format!("{} (no result)", s.name) } else { s.name.to_string() };
                (name, PALETTE[i % PALETTE.len()], Mark::Scheme(i))
            })
            .collect();
        if schemes.iter().any(|s| !s.adaptive.is_empty()) {
            entries.push(("adaptive step (its scheme's colour)".into(), grey, Mark::Ring));
        }
        if let Some((_, label)) = reference {
            entries.push((label.to_string(), grey, Mark::Dashed));
        }
        let width = 60 + 8 * entries.iter().map(|e| e.0.chars().count()).max().unwrap_or(0) as i32;
        let (left, top) = (xr.end - width - 10, yr.start + 10);
        let frame = [(left, top), (xr.end - 10, top + 10 + 20 * entries.len() as i32)];
        root.draw(&Rectangle::new(frame, WHITE.mix(0.9).filled())).map_err(draw_error)?;
        root.draw(&Rectangle::new(frame, RGBColor(160, 160, 160).stroke_width(1))).map_err(draw_error)?;
        for (k, (name, color, mark)) in entries.iter().enumerate() {
            let y = top + 15 + 20 * k as i32;
            let (a, b) = ((left + 8, y), (left + 36, y));
            match mark {
                Mark::Scheme(_) => root.draw(&PathElement::new(vec![a, b], color.stroke_width(2))),
                Mark::Dashed => root
                    .draw(&PathElement::new(vec![a, (left + 16, y)], color.stroke_width(1)))
                    .and_then(|_| root.draw(&PathElement::new(vec![(left + 22, y), b], color.stroke_width(1)))),
                Mark::Ring => Ok(()),
            }
            .map_err(draw_error)?;
            let c = (left + 22, y);
            match mark {
                Mark::Scheme(i) => match i % 5 {
                    0 => root.draw(&Circle::new(c, 4, color.filled())),
                    1 => root.draw(&TriangleMarker::new(c, 5, color.filled())),
                    2 => root.draw(&Cross::new(c, 4, color.stroke_width(2))),
                    3 => root.draw(&Rectangle::new([(c.0 - 4, c.1 - 4), (c.0 + 4, c.1 + 4)], color.filled())),
                    _ => root.draw(&Circle::new(c, 4, color.stroke_width(2))),
                },
                Mark::Ring => root.draw(&Circle::new(c, ADAPTIVE_RING, color.stroke_width(2))),
                Mark::Dashed => Ok(()),
            }
            .map_err(draw_error)?;
            let font = TextStyle::from((FONT, 13).into_font()).pos(plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Left,
                plotters::style::text_anchor::VPos::Center,
            ));
            root.draw(&Text::new(name.clone(), (left + 44, y), font)).map_err(draw_error)?;
        }
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

/// One cell of a stability map: column `ix` (x centre), row `iy` (y centre), its category and
/// a short text (e.g. iterations per step; empty for none).
pub struct Cell {
    pub ix: usize,
    pub iy: usize,
    pub category: usize,
    pub text: String,
}

/// One panel of a stability map.
pub struct MapPanel<'a> {
    pub title: &'a str,
    pub cells: Vec<Cell>,
}

/// Cell edges around increasing positive centres, in log10: halfway between neighbours, the
/// outer cells as wide as their neighbours (one decade for a single centre).
fn log_edges(centres: &[f64]) -> Vec<f64> {
    let l: Vec<f64> = centres.iter().map(|c| c.log10()).collect();
    if l.len() == 1 {
        return vec![l[0] - 0.5, l[0] + 0.5];
    }
    let mut e = vec![l[0] - 0.5 * (l[1] - l[0])];
    e.extend(l.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    e.push(l[l.len() - 1] + 0.5 * (l[l.len() - 1] - l[l.len() - 2]));
    e
}

/// A linear axis (here over log10 values) with ticks exactly at given points: the cell centres
/// of a map.
#[derive(Clone)]
struct KeyedAxis {
    lo: f64,
    hi: f64,
    keys: Vec<f64>,
}

impl plotters::coord::ranged1d::Ranged for KeyedAxis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (v - self.lo) / (self.hi - self.lo);
        limit.0 + (f * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        self.keys.clone()
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// A tick label for 10^v: the value in plain decimals.
fn decimal_label(v: f64) -> String {
    let x = 10f64.powf(v);
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// Panels (two per row) of categorical cells over `x` (e.g. the macro step) and `y` (e.g. the
/// mass factor), both logarithmic; a legend of the categories on the right.
pub fn stability_map(
    title: &str,
    x_label: &str,
    y_label: &str,
    x: &[f64],
    y: &[f64],
    categories: &[(&str, RGBColor)],
    panels: &[MapPanel<'_>],
) -> Result<String, PlotError> {
    for (what, c) in [("x", x), ("y", y)] {
        if c.is_empty() || c.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
            return Err(PlotError::Data(format!("stability map: the {what} centres must be positive and finite")));
        }
    }
    let sorted = |c: &[f64]| {
        let mut v = c.to_vec();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let (xs, ys) = (sorted(x), sorted(y));
    for p in panels {
        if let Some(c) = p.cells.iter().find(|c| c.ix >= x.len() || c.iy >= y.len() || c.category >= categories.len()) {
            return Err(PlotError::Data(format!(
                "stability map `{}`: cell ({}, {}) of category {} is outside the grid",
                p.title, c.ix, c.iy, c.category
            )));
        }
    }
    let rows = panels.len().div_ceil(2).max(1) as u32;
    let (w, h) = (1100u32, 330 * rows + 60);
    let legend_w = 170u32;
    let (xe, ye) = (log_edges(&xs), log_edges(&ys));
    let position = |sorted: &[f64], v: f64| sorted.iter().position(|s| *s == v).expect("a centre");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let root = root.titled(title, (FONT, 18)).map_err(draw_error)?;
        let (maps, legend) = root.split_horizontally(w - legend_w);
        draw_legend(&legend, categories)?;
        let areas = maps.split_evenly((rows as usize, 2));
        for (p, area) in panels.iter().zip(areas.iter()) {
            let x_keys: Vec<f64> = xs.iter().map(|v| v.log10()).collect();
            let y_keys: Vec<f64> = ys.iter().map(|v| v.log10()).collect();
            let mut chart = ChartBuilder::on(area)
                .caption(p.title, (FONT, 15))
                .margin(8)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(
                    KeyedAxis { lo: xe[0], hi: xe[xe.len() - 1], keys: x_keys },
                    KeyedAxis { lo: ye[0], hi: ye[ye.len() - 1], keys: y_keys },
                )
                .map_err(draw_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .label_style((FONT, 12))
                .axis_desc_style((FONT, 13))
                .x_label_formatter(&|v| decimal_label(*v))
                .y_label_formatter(&|v| decimal_label(*v))
                .draw()
                .map_err(draw_error)?;
            for c in &p.cells {
                let (i, j) = (position(&xs, x[c.ix]), position(&ys, y[c.iy]));
                let color = categories[c.category].1;
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(xe[i], ye[j]), (xe[i + 1], ye[j + 1])],
                        color.filled(),
                    )))
                    .map_err(draw_error)?;
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(xe[i], ye[j]), (xe[i + 1], ye[j + 1])],
                        WHITE.stroke_width(1),
                    )))
                    .map_err(draw_error)?;
                if !c.text.is_empty() {
                    let centre = (0.5 * (xe[i] + xe[i + 1]), 0.5 * (ye[j] + ye[j + 1]));
                    let text_color = contrasting_text(color);
                    let style = TextStyle::from((FONT, 12).into_font()).color(&text_color).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Center,
                        ),
                    );
                    chart.draw_series(std::iter::once(Text::new(c.text.clone(), centre, style))).map_err(draw_error)?;
                }
            }
        }
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

/// The categories as colour swatches with their names, top of `area`.
fn draw_legend(area: &DrawingArea<SVGBackend<'_>, Shift>, categories: &[(&str, RGBColor)]) -> Result<(), PlotError> {
    for (k, (name, color)) in categories.iter().enumerate() {
        let y = 40 + 26 * k as i32;
        area.draw(&Rectangle::new([(8, y), (28, y + 16)], color.filled())).map_err(draw_error)?;
        area.draw(&Rectangle::new([(8, y), (28, y + 16)], RGBColor(120, 120, 120).stroke_width(1)))
            .map_err(draw_error)?;
        area.draw(&Text::new(name.to_string(), (36, y + 2), (FONT, 13).into_font())).map_err(draw_error)?;
    }
    Ok(())
}

/// Black or white, whichever reads better on `c` (WCAG relative luminance; the two contrast
/// ratios are equal at 0.179).
fn contrasting_text(c: RGBColor) -> RGBColor {
    let lin = |v: u8| {
        let v = f64::from(v) / 255.0;
        if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
    };
    let l = 0.2126 * lin(c.0) + 0.7152 * lin(c.1) + 0.0722 * lin(c.2);
    if l > 0.179 { BLACK } else { WHITE }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_each_columns_extremes_and_ends() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|v| (v * 0.01).sin()).collect();
        y[12_345] = 50.0; // a spike inside one column
        y[77_777] = -40.0;
        let segs = decimate_columns(&x, &y, (0.0, (n - 1) as f64), 800);
        assert_eq!(segs.len(), 1);
        let s = &segs[0];
        assert!(s.len() <= 4 * 800, "{} points", s.len());
        assert_eq!(s[0], (0.0, y[0]));
        assert_eq!(*s.last().unwrap(), ((n - 1) as f64, y[n - 1]));
        assert!(s.contains(&(12_345.0, 50.0)) && s.contains(&(77_777.0, -40.0)));
        assert!(s.windows(2).all(|w| w[0].0 < w[1].0), "order kept");
    }

    #[test]
    fn decimation_breaks_lines_at_non_finite_points() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [0.0, 1.0, f64::NAN, 3.0, f64::INFINITY];
        let segs = decimate_columns(&x, &y, (0.0, 4.0), 1000);
        assert_eq!(segs, vec![vec![(0.0, 0.0), (1.0, 1.0)], vec![(3.0, 3.0)]]);
    }

    #[test]
    fn ranges_pad_the_data_and_cover_whole_decades() {
        assert_eq!(padded_range([0.0, 10.0].into_iter()), (-0.4, 10.4));
        assert_eq!(padded_range([2.0, 2.0].into_iter()), (1.8, 2.2));
        assert_eq!(padded_range([f64::NAN].into_iter()), (0.0, 1.0));
        let close = |(a, b): (f64, f64), (c, d): (f64, f64)| (a / c - 1.0).abs() < 1e-8 && (b / d - 1.0).abs() < 1e-8;
        assert!(close(decade_range([0.03, 2.0].into_iter()), (0.01, 10.0)));
        assert!(close(decade_range([1.0].into_iter()), (1.0, 10.0)));
        assert_eq!(contrasting_text(CATEGORY_COLORS[3]), BLACK);
        assert_eq!(contrasting_text(PALETTE[0]), WHITE);
    }
}
