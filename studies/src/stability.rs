//! Where each coupling scheme is stable, over the mass ratio (the Stewart platform's masses and
//! inertias scaled) and the macro step; iterations per step where it iterates. The map as a
//! table per scheme, CSV and SVG.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::Context;
use cable::net::CableNet;
use cable::statics::{StaticsError, form_find};
use feedcore::scene::ValidScene;

use crate::limits::Limits;
use crate::observe::Observer;
use crate::options::{SchemeName, SchemeOptions};
use crate::plot::{CATEGORY_COLORS, Cell, MapPanel, PlotError, stability_map};
use crate::points::{Codec, Store};
use crate::simulate::{Run, RunError};
use crate::table::Table;

/// What a map is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub schemes: Vec<SchemeName>,
    /// Factors on every mass and inertia of the Stewart platform (1: the scene's platform).
    pub ratios: Vec<f64>,
    /// Macro steps, s.
    pub dts: Vec<f64>,
    /// Simulated time of every run, s.
    pub t_end: f64,
    pub options: SchemeOptions,
    /// Worker threads (`None`: one per core).
    pub jobs: Option<usize>,
    pub limits: Limits,
}

impl Default for Settings {
    fn default() -> Self {
        use SchemeName::*;
        Settings {
            schemes: vec![Jacobi, GaussSeidel, GaussSeidelReversed, Iterative, Ijcsa, IqnIls],
            ratios: vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0],
            dts: vec![0.04, 0.02, 0.01, 0.005, 0.0025],
            t_end: 10.0,
            options: SchemeOptions::default(),
            jobs: None,
            limits: Limits::default(),
        }
    }
}

/// The outcome of one cell; the order is that of the map's colours ([`CATEGORY_COLORS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Stable,
    Unstable,
    NotConverged,
    /// The scaled platform cannot be held at the pose at all (a cable would have to push).
    Infeasible,
}

impl Verdict {
    const ALL: [Verdict; 4] = [Verdict::Stable, Verdict::Unstable, Verdict::NotConverged, Verdict::Infeasible];

    pub fn label(self) -> &'static str {
        match self {
            Verdict::Stable => "stable",
            Verdict::Unstable => "unstable",
            Verdict::NotConverged => "not converged",
            Verdict::Infeasible => "infeasible",
        }
    }
}

/// One cell of the map, run.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub scheme: SchemeName,
    pub ratio: f64,
    pub dt: f64,
    pub verdict: Verdict,
    /// Iterations per step of a run that ended (NaN for one that stopped or did not start).
    pub iterations: f64,
    pub note: String,
}

/// A map ready to run: every run checked, the variants of the scene made.
pub struct Stability<'a> {
    scene: &'a ValidScene,
    file: &'a Path,
    settings: Settings,
    variants: Vec<(f64, ValidScene)>,
}

/// The map.
#[derive(Clone, Debug)]
pub struct Map {
    pub scene: String,
    pub settings: Settings,
    /// Every cell: by variant, scheme, step.
    pub cells: Vec<Outcome>,
}

/// One cell to run: a scheme on a variant (its index among the mass factors) at a step.
struct Case<'a> {
    scheme: SchemeName,
    variant: usize,
    ratio: f64,
    dt: f64,
    run: Run<'a>,
}

impl Case<'_> {
    fn label(&self) -> String {
        format!("{}, mass ×{}, h = {} s", self.scheme.as_str(), self.ratio, self.dt)
    }
}

/// A cell's outcome as a store keeps it (the number exactly, NaN included).
fn to_cells((verdict, iterations, note): &(Verdict, f64, String)) -> Vec<String> {
    vec![verdict.label().to_owned(), format!("{iterations:?}"), note.clone()]
}

/// The outcome a store's cells give, if it is one a run can give: iterations per step (at least
/// one) for a run that ended, none (NaN) for one that stopped or could not start.
fn from_cells(cells: &[String]) -> anyhow::Result<(Verdict, f64, String)> {
    let [verdict, iterations, note] = cells else { anyhow::bail!("a cell of {} fields, not 3", cells.len()) };
    let verdict =
        Verdict::ALL.into_iter().find(|v| v.label() == verdict).with_context(|| format!("a verdict `{verdict}`"))?;
    let it: f64 = iterations.parse().with_context(|| format!("a number `{iterations}`"))?;
    let ran = it.is_finite() && it >= 1.0;
    let possible = match verdict {
        Verdict::Stable => ran,
        Verdict::Unstable => ran || it.is_nan(),
        Verdict::NotConverged | Verdict::Infeasible => it.is_nan(),
    };
    anyhow::ensure!(possible, "{} with {iterations} iterations per step", verdict.label());
    Ok((verdict, it, note.clone()))
}

/// How a run that stopped failed: an iteration limit reached without a sign of divergence is
/// "not converged", anything else "unstable".
fn stopped_verdict(reason: &str) -> Verdict {
    if reason.contains("did not converge in") && !reason.contains("unstable") {
        Verdict::NotConverged
    } else {
        Verdict::Unstable
    }
}

impl<'a> Stability<'a> {
    /// The map of `scene` (read from `file`): every run checked before any starts.
    pub fn new(scene: &'a ValidScene, file: &'a Path, settings: Settings) -> anyhow::Result<Stability<'a>> {
        let mut variants = Vec::new();
        for &f in &settings.ratios {
            let variant = scene.edited(|s| crate::sweep::scale_platform_mass(s, f));
            variants.push((f, variant.with_context(|| format!("the platform's mass ×{f}"))?));
        }
        let map = Stability { scene, file, settings, variants };
        map.cases()?;
        Ok(map)
    }

    /// Every cell's run, by variant, scheme and step.
    fn cases(&self) -> anyhow::Result<Vec<Case<'_>>> {
        let s = &self.settings;
        let mut cases = Vec::new();
        for (v, (f, variant)) in self.variants.iter().enumerate() {
            for &scheme in &s.schemes {
                for &dt in &s.dts {
                    let context = || format!("{}, mass ×{f}, h = {dt} s", scheme.as_str());
                    let method = s.options.method(scheme).with_context(context)?;
                    let run = Run::prepare(variant, self.file, method, dt, s.t_end, &s.limits).with_context(context)?;
                    cases.push(Case { scheme, variant: v, ratio: *f, dt, run });
                }
            }
        }
        Ok(cases)
    }

    /// Runs every cell on the settings' threads, the longest first; a cell `store` holds from an
    /// earlier run is taken from there.
    pub fn run(&self, store: &dyn Store, observer: &dyn Observer) -> anyhow::Result<Map> {
        let cases = self.cases()?;
        // A variant is form-found by the first of its cells to run (the others wait for it): the
        // statics of an infeasible variant, slow to prove so, then overlap the runs of the others
        // instead of holding them all back.
        let found: Vec<OnceLock<Result<bool, StaticsError>>> = self.variants.iter().map(|_| OnceLock::new()).collect();
        let feasible = |v: usize| -> anyhow::Result<bool> {
            let (f, variant) = &self.variants[v];
            let found = found[v].get_or_init(|| {
                let net = CableNet::from_scene(variant);
                match form_find(&net, variant.target_position(), variant.target_orientation()) {
                    Ok(_) => Ok(true),
                    Err(StaticsError::Infeasible { .. }) => Ok(false),
                    Err(e) => Err(e),
                }
            });
            found.clone().with_context(|| format!("form-finding with the platform's mass ×{f}"))
        };
        let cell = |case: &Case<'_>| -> anyhow::Result<(Verdict, f64, String)> {
            if !feasible(case.variant)? {
                return Ok((Verdict::Infeasible, f64::NAN, "a cable would have to push".to_string()));
            }
            observer.begin(&case.label());
            match case.run.execute_watched(&mut *observer.watch()) {
                Ok(t) => {
                    // a run that ends but keeps growing is not stable either
                    let n = t.disp_mm.len();
                    let peak =
                        |r: std::ops::Range<usize>| t.disp_mm[r].iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                    let (early, late) = (peak(0..n / 3), peak(2 * n / 3..n));
                    if late > 10.0 * early.max(1e-9) {
                        let note = format!("growing: peak {early:.2e} → {late:.2e} mm");
                        Ok((Verdict::Unstable, t.mean_iterations(), note))
                    } else {
                        Ok((Verdict::Stable, t.mean_iterations(), String::new()))
                    }
                }
                Err(RunError::Stopped { time, reason, .. }) => {
                    Ok((stopped_verdict(&reason), f64::NAN, format!("stopped at t = {time:.6} s: {reason}")))
                }
                // a missing FMU or a model that cannot be set up is no verdict on the scheme
                Err(e) => Err(e.into()),
            }
        };
        // steps × the scheme's cost per step (an infeasible variant's cells are estimated as
        // runs: which variants are infeasible is known only once their cells start)
        let t_end = self.settings.t_end;
        let cost = |case: &Case<'_>| t_end / case.dt * case.scheme.relative_cost();
        let codec = Codec { key: Case::label, encode: to_cells, decode: |_: &Case<'_>, c: &[String]| from_cells(c) };
        let results = crate::points::map(&cases, self.settings.jobs, cost, store, codec, |_, case| {
            cell(case).with_context(|| case.label())
        })?;
        let cells = cases
            .iter()
            .zip(results)
            .map(|(case, (verdict, iterations, note))| Outcome {
                scheme: case.scheme,
                ratio: case.ratio,
                dt: case.dt,
                verdict,
                iterations,
                note,
            })
            .collect();
        Ok(Map { scene: self.scene.name.clone(), settings: self.settings.clone(), cells })
    }
}

impl Map {
    fn cell(&self, scheme: SchemeName, ratio: f64, dt: f64) -> &Outcome {
        self.cells.iter().find(|c| c.scheme == scheme && c.ratio == ratio && c.dt == dt).expect("every cell was run")
    }

    /// `stability.csv`: a line per cell.
    pub fn csv(&self) -> String {
        let mut csv = String::from("scheme,mass_factor,dt_s,verdict,mean_iterations,note\n");
        for c in &self.cells {
            let it = if c.iterations.is_nan() { String::new() } else { format!("{:.3}", c.iterations) };
            csv.push_str(&format!(
                "{},{},{},{},{it},\"{}\"\n",
                c.scheme.as_str(),
                c.ratio,
                c.dt,
                c.verdict.label(),
                c.note.replace('"', "'")
            ));
        }
        csv
    }

    /// A table per scheme: S, U, N or – per mass factor and step, with iterations per step where
    /// the scheme iterates.
    pub fn text(&self) -> String {
        let s = &self.settings;
        let mut text = format!(
            "{}: stable (S), unstable (U), not converged (N), infeasible pose (–); iterations per step where the scheme iterates\n",
            self.scene
        );
        for &name in &s.schemes {
            let mut table =
                Table::new(std::iter::once("mass factor".to_string()).chain(s.dts.iter().map(|d| format!("h = {d}"))));
            for &f in &s.ratios {
                let mut row = vec![format!("×{f}")];
                for &dt in &s.dts {
                    let c = self.cell(name, f, dt);
                    row.push(match c.verdict {
                        Verdict::Stable if name.iterates() => format!("S {:.1}", c.iterations),
                        Verdict::Stable => "S".into(),
                        Verdict::Unstable => "U".into(),
                        Verdict::NotConverged => "N".into(),
                        Verdict::Infeasible => "–".into(),
                    });
                }
                table.row(row);
            }
            text.push_str(&format!("\n{}:\n{}", name.as_str(), table.render()));
        }
        text
    }

    /// `stability.svg`: a map per scheme.
    pub fn svg(&self) -> Result<String, PlotError> {
        let s = &self.settings;
        let mut panels = Vec::new();
        for &name in &s.schemes {
            let mut cells = Vec::new();
            for (iy, &f) in s.ratios.iter().enumerate() {
                for (ix, &dt) in s.dts.iter().enumerate() {
                    let c = self.cell(name, f, dt);
                    let stable = c.verdict == Verdict::Stable && name.iterates();
                    let text = if stable { format!("{:.1}", c.iterations) } else { String::new() };
                    cells.push(Cell { ix, iy, category: c.verdict as usize, text });
                }
            }
            panels.push(MapPanel { title: name.as_str(), cells });
        }
        let categories = [
            ("stable", CATEGORY_COLORS[0]),
            ("unstable", CATEGORY_COLORS[1]),
            ("not converged", CATEGORY_COLORS[2]),
            ("infeasible pose", CATEGORY_COLORS[3]),
        ];
        stability_map(
            &format!(
                "{}: stability over the platform's mass factor and the macro step ({} s runs)",
                self.scene, s.t_end
            ),
            "macro step h (s)",
            "platform mass factor",
            &s.dts,
            &s.ratios,
            &categories,
            &panels,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stored cell reads back as written; iterations a run cannot give with its verdict (a
    /// stable run without them, a stopped one with them, none at all below one, infinite) do not.
    #[test]
    fn only_an_outcome_a_run_can_give_reads_back_from_a_store() {
        for outcome in [
            (Verdict::Stable, 2.02, String::new()),
            (Verdict::Unstable, 1.0, "growing".to_string()),
            (Verdict::Unstable, f64::NAN, "stopped".to_string()),
            (Verdict::NotConverged, f64::NAN, "stopped".to_string()),
            (Verdict::Infeasible, f64::NAN, "a cable would have to push".to_string()),
        ] {
            assert_eq!(to_cells(&from_cells(&to_cells(&outcome)).unwrap()), to_cells(&outcome));
        }
        let cells = |x: [&str; 3]| x.map(String::from);
        for bad in [
            cells(["S", "NaN", ""]),
            cells(["S", "inf", ""]),
            cells(["S", "0.5", ""]),
            cells(["N", "2.0", ""]),
            cells(["–", "3", ""]),
            cells(["X", "2.0", ""]),
        ] {
            assert!(from_cells(&bad).is_err(), "{bad:?}");
        }
        assert!(from_cells(&cells(["S", "2.0", ""])[..2]).is_err());
    }
}
