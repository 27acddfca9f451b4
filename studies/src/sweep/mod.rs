//! Sweeps over the workspace and the parameters: for every point of a grid (cabin positions,
//! the platform's mass factor, the macro step) the statics (feasible, smallest and largest
//! cable tension, slack cables), the first natural frequencies and, if asked, a short coupled
//! run. Points are independent: they run on every core ([`crate::parallel`]) and split into
//! disjoint shards (point i belongs to shard i mod n) that [`table::merge`] joins again.
//!
//! * [`grid`](Grid): the axes and their values, and the scene of one point;
//! * [`table`]: the CSV of a sweep or of a shard, and the merge;
//! * [`map`]: the workspace maps (tension margin and first frequency).

pub mod map;
pub mod table;

use std::fmt;
use std::path::Path;
use std::time::Instant;

use cable::model::CableCabin;
use cable::net::CableNet;
use cable::statics::{CableState, StaticsError, form_find};
use feedcore::Vec3;
use feedcore::scene::{Scene, ValidScene};
use thiserror::Error;

use crate::limits::Limits;
use crate::simulate::{Method, Run};

#[derive(Debug, Error)]
pub enum SweepError {
    #[error("--grid {spec}: {reason}")]
    Grid { spec: String, reason: String },
    #[error("--surface {spec}: {reason}")]
    Surface { spec: String, reason: String },
    #[error("--shard {spec}: {reason}")]
    Shard { spec: String, reason: String },
    #[error("{file}: {reason}")]
    Table { file: String, reason: String },
    #[error("merge: {0}")]
    Merge(String),
    #[error("{file}: {source}")]
    Io { file: String, source: std::io::Error },
}

/// A quantity the sweep varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// World position of the cabin centre point (m).
    X,
    Y,
    Z,
    /// Factor on every mass and inertia of the Stewart platform.
    Mass,
    /// Macro step of the coupled run (s).
    Dt,
}

impl Axis {
    const ALL: [Axis; 5] = [Axis::X, Axis::Y, Axis::Z, Axis::Mass, Axis::Dt];

    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
            Axis::Mass => "mass",
            Axis::Dt => "dt",
        }
    }

    /// CSV column.
    pub fn column(self) -> &'static str {
        match self {
            Axis::X => "x_m",
            Axis::Y => "y_m",
            Axis::Z => "z_m",
            Axis::Mass => "mass_factor",
            Axis::Dt => "dt_s",
        }
    }

    /// Plot label.
    pub fn label(self) -> &'static str {
        match self {
            Axis::X => "cabin x (m)",
            Axis::Y => "cabin y (m)",
            Axis::Z => "cabin z (m)",
            Axis::Mass => "platform mass factor",
            Axis::Dt => "macro step h (s)",
        }
    }
}

/// One axis of the grid and its values.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisValues {
    pub axis: Axis,
    pub values: Vec<f64>,
}

/// The points of a sweep: every combination of the axes' values, the first axis varying
/// slowest.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub axes: Vec<AxisValues>,
}

impl Grid {
    /// Parses axes given as `name=start:stop:count` (evenly spaced, both ends included) or
    /// `name=v1,v2,...`; names: x, y, z (m), mass (factor), dt (s).
    pub fn parse(specs: &[String]) -> Result<Grid, SweepError> {
        let mut axes: Vec<AxisValues> = Vec::new();
        for spec in specs {
            let err = |reason: &str| SweepError::Grid { spec: spec.clone(), reason: reason.to_string() };
            let (name, list) =
                spec.split_once('=').ok_or_else(|| err("give `name=start:stop:count` or `name=v1,v2,...`"))?;
            let axis = Axis::ALL.into_iter().find(|a| a.name() == name.trim()).ok_or_else(|| {
                err(&format!("unknown axis `{}`; known: x, y, z (m), mass (factor), dt (s)", name.trim()))
            })?;
            if axes.iter().any(|a| a.axis == axis) {
                return Err(err("this axis is given twice"));
            }
            let number = |t: &str| -> Result<f64, SweepError> {
                let x: f64 = t.trim().parse().map_err(|_| err(&format!("`{}` is not a number", t.trim())))?;
                if x.is_finite() { Ok(x) } else { Err(err(&format!("`{}` is not finite", t.trim()))) }
            };
            let values = match list.split(':').collect::<Vec<_>>().as_slice() {
                [a, b, n] => {
                    let (a, b) = (number(a)?, number(b)?);
                    let n: usize =
                        n.trim().parse().map_err(|_| err(&format!("count `{}` is not a whole number", n.trim())))?;
                    match n {
                        0 => return Err(err("the count must be at least 1")),
                        1 => vec![a],
                        _ => (0..n).map(|i| a + (b - a) * i as f64 / (n - 1) as f64).collect(),
                    }
                }
                [_] => list.split(',').map(number).collect::<Result<Vec<_>, _>>()?,
                _ => return Err(err("a range is `start:stop:count`")),
            };
            if matches!(axis, Axis::Mass | Axis::Dt) && values.iter().any(|v| !(*v > 0.0)) {
                return Err(err("mass factors and steps must be positive"));
            }
            axes.push(AxisValues { axis, values });
        }
        Ok(Grid { axes })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The axis values of point `index`.
    pub fn point(&self, index: usize) -> Vec<(Axis, f64)> {
        let mut rest = index;
        let mut out = vec![(Axis::X, 0.0); self.axes.len()];
        for (k, a) in self.axes.iter().enumerate().rev() {
            let n = a.values.len();
            out[k] = (a.axis, a.values[rest % n]);
            rest /= n;
        }
        out
    }

    /// The steps the runs at the points take: the `dt` axis's values, else `scene_dt`.
    pub fn steps(&self, scene_dt: f64) -> Vec<f64> {
        self.axes.iter().find(|a| a.axis == Axis::Dt).map_or(vec![scene_dt], |a| a.values.clone())
    }

    /// The cost of point `index`'s run against one at a unit step, to start the longest first:
    /// in proportion to its steps.
    pub fn cost(&self, index: usize) -> f64 {
        self.point(index).iter().find(|(a, _)| *a == Axis::Dt).map_or(1.0, |(_, dt)| 1.0 / dt)
    }

    /// The axes as `--grid` arguments would give them, joined by spaces (values exactly).
    pub fn describe(&self) -> String {
        let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(",");
        self.axes.iter().map(|a| format!("{}={}", a.axis.name(), list(&a.values))).collect::<Vec<_>>().join(" ")
    }
}

/// One of `count` disjoint parts: point i belongs to part i mod count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// `i/n`, 0 ≤ i < n (a Slurm array `--array=0-(n-1)` passes `$SLURM_ARRAY_TASK_ID/n`).
    pub fn parse(spec: &str) -> Result<Shard, SweepError> {
        let err = |reason: &str| SweepError::Shard { spec: spec.to_string(), reason: reason.to_string() };
        let (i, n) = spec.split_once('/').ok_or_else(|| err("give `i/n`, e.g. 0/4"))?;
        let i: usize = i.trim().parse().map_err(|_| err("`i` is not a whole number"))?;
        let n: usize = n.trim().parse().map_err(|_| err("`n` is not a whole number"))?;
        if n == 0 || i >= n {
            return Err(err("need 0 ≤ i < n"));
        }
        Ok(Shard { index: i, count: n })
    }

    pub fn contains(&self, point: usize) -> bool {
        point % self.count == self.index
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A sphere whose lower half the cabin centre follows (the focal surface): z comes from x, y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub centre: Vec3,
    pub radius: f64,
}

impl Surface {
    /// `cx,cy,cz,r` (m).
    pub fn parse(spec: &str) -> Result<Surface, SweepError> {
        let err = |reason: &str| SweepError::Surface { spec: spec.to_string(), reason: reason.to_string() };
        let v: Vec<f64> = spec
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| err("give the centre and the radius as `cx,cy,cz,r` (m)"))?;
        match v.as_slice() {
            [cx, cy, cz, r] if v.iter().all(|x| x.is_finite()) && *r > 0.0 => {
                Ok(Surface { centre: Vec3::new(*cx, *cy, *cz), radius: *r })
            }
            _ => Err(err("give the centre and a positive radius as `cx,cy,cz,r` (m)")),
        }
    }

    pub fn describe(&self) -> String {
        format!("{:?},{:?},{:?},{:?}", self.centre.x, self.centre.y, self.centre.z, self.radius)
    }
}

/// How a point's scene is made from the base scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// The cabin centre follows this surface (z from x and y).
    pub surface: Option<Surface>,
    /// Tilt the cabin towards the surface's axis by this share of the point's angle from the
    /// axis (seen from the surface's centre); without it the cabin keeps the scene's orientation.
    pub tilt_share: Option<f64>,
}

/// Natural frequencies per point unless asked otherwise, and the most that can be asked.
pub const DEFAULT_MODES: usize = 3;
pub const MAX_MODES: usize = 10_000;
/// Simulated time of a point's run unless asked otherwise, s.
pub const DEFAULT_RUN_S: f64 = 2.0;

/// Natural frequencies per point, as typed: 0 (none) to [`MAX_MODES`].
pub fn mode_count(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n <= MAX_MODES => Ok(n),
        _ => Err(format!("`{text}`: give 0 to {MAX_MODES} modes")),
    }
}

/// The scene of one point and its macro step.
pub fn point_scene(
    base: &ValidScene,
    placement: &Placement,
    values: &[(Axis, f64)],
) -> Result<(ValidScene, f64), String> {
    let mut s = base.to_scene();
    let mut dt = base.solver.dt_s;
    let mut p = Vec3::from(base.pose.position_m);
    for &(axis, v) in values {
        match axis {
            Axis::X => p.x = v,
            Axis::Y => p.y = v,
            Axis::Z => p.z = v,
            Axis::Mass => scale_platform_mass(&mut s, v),
            Axis::Dt => dt = v,
        }
    }
    if let Some(surf) = placement.surface {
        let (dx, dy) = (p.x - surf.centre.x, p.y - surf.centre.y);
        let h2 = surf.radius * surf.radius - dx * dx - dy * dy;
        if h2 < 0.0 {
            return Err(format!("({:.3}, {:.3}) lies outside the surface (radius {} m)", p.x, p.y, surf.radius));
        }
        p.z = surf.centre.z - h2.sqrt();
        if let Some(share) = placement.tilt_share {
            let rho = dx.hypot(dy);
            let zenith = rho.atan2(surf.centre.z - p.z);
            s.pose.orientation_wxyz = None;
            if rho > 0.0 {
                // about Z × (−e_r): the cabin axis leans towards the surface's axis
                s.pose.rotation_axis = Some([dy / rho, -dx / rho, 0.0]);
            } else {
                s.pose.rotation_axis = Some([1.0, 0.0, 0.0]);
            }
            s.pose.rotation_angle_deg = Some((share * zenith).to_degrees());
        }
    }
    s.pose.position_m = [p.x, p.y, p.z];
    Ok((s.validated(&base.name).map_err(|e| e.to_string())?, dt))
}

/// Scales every mass and inertia of the scene's Stewart platform by `f` (an edit: validate the
/// scene afterwards, e.g. through [`ValidScene::edited`]).
pub fn scale_platform_mass(scene: &mut Scene, f: f64) {
    let st = &mut scene.stewart;
    st.platform.mass_kg *= f;
    for row in st.platform.inertia_kg_m2.iter_mut() {
        row.iter_mut().for_each(|x| *x *= f);
    }
    for part in [&mut st.upper_leg, &mut st.lower_leg] {
        part.mass_kg *= f;
        part.inertia_transverse_kg_m2 *= f;
        part.inertia_axial_kg_m2 *= f;
    }
}

/// A cable longer than this many times its chord hangs in a loop (sag/span ≈ 0.4 and more):
/// the form finding found the deep second catenary through the same ends.
pub const DEEP_SAG: f64 = 1.5;

/// What to compute at every point.
#[derive(Clone, Debug)]
pub struct Request {
    /// Natural frequencies reported (0: no eigen solve).
    pub modes: usize,
    /// A coupled run of this length (s) with this method, if any.
    pub run: Option<(Method, f64)>,
    /// Caps of every run (steps, memory).
    pub limits: Limits,
    /// Report `max_utilisation` (the scene gives `cables.breaking_load_n`).
    pub utilisation: bool,
}

/// A short coupled run at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunOutcome {
    /// Largest distance of the cabin centre from its static position (mm).
    pub peak_mm: f64,
    pub mean_iterations: f64,
    pub wall_s: f64,
}

/// The results at one point; `note` says why something is missing.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub feasible: bool,
    pub min_tension_n: f64,
    pub max_tension_n: f64,
    /// The largest tension over the breaking load (NaN without one); above 1 the point is not
    /// feasible.
    pub max_utilisation: f64,
    pub slack_cables: usize,
    pub nearly_slack_cables: usize,
    /// Largest ratio of a cable's unstretched length to its chord.
    pub length_over_chord: f64,
    pub frequencies_hz: Vec<f64>,
    pub run: Option<RunOutcome>,
    pub wall_s: f64,
    pub note: String,
}

/// Evaluates the sweep's point at `values` (`base` read from `base_file`). Never fails: what
/// cannot be computed is left out and named in the note.
pub fn evaluate(
    base: &ValidScene,
    base_file: &Path,
    placement: &Placement,
    request: &Request,
    values: &[(Axis, f64)],
) -> Outcome {
    let start = Instant::now();
    let mut out = Outcome {
        feasible: false,
        min_tension_n: f64::NAN,
        max_tension_n: f64::NAN,
        max_utilisation: f64::NAN,
        slack_cables: 0,
        nearly_slack_cables: 0,
        length_over_chord: f64::NAN,
        frequencies_hz: vec![],
        run: None,
        wall_s: 0.0,
        note: String::new(),
    };
    let finish = |mut out: Outcome, note: String| {
        out.note = note;
        out.wall_s = start.elapsed().as_secs_f64();
        out
    };
    let (scene, dt) = match point_scene(base, placement, values) {
        Ok(x) => x,
        Err(e) => return finish(out, format!("no pose: {e}")),
    };
    let net = CableNet::from_scene(&scene);
    match form_find(&net, scene.target_position(), scene.target_orientation()) {
        Ok(eq) => {
            let ends = || eq.cables.iter().flat_map(|c| [c.tension_anchor, c.tension_cabin]);
            out.min_tension_n = ends().fold(f64::INFINITY, f64::min);
            out.max_tension_n = ends().fold(f64::NEG_INFINITY, f64::max);
            out.slack_cables = eq.cables.iter().filter(|c| c.state == CableState::Slack).count();
            out.nearly_slack_cables = eq.cables.iter().filter(|c| c.state == CableState::NearlySlack).count();
            // The form finding can land on a cable hanging in a deep loop (a second catenary
            // through the same ends): an equilibrium of the model, not a usable pose.
            let (ratio, cable) = eq
                .cables
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    let chord = (net.anchors[i] - (eq.position + eq.orientation * net.attachments[i])).norm();
                    (c.unstretched_length / chord, i)
                })
                .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
            out.length_over_chord = ratio;
            out.max_utilisation = scene.cables.utilisation(out.max_tension_n).unwrap_or(f64::NAN);
            if out.max_utilisation > 1.0 {
                let note = format!(
                    "overloaded: the largest tension {:.0} N is {:.2} times the breaking load (cables.breaking_load_n)",
                    out.max_tension_n, out.max_utilisation
                );
                return finish(out, note);
            }
            if ratio > DEEP_SAG {
                return finish(
                    out,
                    format!(
                        "deep-sag branch: cable {cable} is {ratio:.2} times its chord long and hangs to z = {:.1} m; \
                         not a usable pose",
                        eq.cables[cable].lowest_point_z
                    ),
                );
            }
            out.feasible = true;
        }
        Err(e @ StaticsError::Infeasible { .. }) => return finish(out, e.to_string()),
        Err(e) => return finish(out, format!("statics: {e}")),
    }
    if request.modes > 0 {
        match CableCabin::build(&scene, request.modes) {
            Ok(model) => {
                if let Some(m) = &model.modes {
                    out.frequencies_hz = m.frequencies_hz.iter().take(request.modes).copied().collect();
                }
            }
            Err(e) => return finish(out, format!("modes: {e}")),
        }
    }
    if let Some((method, t_end)) = request.run.clone() {
        let run = Run::prepare(&scene, base_file, method, dt, t_end, &request.limits)
            .and_then(|run| run.execute())
            .map_err(|e| error_chain(&e));
        match run {
            Ok(t) => {
                out.run = Some(RunOutcome {
                    peak_mm: t.peak_mm(),
                    mean_iterations: t.mean_iterations(),
                    wall_s: t.wall_time_s,
                })
            }
            Err(e) => return finish(out, format!("run: {e}")),
        }
    }
    finish(out, String::new())
}

/// An error and its causes on one line (a CSV cell).
fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

/// The CSV columns of a sweep over `grid` with `request`.
pub fn columns(grid: &Grid, request: &Request) -> Vec<String> {
    let mut c = vec!["index".to_string()];
    c.extend(grid.axes.iter().map(|a| a.axis.column().to_string()));
    c.extend(
        ["feasible", "min_tension_n", "max_tension_n", "slack_cables", "nearly_slack_cables", "length_over_chord"]
            .map(String::from),
    );
    if request.utilisation {
        c.push("max_utilisation".into());
    }
    c.extend((1..=request.modes).map(|k| format!("f{k}_hz")));
    if request.run.is_some() {
        c.extend(["run_peak_mm", "run_iterations", "run_wall_s"].map(String::from));
    }
    c.extend(["wall_s", "note"].map(String::from));
    c
}

/// What names a point of the grid: its index and its values.
pub fn point_key(index: usize, values: &[(Axis, f64)]) -> String {
    let mut key = index.to_string();
    for (axis, v) in values {
        key.push_str(&format!(" {}={v:?}", axis.column()));
    }
    key
}

/// Whether `cells` could be the row [`cells`] writes for point `index` at `values` under
/// `columns`: as many cells, the point's own index and values, `feasible` true or false, and
/// every other cell but the note empty or a finite number.
pub fn check_cells(columns: &[String], index: usize, values: &[(Axis, f64)], cells: &[String]) -> Result<(), String> {
    if cells.len() != columns.len() {
        return Err(format!("{} cells for {} columns", cells.len(), columns.len()));
    }
    let expected = cells_of_point(index, values);
    if cells[..expected.len()] != expected[..] {
        return Err(format!("point {index} at {:?}, not {:?}", &cells[..expected.len()], expected));
    }
    for (column, cell) in columns.iter().zip(cells).skip(expected.len()) {
        let fine = match column.as_str() {
            "feasible" => cell == "true" || cell == "false",
            "note" => true,
            _ => cell.is_empty() || cell.parse::<f64>().is_ok_and(f64::is_finite),
        };
        if !fine {
            return Err(format!("{column} = `{cell}`"));
        }
    }
    Ok(())
}

/// The cells that say which point a row is: its index and its values.
fn cells_of_point(index: usize, values: &[(Axis, f64)]) -> Vec<String> {
    std::iter::once(index.to_string()).chain(values.iter().map(|(_, v)| number_cell(*v))).collect()
}

/// A number as a row holds it: its shortest exact form, empty if not finite.
fn number_cell(x: f64) -> String {
    if x.is_finite() { format!("{x:?}") } else { String::new() }
}

/// One CSV row (numbers in their shortest exact form; empty where not computed).
pub fn cells(index: usize, values: &[(Axis, f64)], request: &Request, o: &Outcome) -> Vec<String> {
    let num = number_cell;
    let mut c = cells_of_point(index, values);
    c.push(o.feasible.to_string());
    c.extend([num(o.min_tension_n), num(o.max_tension_n)]);
    if o.min_tension_n.is_finite() {
        c.extend([o.slack_cables.to_string(), o.nearly_slack_cables.to_string()]);
    } else {
        c.extend([String::new(), String::new()]);
    }
    c.push(num(o.length_over_chord));
    if request.utilisation {
        c.push(num(o.max_utilisation));
    }
    c.extend((0..request.modes).map(|k| o.frequencies_hz.get(k).map_or(String::new(), |f| num(*f))));
    if request.run.is_some() {
        match &o.run {
            Some(r) => c.extend([num(r.peak_mm), num(r.mean_iterations), num(r.wall_s)]),
            None => c.extend([String::new(), String::new(), String::new()]),
        }
    }
    c.push(num(o.wall_s));
    c.push(o.note.clone());
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row as [`cells`] writes it passes [`check_cells`]; one cell short or over, another
    /// point's index or value, a non-finite number, a feasibility that is no boolean do not.
    #[test]
    fn only_a_row_the_sweep_could_write_passes_the_check() {
        let g = grid(&["x=-1:1:3", "mass=2,0.5"]).unwrap();
        let request = Request { modes: 2, run: None, limits: Limits::default(), utilisation: false };
        let outcome = Outcome {
            feasible: true,
            min_tension_n: 1.5e3,
            max_tension_n: 4e3,
            max_utilisation: f64::NAN,
            slack_cables: 0,
            nearly_slack_cables: 1,
            length_over_chord: 1.001,
            frequencies_hz: vec![0.46, 0.47],
            run: None,
            wall_s: 0.01,
            note: "a note, with a comma".into(),
        };
        let columns = columns(&g, &request);
        let row = cells(3, &g.point(3), &request, &outcome);
        check_cells(&columns, 3, &g.point(3), &row).unwrap();
        let edited = |at: usize, to: &str| {
            let mut r = row.clone();
            r[at] = to.into();
            r
        };
        let short = row[..row.len() - 1].to_vec();
        let long = [row.clone(), vec!["1".into()]].concat();
        let nan = edited(columns.iter().position(|c| c == "min_tension_n").unwrap(), "NaN");
        let inf = edited(columns.iter().position(|c| c == "f1_hz").unwrap(), "inf");
        let text = edited(columns.iter().position(|c| c == "wall_s").unwrap(), "fast");
        let feasible = edited(columns.iter().position(|c| c == "feasible").unwrap(), "maybe");
        for bad in [short, long, nan, inf, text, feasible, edited(0, "4"), edited(1, "0.5")] {
            assert!(check_cells(&columns, 3, &g.point(3), &bad).is_err(), "{bad:?}");
        }
        assert!(check_cells(&columns, 4, &g.point(4), &row).is_err(), "another point's row");
        // not computed is empty, which passes
        check_cells(&columns, 3, &g.point(3), &edited(columns.iter().position(|c| c == "f2_hz").unwrap(), "")).unwrap();
    }

    fn grid(specs: &[&str]) -> Result<Grid, SweepError> {
        Grid::parse(&specs.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn ranges_include_both_ends_and_lists_keep_their_order() {
        let g = grid(&["x=-1:1:5", "mass=2,0.5"]).unwrap();
        assert_eq!(g.axes[0].values, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(g.axes[1].values, vec![2.0, 0.5]);
        assert_eq!(g.len(), 10);
        // first axis slowest
        assert_eq!(g.point(0), vec![(Axis::X, -1.0), (Axis::Mass, 2.0)]);
        assert_eq!(g.point(1), vec![(Axis::X, -1.0), (Axis::Mass, 0.5)]);
        assert_eq!(g.point(9), vec![(Axis::X, 1.0), (Axis::Mass, 0.5)]);
        // the description parses back to the same grid
        let again = Grid::parse(&g.describe().split(' ').map(String::from).collect::<Vec<_>>()).unwrap();
        assert_eq!(again, g);
    }

    #[test]
    fn bad_axes_are_refused_with_the_argument() {
        for (spec, says) in [
            ("w=1,2", "unknown axis `w`"),
            ("x=1:2", "a range is"),
            ("x=1:2:0", "at least 1"),
            ("x=a,2", "`a` is not a number"),
            ("mass=0,1", "positive"),
            ("dt", "give `name="),
        ] {
            let e = grid(&[spec]).unwrap_err().to_string();
            assert!(e.contains(spec) && e.contains(says), "{spec}: {e}");
        }
        assert!(grid(&["x=1", "x=2"]).unwrap_err().to_string().contains("twice"));
    }

    #[test]
    fn shards_are_disjoint_and_cover_every_point() {
        let n = 5;
        let shards: Vec<Shard> = (0..n).map(|i| Shard::parse(&format!("{i}/{n}")).unwrap()).collect();
        for p in 0..103 {
            assert_eq!(shards.iter().filter(|s| s.contains(p)).count(), 1);
        }
        for bad in ["3/3", "1", "a/2", "0/0"] {
            assert!(Shard::parse(bad).unwrap_err().to_string().contains(bad));
        }
    }

    /// On the focal sphere the point sits at the sphere's lower half and the tilt is the share
    /// of the angle from the axis, leaning towards the axis.
    #[test]
    fn points_on_the_surface_with_their_tilt() {
        let base = Scene::load(format!("{}/../scenes/fast500_centre.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
        let surface = Surface::parse("0,0,300,160").unwrap();
        let placement = Placement { surface: Some(surface), tilt_share: Some(0.35) };
        let r = 160.0 * 40f64.to_radians().sin();
        let (s, _) = point_scene(&base, &placement, &[(Axis::X, 0.0), (Axis::Y, r)]).unwrap();
        let p = s.target_position();
        assert!((p.z - (300.0 - 160.0 * 40f64.to_radians().cos())).abs() < 1e-9);
        let axis = s.target_orientation() * Vec3::z();
        let tilt = axis.angle(&Vec3::z()).to_degrees();
        assert!((tilt - 14.0).abs() < 1e-9, "tilt {tilt}");
        assert!(axis.y < 0.0, "the cabin axis leans towards the surface's axis: {axis:?}");
        let e = point_scene(&base, &placement, &[(Axis::X, 170.0)]).unwrap_err();
        assert!(e.contains("outside the surface"), "{e}");
    }
}
