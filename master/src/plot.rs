//! SVG figures written by hand, without a plotting stack.
//!
//! A [`Figure`] holds one or more [`Panel`]s laid out in rows (stacked vertically by default,
//! optionally in several columns, optionally sharing the x axis). A panel has a title, axis
//! labels, a linear or log10 [`Scale`] per axis, 1-2-5 (linear) or decade (log) ticks with grid
//! lines, a legend, and any number of [`Series`] (lines, optionally with markers, or scatter),
//! reference lines, and at most one categorical [`Grid`] (heat map, e.g. a stability map).
//!
//! ```no_run
//! use master::plot::{Figure, Scale};
//! let t: Vec<f64> = (0..10_001).map(|i| i as f64 * 0.01).collect();
//! let dx: Vec<f64> = t.iter().map(|t| 0.75 * (0.2 * t).sin()).collect();
//! let mut fig = Figure::new(900, 300);
//! fig.panel(|p| p.title("Cabin centre").x_label("t [s]").y_label("Δx [mm]").line("dx", &t, &dx));
//! fig.write_svg("/tmp/dx.svg").unwrap();
//! ```
//!
//! Data handling, documented once here:
//! * Points with a NaN or infinite coordinate are skipped: the line has a gap there.
//! * Automatic ranges cover all finite data with 4 % padding on each side (log axes: widened to
//!   whole decades when the data span a decade or more, see [`ticks::log_auto_range`]); a panel with a grid is fitted to the
//!   grid's cells exactly. Constant data get ±10 % around the value (±1 around zero), no data
//!   [0, 1]: never a division by zero. A fixed range ([`Panel::x_range`]) clips the data.
//! * On a log axis a value ≤ 0 is an error ([`PlotError::NonPositiveOnLog`]) naming the panel,
//!   series, index and value; such values are not dropped silently.
//! * Lines with more points than about two per pixel column are decimated per column keeping
//!   the first, last, lowest and highest point (see [`path::decimate_columns`]), so a 10⁴-point
//!   run stays small on disk and still shows every peak.

use std::fmt;
use std::io;
use std::path::Path;

pub mod path;
mod render;
pub mod style;
mod svg;
pub mod ticks;

pub use style::{Color, Dash, Marker, PALETTE};

/// How data values map to an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Scale {
    #[default]
    Linear,
    /// Base-10 logarithmic; only positive values can be shown.
    Log10,
}

/// Where a panel's legend goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Legend {
    /// Inside the plot, in the corner where it covers the least of the drawn lines; outside on
    /// the right for a panel with a grid (a heat map has no empty corner).
    #[default]
    Auto,
    TopLeft,
    TopRight,
    BottomLeft,
    BottomRight,
    /// Outside the plot area, to its right (the plot narrows to make room).
    Right,
    Hidden,
}

/// Which axis of a panel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Axis::X => "x",
            Axis::Y => "y",
        })
    }
}

/// Why a figure cannot be drawn. Every variant names the panel (0-based, with its title) and
/// the offending series, axis and value, so that the message alone locates the problem.
#[derive(Clone, Debug, PartialEq)]
pub enum PlotError {
    /// The figure has no panels.
    Empty,
    /// Width or height too small to lay out anything (or zero).
    TooSmall { width: u32, height: u32 },
    /// `x` and `y` of a series have different lengths.
    LengthMismatch { panel: String, series: String, x_len: usize, y_len: usize },
    /// A value ≤ 0 on a log axis.
    NonPositiveOnLog { panel: String, series: String, axis: Axis, index: usize, value: f64 },
    /// A fixed range that is empty, reversed, not finite, or not positive on a log axis.
    BadRange { panel: String, axis: Axis, min: f64, max: f64 },
    /// Data whose extent cannot be drawn: values beyond about ±1e307 (the span overflows) or a
    /// span below 1e-290.
    DataRange { panel: String, axis: Axis, min: f64, max: f64 },
    /// Panels that share the x axis but disagree on its scale.
    SharedScaleMismatch { panel: String },
    /// A grid whose centres are not finite and strictly monotone, or whose cell refers to a
    /// missing row, column or category.
    BadGrid { panel: String, reason: String },
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlotError::Empty => write!(f, "figure has no panels"),
            PlotError::TooSmall { width, height } => {
                write!(f, "figure size {width}×{height} px is too small (at least 120×80 px per panel)")
            }
            PlotError::LengthMismatch { panel, series, x_len, y_len } => {
                write!(f, "{panel}, series \"{series}\": x has {x_len} values but y has {y_len}")
            }
            PlotError::NonPositiveOnLog { panel, series, axis, index, value } => write!(
                f,
                "{panel}, series \"{series}\": {axis}[{index}] = {value} cannot be shown on the logarithmic {axis} axis \
                 (values must be > 0; remove such points or use a linear axis)"
            ),
            PlotError::BadRange { panel, axis, min, max } => {
                write!(f, "{panel}: {axis} range [{min}, {max}] is not a finite interval with min < max")?;
                write!(f, " (and min > 0 on a logarithmic axis)")
            }
            PlotError::DataRange { panel, axis, min, max } => write!(
                f,
                "{panel}: the {axis} data span [{min}, {max}] cannot be drawn (too wide to subtract, or narrower than \
                 1e-290); fix the {axis} range"
            ),
            PlotError::SharedScaleMismatch { panel } => {
                write!(f, "{panel}: its x scale differs from the first panel's, but the figure shares the x axis")
            }
            PlotError::BadGrid { panel, reason } => write!(f, "{panel}, grid: {reason}"),
        }
    }
}

impl std::error::Error for PlotError {}

/// Line or markers-only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SeriesKind {
    Line,
    Scatter,
}

/// Marker choice of a series.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MarkerChoice {
    /// Lines: none. Scatter: the next shape of [`Marker::CYCLE`].
    Default,
    /// The next shape of [`Marker::CYCLE`] (counted over the panel's series).
    Auto,
    Fixed(Marker),
    Off,
}

/// One data series: a polyline (optionally with markers) or a scatter of markers.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    name: String,
    x: Vec<f64>,
    y: Vec<f64>,
    kind: SeriesKind,
    color: Option<Color>,
    width: f64,
    dash: Dash,
    marker: MarkerChoice,
    marker_size: f64,
}

impl Series {
    /// A line through `(x[i], y[i])`; an empty name keeps it out of the legend.
    pub fn line(name: &str, x: &[f64], y: &[f64]) -> Self {
        Self {
            name: name.to_owned(),
            x: x.to_vec(),
            y: y.to_vec(),
            kind: SeriesKind::Line,
            color: None,
            width: 1.5,
            dash: Dash::Solid,
            marker: MarkerChoice::Default,
            marker_size: 7.0,
        }
    }

    /// Markers at `(x[i], y[i])`, no line.
    pub fn scatter(name: &str, x: &[f64], y: &[f64]) -> Self {
        Self { kind: SeriesKind::Scatter, ..Self::line(name, x, y) }
    }

    /// Colour instead of the panel's next palette colour.
    pub fn color(mut self, color: Color) -> Self {
        self.color = Some(color);
        self
    }

    /// Line width in pixels (default 1.5).
    pub fn width(mut self, px: f64) -> Self {
        self.width = if px.is_finite() && px > 0.0 { px } else { 1.5 };
        self
    }

    pub fn dash(mut self, dash: Dash) -> Self {
        self.dash = dash;
        self
    }

    /// Markers of this shape at every point (lines too).
    pub fn marker(mut self, marker: Marker) -> Self {
        self.marker = MarkerChoice::Fixed(marker);
        self
    }

    /// Markers at every point, shape picked from [`Marker::CYCLE`] by the series' position.
    pub fn auto_marker(mut self) -> Self {
        self.marker = MarkerChoice::Auto;
        self
    }

    /// No markers (also for scatter series, which then draw nothing but their legend entry).
    pub fn no_marker(mut self) -> Self {
        self.marker = MarkerChoice::Off;
        self
    }

    /// Marker size in pixels (bounding box, default 7).
    pub fn marker_size(mut self, px: f64) -> Self {
        self.marker_size = if px.is_finite() && px > 0.0 { px } else { 7.0 };
        self
    }
}

/// A categorical heat map over cells centred at `x[i]`, `y[j]` (e.g. macro step × mass ratio
/// coloured stable/unstable), each cell optionally annotated with text.
///
/// Cell edges lie halfway between neighbouring centres in axis coordinates (geometric means on
/// a log axis); the outer cells are as wide as their neighbours. Cells never set stay blank.
/// Unless the panel sets its own ticks, the grid's axes get one tick per centre.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    x: Vec<f64>,
    y: Vec<f64>,
    categories: Vec<(String, Color)>,
    cells: Vec<GridCell>,
}

#[derive(Clone, Debug, PartialEq)]
struct GridCell {
    ix: usize,
    iy: usize,
    category: usize,
    text: String,
}

impl Grid {
    pub fn new(x_centres: &[f64], y_centres: &[f64]) -> Self {
        Self { x: x_centres.to_vec(), y: y_centres.to_vec(), categories: Vec::new(), cells: Vec::new() }
    }

    /// Adds a category (legend entry and cell colour); categories are numbered 0, 1, … in the
    /// order they are added.
    pub fn category(mut self, name: &str, color: Color) -> Self {
        self.categories.push((name.to_owned(), color));
        self
    }

    /// Colours cell (`ix`, `iy`) with `category` and writes `text` in it (empty for none).
    /// Indices are checked when the figure is drawn.
    pub fn set(&mut self, ix: usize, iy: usize, category: usize, text: &str) -> &mut Self {
        self.cells.push(GridCell { ix, iy, category, text: text.to_owned() });
        self
    }
}

/// Tick placement of one axis.
#[derive(Clone, Debug, PartialEq, Default)]
enum TickChoice {
    #[default]
    Auto,
    /// At these values, labelled with the value.
    At(Vec<f64>),
    /// At these values with these labels.
    Labelled(Vec<(f64, String)>),
}

/// A horizontal or vertical reference line across the plot (e.g. "1 % of peak").
#[derive(Clone, Debug, PartialEq)]
struct RefLine {
    axis: Axis,
    value: f64,
    label: String,
}

/// Settings of one axis of a panel.
#[derive(Clone, Debug, PartialEq, Default)]
struct AxisSpec {
    label: String,
    scale: Scale,
    range: Option<(f64, f64)>,
    ticks: TickChoice,
}

/// One plot area with its axes, series and legend. Built through [`Figure::panel`].
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Panel {
    title: String,
    x: AxisSpec,
    y: AxisSpec,
    legend: Legend,
    series: Vec<Series>,
    grid: Option<Grid>,
    ref_lines: Vec<RefLine>,
}

impl Panel {
    pub fn title(&mut self, title: &str) -> &mut Self {
        self.title = title.to_owned();
        self
    }

    /// x-axis label, units included (e.g. `"t [s]"`).
    pub fn x_label(&mut self, label: &str) -> &mut Self {
        self.x.label = label.to_owned();
        self
    }

    /// y-axis label, units included (e.g. `"Δy [mm]"`).
    pub fn y_label(&mut self, label: &str) -> &mut Self {
        self.y.label = label.to_owned();
        self
    }

    pub fn x_scale(&mut self, scale: Scale) -> &mut Self {
        self.x.scale = scale;
        self
    }

    pub fn y_scale(&mut self, scale: Scale) -> &mut Self {
        self.y.scale = scale;
        self
    }

    /// Fixes the x range (no padding); data outside is clipped.
    pub fn x_range(&mut self, min: f64, max: f64) -> &mut Self {
        self.x.range = Some((min, max));
        self
    }

    /// Fixes the y range (no padding); data outside is clipped.
    pub fn y_range(&mut self, min: f64, max: f64) -> &mut Self {
        self.y.range = Some((min, max));
        self
    }

    /// x ticks at exactly these values (labelled with the value; those outside the range are
    /// dropped).
    pub fn x_ticks(&mut self, values: &[f64]) -> &mut Self {
        self.x.ticks = TickChoice::At(values.to_vec());
        self
    }

    /// y ticks at exactly these values.
    pub fn y_ticks(&mut self, values: &[f64]) -> &mut Self {
        self.y.ticks = TickChoice::At(values.to_vec());
        self
    }

    /// x ticks at these values with these labels.
    pub fn x_tick_labels(&mut self, ticks: &[(f64, &str)]) -> &mut Self {
        self.x.ticks = TickChoice::Labelled(ticks.iter().map(|&(v, s)| (v, s.to_owned())).collect());
        self
    }

    /// y ticks at these values with these labels.
    pub fn y_tick_labels(&mut self, ticks: &[(f64, &str)]) -> &mut Self {
        self.y.ticks = TickChoice::Labelled(ticks.iter().map(|&(v, s)| (v, s.to_owned())).collect());
        self
    }

    pub fn legend(&mut self, legend: Legend) -> &mut Self {
        self.legend = legend;
        self
    }

    /// Adds a line series with default style.
    pub fn line(&mut self, name: &str, x: &[f64], y: &[f64]) -> &mut Self {
        self.add(Series::line(name, x, y))
    }

    /// Adds a scatter series with default style.
    pub fn scatter(&mut self, name: &str, x: &[f64], y: &[f64]) -> &mut Self {
        self.add(Series::scatter(name, x, y))
    }

    /// Adds a styled series.
    pub fn add(&mut self, series: Series) -> &mut Self {
        self.series.push(series);
        self
    }

    /// Sets the panel's heat-map grid (one per panel; a second call replaces the first).
    pub fn grid(&mut self, grid: Grid) -> &mut Self {
        self.grid = Some(grid);
        self
    }

    /// A dashed horizontal reference line at `y`, labelled at its right end.
    pub fn hline(&mut self, y: f64, label: &str) -> &mut Self {
        self.ref_lines.push(RefLine { axis: Axis::Y, value: y, label: label.to_owned() });
        self
    }

    /// A dashed vertical reference line at `x`, labelled at its top.
    pub fn vline(&mut self, x: f64, label: &str) -> &mut Self {
        self.ref_lines.push(RefLine { axis: Axis::X, value: x, label: label.to_owned() });
        self
    }
}

/// A figure: panels in rows (and optionally columns), written as one standalone SVG.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    width: u32,
    height: u32,
    title: String,
    share_x: bool,
    columns: usize,
    panels: Vec<Panel>,
}

impl Figure {
    /// An empty figure of `width_px` × `height_px` pixels.
    pub fn new(width_px: u32, height_px: u32) -> Self {
        Self {
            width: width_px,
            height: height_px,
            title: String::new(),
            share_x: false,
            columns: 1,
            panels: Vec::new(),
        }
    }

    /// Title above all panels.
    pub fn title(&mut self, title: &str) -> &mut Self {
        self.title = title.to_owned();
        self
    }

    /// Panels share one x range; only the bottom panel of each column shows x tick labels and
    /// the x label (taken from the first panel that has one).
    pub fn share_x(&mut self, share: bool) -> &mut Self {
        self.share_x = share;
        self
    }

    /// Lays the panels out row by row in `n` columns (default 1: stacked vertically).
    pub fn columns(&mut self, n: usize) -> &mut Self {
        self.columns = n.max(1);
        self
    }

    /// Adds a panel built by `build`, e.g. `fig.panel(|p| p.title("X").line("dx", &t, &dx))`.
    pub fn panel(&mut self, build: impl FnOnce(&mut Panel) -> &mut Panel) -> &mut Self {
        let mut panel = Panel::default();
        build(&mut panel);
        self.panels.push(panel);
        self
    }

    /// The figure as a standalone SVG document.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        render::render(self)
    }

    /// Writes the figure to `path`; a figure that cannot be drawn is an
    /// [`io::ErrorKind::InvalidInput`] error carrying the [`PlotError`].
    pub fn write_svg(&self, path: impl AsRef<Path>) -> io::Result<()> {
        let svg = self.to_svg_string().map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        std::fs::write(path, svg)
    }
}
