//! Layout and SVG output of a [`Figure`]: validate, resolve ranges, lay out panels, place ticks
//! and legends, write elements.
//!
//! Elements carry classes (`frame`, `line`, `markers`, `xtick`, `ytick`, `legend`, `cell`, …)
//! and series paths a `data-series` name, so that tests and other tools can read a figure back.

use std::fmt::Write;

use super::path::{Pt, Rect, clip_polyline, decimate_columns, length_inside};
use super::svg::{Esc, Num};
use super::ticks::{self, Label, Tick};
use super::{
    Axis, AxisSpec, Color, Dash, Figure, Grid, Legend, Marker, MarkerChoice, PALETTE, Panel, PlotError, Scale, Series,
    SeriesKind, TickChoice,
};

const FONT_FAMILY: &str = "DejaVu Sans, Helvetica, Arial, sans-serif";
const TICK_FONT: f64 = 12.0;
const LABEL_FONT: f64 = 13.0;
const TITLE_FONT: f64 = 14.0;
const FIG_TITLE_FONT: f64 = 16.0;
const LEGEND_FONT: f64 = 12.0;
const REF_FONT: f64 = 11.0;
const PAD: f64 = 10.0;
const TICK_LEN: f64 = 5.0;
const MINOR_TICK_LEN: f64 = 3.0;
/// Automatic ranges are widened by this fraction of the data span on each side.
const AUTO_PAD: f64 = 0.04;
/// Room right of the plot for the last x tick label.
const RIGHT_MARGIN: f64 = 24.0;
const LEGEND_ROW: f64 = 18.0;
const LEGEND_SWATCH: f64 = 24.0;
const MIN_PLOT_W: f64 = 60.0;
const MIN_PLOT_H: f64 = 40.0;

/// Axis coordinate of a data value: the value, or its log10.
fn to_axis(scale: Scale, v: f64) -> f64 {
    match scale {
        Scale::Linear => v,
        Scale::Log10 => v.log10(),
    }
}

fn panel_name(i: usize, p: &Panel) -> String {
    if p.title.is_empty() { format!("panel {i}") } else { format!("panel {i} (\"{}\")", p.title) }
}

/// Min and max of finite values, in axis coordinates.
#[derive(Clone, Copy, Debug)]
struct Extent {
    min: f64,
    max: f64,
}

fn widen(e: Option<Extent>, v: f64) -> Option<Extent> {
    if !v.is_finite() {
        return e;
    }
    Some(match e {
        None => Extent { min: v, max: v },
        Some(e) => Extent { min: e.min.min(v), max: e.max.max(v) },
    })
}

fn union(a: Option<Extent>, b: Option<Extent>) -> Option<Extent> {
    match (a, b) {
        (Some(a), Some(b)) => Some(Extent { min: a.min.min(b.min), max: a.max.max(b.max) }),
        (a, None) => a,
        (None, b) => b,
    }
}

/// Cell edges around `centres` (already in axis coordinates, strictly monotone).
fn cell_edges(centres: &[f64]) -> Vec<f64> {
    let n = centres.len();
    if n == 1 {
        return vec![centres[0] - 0.5, centres[0] + 0.5];
    }
    let mut edges = Vec::with_capacity(n + 1);
    edges.push(centres[0] - 0.5 * (centres[1] - centres[0]));
    for w in centres.windows(2) {
        edges.push(0.5 * (w[0] + w[1]));
    }
    edges.push(centres[n - 1] + 0.5 * (centres[n - 1] - centres[n - 2]));
    edges
}

/// A panel's grid with centres converted to axis coordinates and cells checked.
struct GridGeom<'a> {
    grid: &'a Grid,
    x_edges: Vec<f64>,
    y_edges: Vec<f64>,
}

/// The validated data of a panel in axis coordinates.
struct Prepared<'a> {
    name: String,
    x_extent: Option<Extent>,
    y_extent: Option<Extent>,
    grid: Option<GridGeom<'a>>,
}

fn check_log(panel: &str, series: &str, axis: Axis, scale: Scale, values: &[f64]) -> Result<(), PlotError> {
    if scale == Scale::Log10
        && let Some((index, &value)) = values.iter().enumerate().find(|&(_, &v)| v.is_finite() && v <= 0.0)
    {
        return Err(PlotError::NonPositiveOnLog {
            panel: panel.to_owned(),
            series: series.to_owned(),
            axis,
            index,
            value,
        });
    }
    Ok(())
}

fn grid_centres(panel: &str, what: &str, scale: Scale, centres: &[f64]) -> Result<Vec<f64>, PlotError> {
    let bad = |reason: String| PlotError::BadGrid { panel: panel.to_owned(), reason };
    if centres.is_empty() {
        return Err(bad(format!("no {what} centres")));
    }
    check_log(panel, &format!("grid {what} centres"), if what == "x" { Axis::X } else { Axis::Y }, scale, centres)?;
    let c: Vec<f64> = centres.iter().map(|&v| to_axis(scale, v)).collect();
    if let Some(i) = c.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!("{what} centre {i} is {}", centres[i])));
    }
    let increasing = c.windows(2).all(|w| w[1] > w[0]);
    let decreasing = c.windows(2).all(|w| w[1] < w[0]);
    if !(increasing || decreasing) {
        return Err(bad(format!("{what} centres {centres:?} are not strictly increasing or decreasing")));
    }
    Ok(c)
}

fn prepare(i: usize, p: &Panel) -> Result<Prepared<'_>, PlotError> {
    let name = panel_name(i, p);
    let (xs, ys) = (p.x.scale, p.y.scale);
    let (mut xe, mut ye) = (None, None);
    for s in &p.series {
        if s.x.len() != s.y.len() {
            return Err(PlotError::LengthMismatch {
                panel: name,
                series: s.name.clone(),
                x_len: s.x.len(),
                y_len: s.y.len(),
            });
        }
        check_log(&name, &s.name, Axis::X, xs, &s.x)?;
        check_log(&name, &s.name, Axis::Y, ys, &s.y)?;
        for (&x, &y) in s.x.iter().zip(&s.y) {
            if x.is_finite() && y.is_finite() {
                xe = widen(xe, to_axis(xs, x));
                ye = widen(ye, to_axis(ys, y));
            }
        }
    }
    for r in &p.ref_lines {
        let scale = if r.axis == Axis::X { xs } else { ys };
        check_log(&name, &r.label, r.axis, scale, &[r.value])?;
        match r.axis {
            Axis::X => xe = widen(xe, to_axis(xs, r.value)),
            Axis::Y => ye = widen(ye, to_axis(ys, r.value)),
        }
    }
    let grid = match &p.grid {
        None => None,
        Some(g) => {
            let cx = grid_centres(&name, "x", xs, &g.x)?;
            let cy = grid_centres(&name, "y", ys, &g.y)?;
            for c in &g.cells {
                if c.ix >= g.x.len() || c.iy >= g.y.len() {
                    return Err(PlotError::BadGrid {
                        panel: name,
                        reason: format!("cell ({}, {}) is outside the {}×{} grid", c.ix, c.iy, g.x.len(), g.y.len()),
                    });
                }
                if c.category >= g.categories.len() {
                    return Err(PlotError::BadGrid {
                        panel: name,
                        reason: format!(
                            "cell ({}, {}) has category {} but only {} categories were added",
                            c.ix,
                            c.iy,
                            c.category,
                            g.categories.len()
                        ),
                    });
                }
            }
            let (x_edges, y_edges) = (cell_edges(&cx), cell_edges(&cy));
            for &e in [x_edges[0], x_edges[x_edges.len() - 1]].iter() {
                xe = widen(xe, e);
            }
            for &e in [y_edges[0], y_edges[y_edges.len() - 1]].iter() {
                ye = widen(ye, e);
            }
            Some(GridGeom { grid: g, x_edges, y_edges })
        }
    };
    Ok(Prepared { name, x_extent: xe, y_extent: ye, grid })
}

/// The drawn range of an axis in axis coordinates (`lo < hi`, both finite).
fn resolve_range(
    panel: &str,
    axis: Axis,
    spec: &AxisSpec,
    extent: Option<Extent>,
    fitted: bool,
) -> Result<(f64, f64), PlotError> {
    if let Some((min, max)) = spec.range {
        let ok = min < max && (spec.scale == Scale::Linear || min > 0.0);
        let (lo, hi) = (to_axis(spec.scale, min), to_axis(spec.scale, max));
        if !(ok && ticks::drawable_span(lo, hi)) {
            return Err(PlotError::BadRange { panel: panel.to_owned(), axis, min, max });
        }
        return Ok((lo, hi));
    }
    let Some(Extent { min, max }) = extent else {
        return Ok((0.0, 1.0));
    };
    let (lo, hi) = if fitted && max > min {
        (min, max)
    } else {
        match spec.scale {
            Scale::Linear if max > min => {
                let p = AUTO_PAD * (max - min);
                (min - p, max + p)
            }
            Scale::Linear => {
                let d = if min == 0.0 { 1.0 } else { 0.1 * min.abs() };
                (min - d, min + d)
            }
            Scale::Log10 => ticks::log_auto_range_axis(min, max, AUTO_PAD),
        }
    };
    if !ticks::drawable_span(lo, hi) {
        let back = |v: f64| if spec.scale == Scale::Log10 { 10f64.powf(v) } else { v };
        return Err(PlotError::DataRange { panel: panel.to_owned(), axis, min: back(min), max: back(max) });
    }
    Ok((lo, hi))
}

/// Maps axis coordinates to pixels for one panel.
#[derive(Clone, Copy)]
struct Mapping {
    rect: Rect,
    x: (f64, f64),
    y: (f64, f64),
}

impl Mapping {
    fn px(&self, ax: f64) -> f64 {
        self.rect.x0 + (ax - self.x.0) / (self.x.1 - self.x.0) * self.rect.width()
    }

    fn py(&self, ay: f64) -> f64 {
        self.rect.y1 - (ay - self.y.0) / (self.y.1 - self.y.0) * self.rect.height()
    }
}

fn inside(lo: f64, hi: f64, p: f64) -> bool {
    let eps = 1e-9 * (hi - lo);
    p >= lo - eps && p <= hi + eps
}

/// Ticks given by the caller (or a grid's centres), kept if inside the range.
fn explicit_ticks(scale: Scale, lo: f64, hi: f64, ticks: &[(f64, Option<String>)]) -> Vec<Tick> {
    ticks
        .iter()
        .filter(|(v, _)| v.is_finite() && (scale == Scale::Linear || *v > 0.0))
        .map(|(v, text)| Tick {
            pos: to_axis(scale, *v),
            label: Some(text.as_ref().map_or_else(|| ticks::value_label(*v), |t| Label::plain(t.clone()))),
        })
        .filter(|t| inside(lo, hi, t.pos))
        .collect()
}

/// Ticks of one axis. Automatic ticks are thinned until neighbouring labels do not touch:
/// `room(label)` is the space a label needs along the axis.
fn axis_ticks(
    spec: &AxisSpec,
    grid_centres: Option<&[f64]>,
    (lo, hi): (f64, f64),
    length_px: f64,
    room: impl Fn(&Label) -> f64,
    start_labels: usize,
) -> Vec<Tick> {
    let explicit: Option<Vec<(f64, Option<String>)>> = match (&spec.ticks, grid_centres) {
        (TickChoice::At(v), _) => Some(v.iter().map(|&v| (v, None)).collect()),
        (TickChoice::Labelled(v), _) => Some(v.iter().map(|(v, s)| (*v, Some(s.clone()))).collect()),
        (TickChoice::Auto, Some(c)) => Some(c.iter().map(|&v| (v, None)).collect()),
        (TickChoice::Auto, None) => None,
    };
    if let Some(e) = explicit {
        return explicit_ticks(spec.scale, lo, hi, &e);
    }
    let px_per_unit = length_px / (hi - lo);
    let mut max_labels = start_labels.max(2);
    loop {
        let t = match spec.scale {
            Scale::Linear => ticks::linear_axis_ticks(lo, hi, max_labels),
            Scale::Log10 => ticks::log_axis_ticks(lo, hi, length_px, max_labels),
        };
        let mut labelled: Vec<(f64, f64)> =
            t.iter().filter_map(|t| t.label.as_ref().map(|l| (t.pos * px_per_unit, room(l)))).collect();
        labelled.sort_by(|a, b| a.0.total_cmp(&b.0));
        let fits = labelled.windows(2).all(|w| (w[1].0 - w[0].0) >= 0.5 * (w[0].1 + w[1].1) + 8.0);
        if fits || max_labels <= 2 {
            return t;
        }
        max_labels -= 1;
    }
}

/// What a legend entry shows left of its text.
enum Swatch {
    Line { color: Color, width: f64, dash: Dash, marker: Option<(Marker, f64)> },
    Markers { color: Color, marker: Marker, size: f64 },
    Patch(Color),
}

struct LegendEntry {
    text: String,
    swatch: Swatch,
}

fn legend_size(entries: &[LegendEntry]) -> (f64, f64) {
    let text_w = entries.iter().map(|e| ticks::text_width_px(&e.text, LEGEND_FONT)).fold(0.0, f64::max);
    (8.0 + LEGEND_SWATCH + 6.0 + text_w + 8.0, 6.0 + LEGEND_ROW * entries.len() as f64 + 2.0)
}

/// A series ready to draw: clipped pieces in pixels, markers, style.
struct DrawnSeries {
    name: String,
    pieces: Vec<Vec<Pt>>,
    markers: Vec<Pt>,
    color: Color,
    width: f64,
    dash: Dash,
    marker: Option<(Marker, f64)>,
}

fn draw_series(p: &Panel, m: &Mapping) -> Vec<DrawnSeries> {
    let (xs, ys) = (p.x.scale, p.y.scale);
    let clip = m.rect.grown(2.0);
    let decimate_above = (2.0 * m.rect.width()).ceil() as usize;
    let mut out = Vec::with_capacity(p.series.len());
    let mut run: Vec<Pt> = Vec::new();
    let mut thinned: Vec<Pt> = Vec::new();
    for (i, s) in p.series.iter().enumerate() {
        let (color, marker) = series_style(i, s);
        let mut pieces = Vec::new();
        let mut markers = Vec::new();
        let mut flush_run = |run: &mut Vec<Pt>, pieces: &mut Vec<Vec<Pt>>| {
            if run.len() > decimate_above {
                thinned.clear();
                decimate_columns(run, &mut thinned);
                clip_polyline(&thinned, &clip, pieces);
            } else {
                clip_polyline(run, &clip, pieces);
            }
            run.clear();
        };
        for (&x, &y) in s.x.iter().zip(&s.y) {
            let pt = (m.px(to_axis(xs, x)), m.py(to_axis(ys, y)));
            if !(x.is_finite() && y.is_finite() && pt.0.is_finite() && pt.1.is_finite()) {
                if s.kind == SeriesKind::Line {
                    flush_run(&mut run, &mut pieces);
                }
                continue;
            }
            if s.kind == SeriesKind::Line {
                run.push(pt);
            }
            if marker.is_some() && m.rect.contains(pt) {
                markers.push(pt);
            }
        }
        if s.kind == SeriesKind::Line {
            flush_run(&mut run, &mut pieces);
        }
        out.push(DrawnSeries {
            name: s.name.clone(),
            pieces,
            markers,
            color,
            width: s.width,
            dash: s.dash,
            marker: marker.map(|mk| (mk, s.marker_size)),
        });
    }
    out
}

/// Colour and marker shape of the `i`-th series of a panel.
fn series_style(i: usize, s: &Series) -> (Color, Option<Marker>) {
    let marker = match (s.marker, s.kind) {
        (MarkerChoice::Fixed(mk), _) => Some(mk),
        (MarkerChoice::Auto, _) | (MarkerChoice::Default, SeriesKind::Scatter) => {
            Some(Marker::CYCLE[i % Marker::CYCLE.len()])
        }
        _ => None,
    };
    (s.color.unwrap_or(PALETTE[i % PALETTE.len()]), marker)
}

fn legend_entries(p: &Panel) -> Vec<LegendEntry> {
    let mut entries = Vec::new();
    for (i, s) in p.series.iter().enumerate().filter(|(_, s)| !s.name.is_empty()) {
        let (color, marker) = series_style(i, s);
        let swatch = match (s.kind, marker) {
            (SeriesKind::Line, marker) => {
                Swatch::Line { color, width: s.width, dash: s.dash, marker: marker.map(|mk| (mk, s.marker_size)) }
            }
            (SeriesKind::Scatter, Some(marker)) => Swatch::Markers { color, marker, size: s.marker_size },
            (SeriesKind::Scatter, None) => Swatch::Patch(color),
        };
        entries.push(LegendEntry { text: s.name.clone(), swatch });
    }
    if let Some(g) = &p.grid {
        for (name, color) in &g.categories {
            entries.push(LegendEntry { text: name.clone(), swatch: Swatch::Patch(*color) });
        }
    }
    entries
}

/// The legend's resolved placement.
#[derive(Clone, Copy, PartialEq)]
enum Placement {
    None,
    Inside,
    Outside,
}

fn placement(p: &Panel, n_entries: usize, legend_h: f64, plot_h_estimate: f64) -> Placement {
    if n_entries == 0 {
        return Placement::None;
    }
    match p.legend {
        Legend::Hidden => Placement::None,
        Legend::Right => Placement::Outside,
        Legend::Auto if p.grid.is_some() || legend_h > plot_h_estimate - 16.0 => Placement::Outside,
        _ => Placement::Inside,
    }
}

/// Top-left corner of an inside legend of size `(w, h)`: the requested corner, or for `Auto`
/// the corner where the fewest pixels of line and markers lie under the box.
fn inside_corner(legend: Legend, rect: &Rect, (w, h): (f64, f64), drawn: &[DrawnSeries], refs: &[Vec<Pt>]) -> Pt {
    let inset = 8.0;
    let corners = [
        (Legend::TopRight, (rect.x1 - inset - w, rect.y0 + inset)),
        (Legend::TopLeft, (rect.x0 + inset, rect.y0 + inset)),
        (Legend::BottomRight, (rect.x1 - inset - w, rect.y1 - inset - h)),
        (Legend::BottomLeft, (rect.x0 + inset, rect.y1 - inset - h)),
    ];
    if let Some(&(_, c)) = corners.iter().find(|(l, _)| *l == legend) {
        return c;
    }
    let mut best = corners[0].1;
    let mut best_cost = f64::INFINITY;
    for &(_, c) in &corners {
        let b = Rect { x0: c.0, y0: c.1, x1: c.0 + w, y1: c.1 + h }.grown(4.0);
        let mut cost = length_inside(refs, &b);
        for d in drawn {
            cost += length_inside(&d.pieces, &b);
            cost += 10.0 * d.markers.iter().filter(|&&pt| b.contains(pt)).count() as f64;
        }
        if cost < best_cost {
            best_cost = cost;
            best = c;
        }
    }
    best
}

/// Everything decided about a panel before writing it.
struct PanelLayout {
    /// Left edge of the panel's column.
    col_x: f64,
    rect: Rect,
    map: Mapping,
    x_ticks: Vec<Tick>,
    y_ticks: Vec<Tick>,
    show_x_ticks: bool,
    x_label: String,
    legend: Placement,
    legend_entries: Vec<LegendEntry>,
    legend_size: (f64, f64),
}

pub(super) fn render(fig: &Figure) -> Result<String, PlotError> {
    let n = fig.panels.len();
    if n == 0 {
        return Err(PlotError::Empty);
    }
    let cols = fig.columns.clamp(1, n);
    let rows = n.div_ceil(cols);
    let (w, h) = (f64::from(fig.width), f64::from(fig.height));
    let too_small = PlotError::TooSmall { width: fig.width, height: fig.height };
    if w < 120.0 * cols as f64 || h < 80.0 * rows as f64 {
        return Err(too_small);
    }

    let prepared: Vec<Prepared> =
        fig.panels.iter().enumerate().map(|(i, p)| prepare(i, p)).collect::<Result<_, _>>()?;

    // Ranges; a shared x axis takes the union of all panels' data and the first fixed range.
    let mut x_ranges = Vec::with_capacity(n);
    let mut y_ranges = Vec::with_capacity(n);
    let shared_x = if fig.share_x {
        let first = &fig.panels[0].x;
        for (p, pr) in fig.panels.iter().zip(&prepared) {
            if p.x.scale != first.scale {
                return Err(PlotError::SharedScaleMismatch { panel: pr.name.clone() });
            }
        }
        let spec = fig.panels.iter().map(|p| &p.x).find(|s| s.range.is_some()).unwrap_or(first);
        let extent = prepared.iter().fold(None, |e, pr| union(e, pr.x_extent));
        let fitted = prepared.iter().any(|pr| pr.grid.is_some());
        Some(resolve_range(&prepared[0].name, Axis::X, spec, extent, fitted)?)
    } else {
        None
    };
    for (p, pr) in fig.panels.iter().zip(&prepared) {
        let fitted = pr.grid.is_some();
        x_ranges.push(match shared_x {
            Some(r) => r,
            None => resolve_range(&pr.name, Axis::X, &p.x, pr.x_extent, fitted)?,
        });
        y_ranges.push(resolve_range(&pr.name, Axis::Y, &p.y, pr.y_extent, fitted)?);
    }

    // Vertical layout: equal plot heights; each row reserves the largest overhead of its panels.
    let shared_x_label = fig.panels.iter().map(|p| p.x.label.as_str()).find(|l| !l.is_empty()).unwrap_or("");
    let show_x_ticks = |i: usize| !fig.share_x || i + cols >= n;
    let x_label_of = |i: usize| -> String {
        if !show_x_ticks(i) {
            String::new()
        } else if fig.share_x && fig.panels[i].x.label.is_empty() {
            shared_x_label.to_owned()
        } else {
            fig.panels[i].x.label.clone()
        }
    };
    let top_of = |i: usize| if fig.panels[i].title.is_empty() { 10.0 } else { TITLE_FONT + 14.0 };
    let bottom_of = |i: usize| {
        let ticks = if show_x_ticks(i) { TICK_LEN + 4.0 + TICK_FONT + 4.0 } else { 8.0 };
        ticks + if x_label_of(i).is_empty() { 0.0 } else { LABEL_FONT + 6.0 }
    };
    let fig_title_h = if fig.title.is_empty() { 0.0 } else { FIG_TITLE_FONT + 14.0 };
    let row_panels = |r: usize| (r * cols)..((r + 1) * cols).min(n);
    let row_top: Vec<f64> = (0..rows).map(|r| row_panels(r).map(top_of).fold(0.0, f64::max)).collect();
    let row_bottom: Vec<f64> = (0..rows).map(|r| row_panels(r).map(bottom_of).fold(0.0, f64::max)).collect();
    let overhead: f64 = row_top.iter().sum::<f64>() + row_bottom.iter().sum::<f64>();
    let plot_h = (h - fig_title_h - PAD - overhead) / rows as f64;
    if plot_h < MIN_PLOT_H {
        return Err(too_small);
    }

    // y ticks (they only need the plot height), then the common left margin.
    let mut y_ticks = Vec::with_capacity(n);
    for ((p, pr), &yr) in fig.panels.iter().zip(&prepared).zip(&y_ranges) {
        let centres = pr.grid.as_ref().map(|g| g.grid.y.as_slice());
        // Start generous; `axis_ticks` thins the labels until they keep apart.
        let max_labels = (plot_h / 25.0) as usize + 1;
        y_ticks.push(axis_ticks(&p.y, centres, yr, plot_h, |_| TICK_FONT * 1.2, max_labels));
    }
    let max_y_label_w =
        y_ticks.iter().flatten().filter_map(|t| t.label.as_ref()).map(|l| l.width_px(TICK_FONT)).fold(0.0, f64::max);
    let any_y_label = fig.panels.iter().any(|p| !p.y.label.is_empty());
    let left = PAD + if any_y_label { LABEL_FONT + 8.0 } else { 0.0 } + max_y_label_w + TICK_LEN + 4.0;

    // Horizontal layout, x ticks, legends.
    let col_w = w / cols as f64;
    let mut layouts = Vec::with_capacity(n);
    let mut y_cursor = fig_title_h;
    let mut row_y0 = Vec::with_capacity(rows);
    for r in 0..rows {
        row_y0.push(y_cursor + row_top[r]);
        y_cursor += row_top[r] + plot_h + row_bottom[r];
    }
    // Legends outside the plot widen the right margin of their whole column, so that the
    // panels of a column stay aligned.
    let mut legends = Vec::with_capacity(n);
    let mut col_right = vec![RIGHT_MARGIN; cols];
    for (i, p) in fig.panels.iter().enumerate() {
        let entries = legend_entries(p);
        let size = legend_size(&entries);
        let place = placement(p, entries.len(), size.1, plot_h);
        if place == Placement::Outside {
            col_right[i % cols] = col_right[i % cols].max(RIGHT_MARGIN + size.0 + 4.0);
        }
        legends.push((entries, size, place));
    }
    let mut drawn_all = Vec::with_capacity(n);
    for (i, (((p, pr), y_ticks), (entries, size, place))) in
        fig.panels.iter().zip(&prepared).zip(y_ticks).zip(legends).enumerate()
    {
        let (r, c) = (i / cols, i % cols);
        let col_x = c as f64 * col_w;
        let right = col_right[c];
        let rect = Rect { x0: col_x + left, y0: row_y0[r], x1: col_x + col_w - right, y1: row_y0[r] + plot_h };
        if rect.width() < MIN_PLOT_W {
            return Err(PlotError::TooSmall { width: fig.width, height: fig.height });
        }
        let map = Mapping { rect, x: x_ranges[i], y: y_ranges[i] };
        let centres = pr.grid.as_ref().map(|g| g.grid.x.as_slice());
        let max_labels = (rect.width() / 70.0) as usize + 1;
        let x_ticks = axis_ticks(&p.x, centres, x_ranges[i], rect.width(), |l| l.width_px(TICK_FONT), max_labels);
        let drawn = draw_series(p, &map);
        layouts.push(PanelLayout {
            col_x,
            rect,
            map,
            x_ticks,
            y_ticks,
            show_x_ticks: show_x_ticks(i),
            x_label: x_label_of(i),
            legend: place,
            legend_entries: entries,
            legend_size: size,
        });
        drawn_all.push(drawn);
    }

    let mut out = String::with_capacity(16 * 1024);
    write_document(&mut out, fig, &prepared, &layouts, &drawn_all).expect("writing to a String cannot fail");
    Ok(out)
}

fn write_document(
    out: &mut String,
    fig: &Figure,
    prepared: &[Prepared],
    layouts: &[PanelLayout],
    drawn: &[Vec<DrawnSeries>],
) -> std::fmt::Result {
    let (w, h) = (fig.width, fig.height);
    writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="{FONT_FAMILY}" font-size="{TICK_FONT}">"#
    )?;
    writeln!(out, r##"<rect class="background" x="0" y="0" width="{w}" height="{h}" fill="#ffffff"/>"##)?;
    if !fig.title.is_empty() {
        writeln!(
            out,
            r#"<text class="figure-title" x="{}" y="{}" text-anchor="middle" font-size="{FIG_TITLE_FONT}" font-weight="bold">{}</text>"#,
            Num(f64::from(w) / 2.0),
            Num(FIG_TITLE_FONT + 6.0),
            Esc(&fig.title)
        )?;
    }
    writeln!(out, "<defs>")?;
    for (i, l) in layouts.iter().enumerate() {
        let r = l.rect;
        writeln!(
            out,
            r#"<clipPath id="clip-{i}"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath>"#,
            Num(r.x0),
            Num(r.y0),
            Num(r.width()),
            Num(r.height())
        )?;
    }
    writeln!(out, "</defs>")?;
    for (i, ((p, l), pr)) in fig.panels.iter().zip(layouts).zip(prepared).enumerate() {
        writeln!(out, r#"<g class="panel" id="panel-{i}">"#)?;
        write_panel(out, i, p, l, pr, &drawn[i])?;
        writeln!(out, "</g>")?;
    }
    writeln!(out, "</svg>")
}

fn write_label(out: &mut String, label: &Label, size: f64) -> std::fmt::Result {
    write!(out, "{}", Esc(&label.text))?;
    if let Some(sup) = &label.sup {
        let raise = 0.42 * size;
        write!(
            out,
            r#"<tspan dy="{}" font-size="{}">{}</tspan>"#,
            Num(-raise),
            Num(ticks::SUP_SCALE * size),
            Esc(sup)
        )?;
    }
    Ok(())
}

fn write_panel(
    out: &mut String,
    i: usize,
    p: &Panel,
    l: &PanelLayout,
    pr: &Prepared,
    drawn: &[DrawnSeries],
) -> std::fmt::Result {
    let r = l.rect;
    let m = &l.map;
    if !p.title.is_empty() {
        writeln!(
            out,
            r#"<text class="panel-title" x="{}" y="{}" text-anchor="middle" font-size="{TITLE_FONT}" font-weight="bold">{}</text>"#,
            Num(0.5 * (r.x0 + r.x1)),
            Num(r.y0 - 9.0),
            Esc(&p.title)
        )?;
    }

    if let Some(g) = &pr.grid {
        write_grid(out, i, g, m)?;
    } else {
        // Grid lines: major ticks darker than minor ones.
        for (major, color) in [(false, "#f0f0f0"), (true, "#dedede")] {
            let mut d = String::new();
            for t in l.x_ticks.iter().filter(|t| t.label.is_some() == major) {
                write!(d, "M{} {}V{}", Num(m.px(t.pos)), Num(r.y0), Num(r.y1))?;
            }
            for t in l.y_ticks.iter().filter(|t| t.label.is_some() == major) {
                write!(d, "M{} {}H{}", Num(r.x0), Num(m.py(t.pos)), Num(r.x1))?;
            }
            if !d.is_empty() {
                writeln!(out, r#"<path class="gridlines" d="{d}" stroke="{color}" stroke-width="1" fill="none"/>"#)?;
            }
        }
    }

    // Reference lines.
    let mut ref_pieces: Vec<Vec<Pt>> = Vec::new();
    for rl in &p.ref_lines {
        let (scale, lo, hi) = match rl.axis {
            Axis::X => (p.x.scale, m.x.0, m.x.1),
            Axis::Y => (p.y.scale, m.y.0, m.y.1),
        };
        let a = to_axis(scale, rl.value);
        if !a.is_finite() || !inside(lo, hi, a) {
            continue;
        }
        let (d, tx, ty, anchor) = match rl.axis {
            Axis::Y => {
                let y = m.py(a);
                ref_pieces.push(vec![(r.x0, y), (r.x1, y)]);
                (format!("M{} {}H{}", Num(r.x0), Num(y), Num(r.x1)), r.x1 - 4.0, y - 4.0, "end")
            }
            Axis::X => {
                let x = m.px(a);
                ref_pieces.push(vec![(x, r.y0), (x, r.y1)]);
                (format!("M{} {}V{}", Num(x), Num(r.y0), Num(r.y1)), x + 4.0, r.y0 + REF_FONT + 3.0, "start")
            }
        };
        writeln!(
            out,
            r##"<path class="refline" d="{d}" stroke="#444444" stroke-width="1" stroke-dasharray="6 4" fill="none"/>"##
        )?;
        if !rl.label.is_empty() {
            writeln!(
                out,
                r##"<text class="refline-label" x="{}" y="{}" text-anchor="{anchor}" font-size="{REF_FONT}" fill="#333333">{}</text>"##,
                Num(tx),
                Num(ty),
                Esc(&rl.label)
            )?;
        }
    }

    // Series, clipped to the plot area (lines are already clipped; this trims markers and
    // line caps at the frame).
    writeln!(out, r#"<g class="series" clip-path="url(#clip-{i})">"#)?;
    for d in drawn {
        if !d.pieces.is_empty() {
            let mut path = String::new();
            for piece in &d.pieces {
                write!(path, "M{} {}L", Num(piece[0].0), Num(piece[0].1))?;
                for (k, pt) in piece[1..].iter().enumerate() {
                    if k > 0 {
                        path.push(' ');
                    }
                    write!(path, "{} {}", Num(pt.0), Num(pt.1))?;
                }
            }
            write!(
                out,
                r#"<path class="line" data-series="{}" d="{path}" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round" stroke-linecap="round""#,
                Esc(&d.name),
                d.color,
                Num(d.width)
            )?;
            write_dash(out, d.dash, d.width)?;
            writeln!(out, "/>")?;
        }
        if let Some((marker, size)) = d.marker
            && !d.markers.is_empty()
        {
            write_markers(out, &d.name, marker, size, d.color, &d.markers)?;
        }
    }
    writeln!(out, "</g>")?;

    writeln!(
        out,
        r##"<rect class="frame" x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#000000" stroke-width="1"/>"##,
        Num(r.x0),
        Num(r.y0),
        Num(r.width()),
        Num(r.height())
    )?;
    write_axes(out, p, l)?;
    match l.legend {
        Placement::None => {}
        Placement::Inside => {
            let at = inside_corner(p.legend, &r, l.legend_size, drawn, &ref_pieces);
            write_legend(out, at, l.legend_size, &l.legend_entries)?;
        }
        Placement::Outside => {
            let at = (r.x1 + 12.0, r.y0);
            write_legend(out, at, l.legend_size, &l.legend_entries)?;
        }
    }
    Ok(())
}

fn write_dash(out: &mut String, dash: Dash, width: f64) -> std::fmt::Result {
    if let Some(a) = dash.dasharray(width) {
        write!(out, r#" stroke-dasharray="{} {} {} {}""#, Num(a[0]), Num(a[1]), Num(a[2]), Num(a[3]))?;
    }
    Ok(())
}

/// Path data of one marker of bounding size `size` centred at `(x, y)`.
fn marker_path(d: &mut String, marker: Marker, size: f64, (x, y): Pt) -> std::fmt::Result {
    let r = 0.5 * size;
    match marker {
        Marker::Circle => write!(
            d,
            "M{} {}a{r} {r} 0 1 0 {} 0a{r} {r} 0 1 0 {} 0Z",
            Num(x - r),
            Num(y),
            Num(2.0 * r),
            Num(-2.0 * r),
            r = Num(r)
        ),
        Marker::Square => {
            let s = 0.85 * r;
            write!(d, "M{} {}h{}v{}h{}Z", Num(x - s), Num(y - s), Num(2.0 * s), Num(2.0 * s), Num(-2.0 * s))
        }
        Marker::Triangle => {
            let s = 1.15 * r;
            write!(
                d,
                "M{} {}L{} {} {} {}Z",
                Num(x),
                Num(y - s),
                Num(x + 0.866 * s),
                Num(y + 0.5 * s),
                Num(x - 0.866 * s),
                Num(y + 0.5 * s)
            )
        }
        Marker::Diamond => {
            let s = 1.1 * r;
            write!(
                d,
                "M{} {}L{} {} {} {} {} {}Z",
                Num(x),
                Num(y - s),
                Num(x + s),
                Num(y),
                Num(x),
                Num(y + s),
                Num(x - s),
                Num(y)
            )
        }
        Marker::Cross => {
            let s = 0.8 * r;
            write!(
                d,
                "M{} {}L{} {}M{} {}L{} {}",
                Num(x - s),
                Num(y - s),
                Num(x + s),
                Num(y + s),
                Num(x - s),
                Num(y + s),
                Num(x + s),
                Num(y - s)
            )
        }
        Marker::Plus => write!(d, "M{} {}H{}M{} {}V{}", Num(x - r), Num(y), Num(x + r), Num(x), Num(y - r), Num(y + r)),
    }
}

fn write_markers(
    out: &mut String,
    name: &str,
    marker: Marker,
    size: f64,
    color: Color,
    points: &[Pt],
) -> std::fmt::Result {
    let mut d = String::new();
    for &pt in points {
        marker_path(&mut d, marker, size, pt)?;
    }
    if marker.is_stroke_only() {
        writeln!(
            out,
            r#"<path class="markers" data-series="{}" d="{d}" fill="none" stroke="{color}" stroke-width="1.5"/>"#,
            Esc(name)
        )
    } else {
        writeln!(
            out,
            r##"<path class="markers" data-series="{}" d="{d}" fill="{color}" stroke="#ffffff" stroke-width="0.75"/>"##,
            Esc(name)
        )
    }
}

fn write_grid(out: &mut String, i: usize, g: &GridGeom, m: &Mapping) -> std::fmt::Result {
    writeln!(out, r#"<g class="heatmap" clip-path="url(#clip-{i})">"#)?;
    for c in &g.grid.cells {
        let (xa, xb) = (m.px(g.x_edges[c.ix]), m.px(g.x_edges[c.ix + 1]));
        let (ya, yb) = (m.py(g.y_edges[c.iy]), m.py(g.y_edges[c.iy + 1]));
        let (x0, x1, y0, y1) = (xa.min(xb), xa.max(xb), ya.min(yb), ya.max(yb));
        let color = g.grid.categories[c.category].1;
        writeln!(
            out,
            r##"<rect class="cell" data-ix="{}" data-iy="{}" x="{}" y="{}" width="{}" height="{}" fill="{color}" stroke="#ffffff" stroke-width="1.5"/>"##,
            c.ix,
            c.iy,
            Num(x0),
            Num(y0),
            Num(x1 - x0),
            Num(y1 - y0)
        )?;
        if !c.text.is_empty() {
            let unit_w = ticks::text_width_px(&c.text, 1.0);
            let size = 12.0f64.min(0.55 * (y1 - y0)).min(0.85 * (x1 - x0) / unit_w);
            if size >= 7.0 {
                writeln!(
                    out,
                    r#"<text class="cell-text" x="{}" y="{}" text-anchor="middle" font-size="{}" fill="{}">{}</text>"#,
                    Num(0.5 * (x0 + x1)),
                    Num(0.5 * (y0 + y1) + 0.36 * size),
                    Num(size),
                    color.contrasting_text(),
                    Esc(&c.text)
                )?;
            }
        }
    }
    writeln!(out, "</g>")
}

fn write_axes(out: &mut String, p: &Panel, l: &PanelLayout) -> std::fmt::Result {
    let r = l.rect;
    let m = &l.map;
    // Tick marks outside the frame.
    let mut d = String::new();
    for t in &l.x_ticks {
        let len = if t.label.is_some() { TICK_LEN } else { MINOR_TICK_LEN };
        write!(d, "M{} {}v{}", Num(m.px(t.pos)), Num(r.y1), Num(len))?;
    }
    for t in &l.y_ticks {
        let len = if t.label.is_some() { TICK_LEN } else { MINOR_TICK_LEN };
        write!(d, "M{} {}h{}", Num(r.x0), Num(m.py(t.pos)), Num(-len))?;
    }
    if !d.is_empty() {
        writeln!(out, r##"<path class="ticks" d="{d}" stroke="#000000" stroke-width="1" fill="none"/>"##)?;
    }
    if l.show_x_ticks {
        for t in &l.x_ticks {
            if let Some(label) = &t.label {
                write!(
                    out,
                    r#"<text class="xtick" x="{}" y="{}" text-anchor="middle">"#,
                    Num(m.px(t.pos)),
                    Num(r.y1 + TICK_LEN + 3.0 + TICK_FONT)
                )?;
                write_label(out, label, TICK_FONT)?;
                writeln!(out, "</text>")?;
            }
        }
    }
    for t in &l.y_ticks {
        if let Some(label) = &t.label {
            write!(
                out,
                r#"<text class="ytick" x="{}" y="{}" text-anchor="end">"#,
                Num(r.x0 - TICK_LEN - 4.0),
                Num(m.py(t.pos) + 0.36 * TICK_FONT)
            )?;
            write_label(out, label, TICK_FONT)?;
            writeln!(out, "</text>")?;
        }
    }
    if !l.x_label.is_empty() {
        writeln!(
            out,
            r#"<text class="xlabel" x="{}" y="{}" text-anchor="middle" font-size="{LABEL_FONT}">{}</text>"#,
            Num(0.5 * (r.x0 + r.x1)),
            Num(r.y1 + TICK_LEN + 4.0 + TICK_FONT + 4.0 + LABEL_FONT),
            Esc(&l.x_label)
        )?;
    }
    if !p.y.label.is_empty() {
        let bx = l.col_x + PAD + 0.8 * LABEL_FONT;
        let by = 0.5 * (r.y0 + r.y1);
        writeln!(
            out,
            r#"<text class="ylabel" x="{}" y="{}" text-anchor="middle" font-size="{LABEL_FONT}" transform="rotate(-90 {} {})">{}</text>"#,
            Num(bx),
            Num(by),
            Num(bx),
            Num(by),
            Esc(&p.y.label)
        )?;
    }
    Ok(())
}

fn write_legend(out: &mut String, (x, y): Pt, (w, h): (f64, f64), entries: &[LegendEntry]) -> std::fmt::Result {
    writeln!(out, r#"<g class="legend">"#)?;
    writeln!(
        out,
        r##"<rect x="{}" y="{}" width="{}" height="{}" fill="#ffffff" fill-opacity="0.9" stroke="#bbbbbb" stroke-width="1" rx="2"/>"##,
        Num(x),
        Num(y),
        Num(w),
        Num(h)
    )?;
    for (k, e) in entries.iter().enumerate() {
        let cy = y + 6.0 + LEGEND_ROW * (k as f64 + 0.5);
        let (sx0, sx1) = (x + 8.0, x + 8.0 + LEGEND_SWATCH);
        match &e.swatch {
            Swatch::Line { color, width, dash, marker } => {
                write!(
                    out,
                    r#"<path d="M{} {}H{}" stroke="{color}" stroke-width="{}" fill="none""#,
                    Num(sx0),
                    Num(cy),
                    Num(sx1),
                    Num(*width)
                )?;
                write_dash(out, *dash, *width)?;
                writeln!(out, "/>")?;
                if let Some((mk, size)) = marker {
                    write_markers(out, &e.text, *mk, *size, *color, &[(0.5 * (sx0 + sx1), cy)])?;
                }
            }
            Swatch::Markers { color, marker, size } => {
                write_markers(out, &e.text, *marker, *size, *color, &[(0.5 * (sx0 + sx1), cy)])?;
            }
            Swatch::Patch(color) => writeln!(
                out,
                r##"<rect x="{}" y="{}" width="{}" height="{}" fill="{color}" stroke="#888888" stroke-width="0.5"/>"##,
                Num(sx0 + 4.0),
                Num(cy - 6.0),
                Num(LEGEND_SWATCH - 8.0),
                Num(12.0)
            )?,
        }
        writeln!(
            out,
            r#"<text class="legend-text" x="{}" y="{}" font-size="{LEGEND_FONT}">{}</text>"#,
            Num(sx1 + 6.0),
            Num(cy + 0.36 * LEGEND_FONT),
            Esc(&e.text)
        )?;
    }
    writeln!(out, "</g>")
}
