//! The net drawn in 3-D as SVG: parallel projections of a [`Frame`] (an oblique view and the
//! three orthographic ones), each element coloured by its tension with a colour bar
//! ([`net_figure`]), and mode shapes over the equilibrium as small multiples ([`modes_figure`]).
//! Every view keeps one metre the same on both screen axes.

use feedcore::Vec3;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::net::{Frame, Layout, by_azimuth};
use crate::plot::{PALETTE, PlotError};

const FONT: &str = "sans-serif";
const GREY: RGBColor = RGBColor(150, 150, 150);
const LIGHT: RGBColor = RGBColor(205, 205, 205);
const SLACK: RGBColor = RGBColor(213, 94, 0);

/// A parallel projection: screen right and up as world directions.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub name: &'static str,
    right: Vec3,
    up: Vec3,
    /// Axis labels of an orthographic view (none for the oblique one).
    labels: Option<(&'static str, &'static str)>,
}

impl View {
    /// Looking from azimuth `azimuth_deg` (from the x axis towards y) and `elevation_deg` above
    /// the horizon.
    pub fn oblique(name: &'static str, azimuth_deg: f64, elevation_deg: f64) -> View {
        let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let towards = Vec3::new(a.cos() * e.cos(), a.sin() * e.cos(), e.sin());
        let right = Vec3::z().cross(&towards).normalize();
        View { name, right, up: towards.cross(&right), labels: None }
    }

    pub const PLAN: View = View {
        name: "plan (x–y)",
        right: Vec3::new(1.0, 0.0, 0.0),
        up: Vec3::new(0.0, 1.0, 0.0),
        labels: Some(("x (m)", "y (m)")),
    };
    pub const FRONT: View = View {
        name: "front (x–z)",
        right: Vec3::new(1.0, 0.0, 0.0),
        up: Vec3::new(0.0, 0.0, 1.0),
        labels: Some(("x (m)", "z (m)")),
    };
    pub const SIDE: View = View {
        name: "side (y–z)",
        right: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::new(0.0, 0.0, 1.0),
        labels: Some(("y (m)", "z (m)")),
    };

    /// Screen coordinates (m) of a world point.
    pub fn project(&self, p: &Vec3) -> (f64, f64) {
        (self.right.dot(p), self.up.dot(p))
    }
}

/// The oblique view of the figures.
pub fn oblique() -> View {
    View::oblique("oblique view", -60.0, 25.0)
}

/// The tension scale: a colour for each force between the smallest and the largest.
#[derive(Clone, Copy, Debug)]
pub struct TensionScale {
    pub min: f64,
    pub max: f64,
}

impl TensionScale {
    pub fn of(tensions: &[f64]) -> TensionScale {
        let (min, max) = tensions.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| (a.min(t), b.max(t)));
        if !(min <= max) {
            return TensionScale { min: 0.0, max: 1.0 };
        }
        if max - min <= 1e-9 * max.abs() {
            return TensionScale { min: min - 1.0, max: max + 1.0 };
        }
        TensionScale { min, max }
    }

    /// Viridis from dark (small) to light (large), short of its palest yellow, which would
    /// vanish on white.
    pub fn colour(&self, t: f64) -> RGBColor {
        let h = ((t - self.min) / (self.max - self.min)).clamp(0.0, 1.0) * 0.88;
        ViridisRGB::get_color(h)
    }
}

/// How a cable is marked: taut, nearly slack (it sags below its cabin end), slack (an element
/// shorter than unstretched).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    Taut,
    NearlySlack,
    Slack,
}

/// Everything a panel draws of one frame.
struct Scene3d<'a> {
    layout: &'a Layout,
    frame: &'a Frame,
}

impl Scene3d<'_> {
    fn cable(&self, i: usize) -> &[Vec3] {
        let n = self.layout.points_per_cable();
        &self.frame.points[i * n..(i + 1) * n]
    }

    /// Every point a view must show (the net, the towers' feet, the bodies).
    fn extent_points(&self) -> Vec<Vec3> {
        let mut pts = self.frame.points.clone();
        pts.extend(self.layout.anchors.iter().map(|a| Vec3::new(a.x, a.y, 0.0)));
        pts.extend(self.body_points());
        pts
    }

    /// The cabin's outline and the platform's points.
    fn body_points(&self) -> Vec<Vec3> {
        let mut pts: Vec<Vec3> = self.layout.attachments.iter().map(|a| self.frame.on_cabin(a)).collect();
        if let Some(p) = &self.layout.platform {
            let placed = self.frame.place(p);
            pts.extend(placed.base_joints);
            pts.extend(placed.platform_joints);
            pts.push(placed.feed);
        }
        pts
    }
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn draw_error<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    e.into()
}

/// A chart on `area` showing the projected `points` at one scale on both axes.
fn equal_chart<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>,
    view: &View,
    caption: &str,
    points: &[Vec3],
) -> Result<Chart<'a, 'b>, PlotError> {
    let area = area.titled(caption, (FONT, 14)).map_err(draw_error)?;
    let (w, h) = area.dim_in_pixel();
    let (margin, x_area, y_area) = if view.labels.is_some() { (6, 34, 46) } else { (6, 0, 0) };
    let (pw, ph) = (
        (w as f64 - 2.0 * margin as f64 - y_area as f64).max(10.0),
        (h as f64 - 2.0 * margin as f64 - x_area as f64).max(10.0),
    );
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for p in points {
        let (x, y) = view.project(p);
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let pad = 0.05 * (x1 - x0).max(y1 - y0).max(1e-3);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    // metres per pixel: the larger of what either axis needs
    let scale = ((x1 - x0 + 2.0 * pad) / pw).max((y1 - y0 + 2.0 * pad) / ph);
    let (hx, hy) = (0.5 * scale * pw, 0.5 * scale * ph);
    let mut chart = ChartBuilder::on(&area)
        .margin(margin)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area)
        .build_cartesian_2d((cx - hx)..(cx + hx), (cy - hy)..(cy + hy))
        .map_err(draw_error)?;
    if let Some((xl, yl)) = view.labels {
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(xl)
            .y_desc(yl)
            .x_labels(6)
            .y_labels(6)
            .label_style((FONT, 11))
            .axis_desc_style((FONT, 12))
            .draw()
            .map_err(draw_error)?;
    }
    Ok(chart)
}

fn segment(chart: &mut Chart<'_, '_>, view: &View, a: &Vec3, b: &Vec3, style: ShapeStyle) -> Result<(), PlotError> {
    chart
        .draw_series(std::iter::once(PathElement::new(vec![view.project(a), view.project(b)], style)))
        .map_err(draw_error)?;
    Ok(())
}

fn polygon(chart: &mut Chart<'_, '_>, view: &View, pts: &[Vec3], style: ShapeStyle) -> Result<(), PlotError> {
    let mut path: Vec<(f64, f64)> = pts.iter().map(|p| view.project(p)).collect();
    if let Some(&first) = path.first() {
        path.push(first);
    }
    chart.draw_series(std::iter::once(PathElement::new(path, style))).map_err(draw_error)?;
    Ok(())
}

/// The bodies of a frame: the cabin's outlines (through the attachment points and through the
/// legs' joints on it), the legs, the platform and the feed point; each world point through
/// `moved` (a mode shape's linear motion; the identity for the frame itself).
fn draw_bodies(
    chart: &mut Chart<'_, '_>,
    view: &View,
    s: &Scene3d<'_>,
    moved: &dyn Fn(Vec3) -> Vec3,
    colour: RGBColor,
    width: u32,
) -> Result<(), PlotError> {
    let cabin: Vec<Vec3> =
        s.layout.cabin_outline().iter().map(|&i| moved(s.frame.on_cabin(&s.layout.attachments[i]))).collect();
    polygon(chart, view, &cabin, BLACK.stroke_width(width))?;
    if let Some(p) = &s.layout.platform {
        let placed = s.frame.place(p);
        let base: Vec<Vec3> = by_azimuth(&p.base_joints).iter().map(|&k| moved(placed.base_joints[k])).collect();
        polygon(chart, view, &base, BLACK.stroke_width(width))?;
        for k in 0..placed.base_joints.len() {
            let (a, b) = (moved(placed.base_joints[k]), moved(placed.platform_joints[k]));
            segment(chart, view, &a, &b, colour.stroke_width(width))?;
        }
        let ring: Vec<Vec3> =
            by_azimuth(&p.platform_joints).iter().map(|&k| moved(placed.platform_joints[k])).collect();
        polygon(chart, view, &ring, colour.stroke_width(width))?;
        let f = view.project(&moved(placed.feed));
        chart.draw_series(std::iter::once(Circle::new(f, 3, colour.filled()))).map_err(draw_error)?;
    }
    Ok(())
}

/// One panel of the net: towers, anchors, cables by tension (slack elements dashed), bodies.
fn net_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    view: &View,
    caption: &str,
    s: &Scene3d<'_>,
    scale: &TensionScale,
    marks: &[Mark],
    close_up: bool,
) -> Result<(), PlotError> {
    let extent = if close_up { s.body_points() } else { s.extent_points() };
    let mut chart = equal_chart(area, view, caption, &extent)?;
    if !close_up {
        for a in &s.layout.anchors {
            segment(&mut chart, view, &Vec3::new(a.x, a.y, 0.0), a, GREY.stroke_width(3))?;
            let p = view.project(a);
            chart.draw_series(std::iter::once(TriangleMarker::new(p, 5, BLACK.filled()))).map_err(draw_error)?;
        }
    }
    let n = s.layout.elements;
    for i in 0..s.layout.cables {
        let pts = s.cable(i);
        for e in 0..n {
            let t = s.frame.tensions[i * n + e];
            let (a, b) = (view.project(&pts[e]), view.project(&pts[e + 1]));
            if t == 0.0 {
                chart
                    .draw_series(DashedLineSeries::new(vec![a, b], 4, 3, SLACK.stroke_width(2)))
                    .map_err(draw_error)?;
            } else {
                chart
                    .draw_series(std::iter::once(PathElement::new(vec![a, b], scale.colour(t).stroke_width(2))))
                    .map_err(draw_error)?;
            }
        }
        if !close_up && marks.get(i).is_some_and(|m| *m != Mark::Taut) {
            // the label at the cable's lowest point
            let low = pts.iter().min_by(|a, b| a.z.total_cmp(&b.z)).expect("a cable has points");
            let text = if marks[i] == Mark::Slack { format!("{i}: SLACK") } else { format!("{i}: nearly slack") };
            let style = TextStyle::from((FONT, 11).into_font()).color(&SLACK);
            chart.draw_series(std::iter::once(Text::new(text, view.project(low), style))).map_err(draw_error)?;
        }
    }
    draw_bodies(&mut chart, view, s, &|p| p, PALETTE[0], if close_up { 2 } else { 1 })?;
    Ok(())
}

/// The colour bar of the tensions, kN, on `area`.
fn colour_bar(area: &DrawingArea<SVGBackend<'_>, Shift>, scale: &TensionScale) -> Result<(), PlotError> {
    let (_, h) = area.dim_in_pixel();
    let (top, bottom, left) = (60i32, h as i32 - 60, 16i32);
    let steps = 60;
    for k in 0..steps {
        let y0 = bottom - (bottom - top) * k / steps;
        let y1 = bottom - (bottom - top) * (k + 1) / steps;
        let t = scale.min + (scale.max - scale.min) * (k as f64 + 0.5) / steps as f64;
        area.draw(&Rectangle::new([(left, y1), (left + 22, y0)], scale.colour(t).filled())).map_err(draw_error)?;
    }
    area.draw(&Rectangle::new([(left, top), (left + 22, bottom)], GREY.stroke_width(1))).map_err(draw_error)?;
    for k in 0..=4 {
        let t = scale.min + (scale.max - scale.min) * k as f64 / 4.0;
        let y = bottom - (bottom - top) * k / 4;
        area.draw(&Text::new(format!("{:.2}", t / 1e3), (left + 27, y - 6), (FONT, 11).into_font()))
            .map_err(draw_error)?;
    }
    area.draw(&Text::new("tension (kN)", (4, top - 30), (FONT, 12).into_font())).map_err(draw_error)?;
    Ok(())
}

/// The net of one frame: the oblique view, plan, front and side, and a close-up of the cabin
/// and the platform; each element coloured by its tension (a colour bar of the range), slack
/// elements dashed, slack and nearly slack cables labelled. `notes`: lines printed under the
/// legend.
pub fn net_figure(
    title: &str,
    layout: &Layout,
    frame: &Frame,
    marks: &[Mark],
    notes: &[String],
) -> Result<String, PlotError> {
    check_frame(layout, frame)?;
    let s = Scene3d { layout, frame };
    let scale = TensionScale::of(&frame.tensions);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1220, 830)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let root = root.titled(title, (FONT, 18)).map_err(draw_error)?;
        let (panels, bar) = root.split_horizontally(1110);
        colour_bar(&bar, &scale)?;
        let areas = panels.split_evenly((2, 3));
        let views = [
            (oblique(), "oblique view", false),
            (View::PLAN, View::PLAN.name, false),
            (oblique(), "cabin and platform (oblique)", true),
            (View::FRONT, View::FRONT.name, false),
            (View::SIDE, View::SIDE.name, false),
        ];
        for ((view, caption, close), area) in views.iter().zip(areas.iter()) {
            net_panel(area, view, caption, &s, &scale, marks, *close)?;
        }
        legend(&areas[5], notes)?;
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

fn legend(area: &DrawingArea<SVGBackend<'_>, Shift>, notes: &[String]) -> Result<(), PlotError> {
    let font = (FONT, 12).into_font();
    let mut y = 40;
    let mut line = |area: &DrawingArea<SVGBackend<'_>, Shift>,
                    key: &dyn Fn(i32) -> Result<(), PlotError>,
                    text: &str|
     -> Result<(), PlotError> {
        key(y)?;
        area.draw(&Text::new(text.to_string(), (50, y - 6), font.clone())).map_err(draw_error)?;
        y += 22;
        Ok(())
    };
    let stroke = |c: RGBColor, w: u32| {
        move |y: i32| area.draw(&PathElement::new(vec![(14, y), (40, y)], c.stroke_width(w))).map_err(draw_error)
    };
    line(
        area,
        &|y| area.draw(&TriangleMarker::new((27, y), 5, BLACK.filled())).map_err(draw_error),
        "anchor (tower top)",
    )?;
    line(area, &stroke(GREY, 3), "tower")?;
    line(area, &stroke(ViridisRGB::get_color(0.5), 2), "cable element, by its tension")?;
    line(
        area,
        &|y| {
            area.draw(&PathElement::new(vec![(14, y), (22, y)], SLACK.stroke_width(2)))
                .and_then(|_| area.draw(&PathElement::new(vec![(28, y), (36, y)], SLACK.stroke_width(2))))
                .map_err(draw_error)
        },
        "slack element",
    )?;
    line(area, &stroke(BLACK, 2), "cabin (attachment and joint rings)")?;
    line(area, &stroke(PALETTE[0], 2), "platform and legs")?;
    line(area, &|y| area.draw(&Circle::new((27, y), 3, PALETTE[0].filled())).map_err(draw_error), "feed point")?;
    y += 8;
    for n in notes {
        area.draw(&Text::new(n.clone(), (14, y - 6), font.clone())).map_err(draw_error)?;
        y += 18;
    }
    Ok(())
}

fn check_frame(layout: &Layout, frame: &Frame) -> Result<(), PlotError> {
    let (points, elements) = (layout.cables * layout.points_per_cable(), layout.cables * layout.elements);
    if frame.points.len() != points || frame.tensions.len() != elements {
        return Err(PlotError::Data(format!(
            "the frame has {} points and {} tensions; the layout {points} and {elements}",
            frame.points.len(),
            frame.tensions.len()
        )));
    }
    if let Some(p) = frame.points.iter().find(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(PlotError::Data(format!("a point of the net is not finite: {p:?}")));
    }
    Ok(())
}

/// One mode shape: its caption, the cable points displaced along it and the cabin's motion
/// (δr, δθ), both already scaled.
pub struct ModeShape {
    pub caption: String,
    pub points: Vec<Vec3>,
    pub cabin: (Vec3, Vec3),
}

/// The mode shapes over the equilibrium `rest`, in the oblique view, three to a row: the
/// equilibrium in light grey, each shape displaced over it (linearly, the bodies by the
/// cabin's motion `δr + δθ × (p − r)`, the platform locked on the cabin).
pub fn modes_figure(title: &str, layout: &Layout, rest: &Frame, modes: &[ModeShape]) -> Result<String, PlotError> {
    check_frame(layout, rest)?;
    for m in modes {
        let moved = Frame { points: m.points.clone(), ..rest.clone() };
        check_frame(layout, &moved)?;
    }
    let view = oblique();
    let columns = modes.len().clamp(1, 3);
    let rows = modes.len().div_ceil(3).max(1);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (400 * columns as u32, 340 * rows as u32 + 40)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        let root = root.titled(title, (FONT, 17)).map_err(draw_error)?;
        let areas = root.split_evenly((rows, columns));
        let still = Scene3d { layout, frame: rest };
        for (m, area) in modes.iter().zip(areas.iter()) {
            let (dr, dth) = m.cabin;
            let centre = rest.cabin.0;
            let moved = move |p: Vec3| p + dr + dth.cross(&(p - centre));
            let mut extent = still.extent_points();
            extent.extend(m.points.iter().copied());
            extent.extend(still.body_points().into_iter().map(moved));
            let mut chart = equal_chart(area, &view, &m.caption, &extent)?;
            for a in &layout.anchors {
                segment(&mut chart, &view, &Vec3::new(a.x, a.y, 0.0), a, LIGHT.stroke_width(2))?;
            }
            let n = layout.points_per_cable();
            for i in 0..layout.cables {
                let p: Vec<(f64, f64)> = still.cable(i).iter().map(|x| view.project(x)).collect();
                chart.draw_series(std::iter::once(PathElement::new(p, LIGHT.stroke_width(1)))).map_err(draw_error)?;
            }
            draw_bodies(&mut chart, &view, &still, &|p| p, LIGHT, 1)?;
            for i in 0..layout.cables {
                let p: Vec<(f64, f64)> = m.points[i * n..(i + 1) * n].iter().map(|x| view.project(x)).collect();
                chart
                    .draw_series(std::iter::once(PathElement::new(p, PALETTE[1].stroke_width(2))))
                    .map_err(draw_error)?;
            }
            draw_bodies(&mut chart, &view, &still, &moved, PALETTE[0], 2)?;
        }
        root.present().map_err(draw_error)?;
    }
    Ok(svg)
}

/// `master statics --plot`: the net at the static equilibrium of the scene's target pose (the
/// platform locked at its start).
pub fn statics_figure(statics: &crate::report::Statics) -> Result<String, PlotError> {
    use cable::statics::CableState;
    let layout = Layout::of(&statics.scene);
    let eq = &statics.equilibrium;
    let (_, frame) = crate::net::equilibrium_frame(&statics.scene, &layout, eq);
    let marks: Vec<Mark> = eq
        .cables
        .iter()
        .map(|c| match c.state {
            CableState::Taut => Mark::Taut,
            CableState::NearlySlack => Mark::NearlySlack,
            CableState::Slack => Mark::Slack,
        })
        .collect();
    let scale = TensionScale::of(&frame.tensions);
    let mut notes = vec![format!("element tensions {:.2} to {:.2} kN", scale.min / 1e3, scale.max / 1e3)];
    for (i, m) in marks.iter().enumerate() {
        match m {
            Mark::Taut => {}
            Mark::NearlySlack => notes.push(format!("cable {i}: nearly slack (sags below its cabin end)")),
            Mark::Slack => notes.push(format!("cable {i}: SLACK")),
        }
    }
    if notes.len() == 1 {
        notes.push("every cable taut".into());
    }
    let title =
        format!("{}: the net at the static equilibrium ({} elements per cable)", statics.scene.name, layout.elements);
    net_figure(&title, &layout, &frame, &marks, &notes)
}

/// `master modes --plot`: each mode's shape over the equilibrium, scaled so that its largest
/// motion is drawn as a twentieth of the net's size.
pub fn modes_figure_of(modal: &crate::report::Modal) -> Result<String, PlotError> {
    let model = &modal.model;
    let found = model.modes.as_ref().ok_or_else(|| PlotError::Data("no modes were computed".into()))?;
    let layout = Layout::of(&modal.scene);
    let system = model.system(cable::model::Payload::Locked);
    let cfg = model.equilibrium_config();
    let rest = Frame::of_equilibrium(&layout, &system, &model.equilibrium);
    let extent = Scene3d { layout: &layout, frame: &rest }.extent_points();
    let (lo, hi) = extent.iter().fold((extent[0], extent[0]), |(a, b), p| (a.inf(p), b.sup(p)));
    let drawn = 0.05 * (hi - lo).norm();
    let shapes: Vec<ModeShape> = modal
        .modes
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let shape = &found.shapes[k];
            let largest = crate::net::largest_motion(&system, &cfg, shape);
            let s = if largest > 0.0 { drawn / largest } else { 0.0 };
            ModeShape {
                caption: format!(
                    "mode {}: {:.4} Hz, period {:.3} s, cabin share {:.2}",
                    k + 1,
                    m.frequency_hz,
                    1.0 / m.frequency_hz,
                    m.cabin_share
                ),
                points: crate::net::moved_points(&rest, &system, &cfg, shape, s),
                cabin: {
                    let (dr, dth) = crate::net::cabin_motion(&system, shape);
                    (dr * s, dth * s)
                },
            }
        })
        .collect();
    let title = format!(
        "{}: mode shapes over the static equilibrium (grey; largest motion of each drawn {:.2} m)",
        modal.scene.name, drawn
    );
    modes_figure(&title, &layout, &rest, &shapes)
}
