//! `master stability`: where each coupling scheme is stable, over the mass ratio (the Stewart
//! platform's masses and inertias scaled) and the macro step; iterations per step where it
//! iterates. A table per scheme, `stability.csv` and a plot of maps.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::sync::OnceLock;

use anyhow::Context;
use cable::net::CableNet;
use cable::statics::{StaticsError, form_find};
use master::journal::{self, Journal};
use master::plot::{CATEGORY_COLORS, Cell, MapPanel, stability_map};
use master::simulate::{Run, RunError};
use master::table::Table;

use super::output::{Outputs, run_inputs};
use super::scheme_args::{SchemeName, SchemeOptions, positive};
use super::{CmdResult, caps, fingerprint, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML).
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Coupling schemes (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "jacobi,gauss-seidel,gauss-seidel-reversed,iterative,ijcsa,iqn-ils"
    )]
    pub(crate) schemes: Vec<SchemeName>,
    /// Factors on every mass and inertia of the Stewart platform (1: the scene's platform).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.1,0.2,0.5,1,2,5,10")]
    pub(crate) ratios: Vec<f64>,
    /// Macro steps (s, comma-separated).
    #[arg(long, value_delimiter = ',', value_parser = positive, allow_negative_numbers = true,
          default_value = "0.04,0.02,0.01,0.005,0.0025")]
    pub(crate) dts: Vec<f64>,
    /// Simulated time of every run (s).
    #[arg(long, default_value_t = 10.0, value_parser = positive, allow_negative_numbers = true)]
    pub(crate) t_end: f64,
    /// Directory for stability.csv and stability.svg.
    #[arg(long, default_value = "out/stability")]
    pub(crate) out: PathBuf,
    /// No progress bars.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Worker threads: the runs are independent (default: one per core; progress bars only
    /// with one).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub(crate) jobs: Option<u16>,
    /// Continue a map that was interrupted or killed: the cells its journal in --out
    /// (`stability.csv.partial`, written as each cell finishes) holds are not run again.
    #[arg(long)]
    pub(crate) resume: bool,
    #[command(flatten)]
    pub(crate) options: SchemeOptions,
}

/// The outcome of one cell; the order is that of the map's colours ([`CATEGORY_COLORS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Stable,
    Unstable,
    NotConverged,
    /// The scaled platform cannot be held at the pose at all (a cable would have to push).
    Infeasible,
}

impl Verdict {
    const ALL: [Verdict; 4] = [Verdict::Stable, Verdict::Unstable, Verdict::NotConverged, Verdict::Infeasible];

    fn label(self) -> &'static str {
        match self {
            Verdict::Stable => "stable",
            Verdict::Unstable => "unstable",
            Verdict::NotConverged => "not converged",
            Verdict::Infeasible => "infeasible",
        }
    }
}

/// A cell's outcome as a journal keeps it (the number exactly, NaN included).
fn to_cells((verdict, iterations, note): &(Verdict, f64, String)) -> Vec<String> {
    vec![verdict.label().to_owned(), format!("{iterations:?}"), note.clone()]
}

/// The outcome a journal cell gives, if it is one a run can give: iterations per step (at least
/// one) for a run that ended, none (NaN) for one that stopped or could not start.
fn from_cells(cells: &[String]) -> anyhow::Result<(Verdict, f64, String)> {
    let [verdict, iterations, note] = cells else { anyhow::bail!("a journal cell of {} fields, not 3", cells.len()) };
    let verdict = Verdict::ALL
        .into_iter()
        .find(|v| v.label() == verdict)
        .with_context(|| format!("a journal verdict `{verdict}`"))?;
    let it: f64 = iterations.parse().with_context(|| format!("a journal number `{iterations}`"))?;
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

/// One cell of the map: a scheme on a variant (its index among the mass factors) at a step.
struct Case<'a> {
    scheme: SchemeName,
    variant: usize,
    ratio: f64,
    dt: f64,
    run: Run<'a>,
}

impl Case<'_> {
    /// How the progress lines and the errors name the cell.
    fn label(&self) -> String {
        format!("{}, mass ×{}, h = {} s", self.scheme.as_str(), self.ratio, self.dt)
    }
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let (ratios, dts) = (&args.ratios, &args.dts);
    let limits = caps().run;
    let jobs = args.jobs.map(usize::from);
    // Every run is checked before the first one starts. A variant is form-found by the first of
    // its cells to run (the others wait for it): the statics of an infeasible variant, slow to
    // prove so, then overlap the runs of the others instead of holding them all back.
    let mut variants = Vec::new();
    for &f in ratios {
        let variant = scene.edited(|s| master::sweep::scale_platform_mass(s, f));
        variants.push((f, variant.with_context(|| format!("the platform's mass ×{f}"))?));
    }
    let found: Vec<OnceLock<Result<bool, StaticsError>>> = variants.iter().map(|_| OnceLock::new()).collect();
    let feasible = |v: usize| -> anyhow::Result<bool> {
        let (f, variant) = &variants[v];
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
    let mut cases = Vec::new();
    for (v, (f, variant)) in variants.iter().enumerate() {
        for &scheme in &args.schemes {
            for &dt in dts {
                let context = || format!("{}, mass ×{f}, h = {dt} s", scheme.as_str());
                let method = args.options.method(scheme).with_context(context)?;
                let run = Run::prepare(variant, &args.scene, method, dt, args.t_end, &limits).with_context(context)?;
                cases.push(Case { scheme, variant: v, ratio: *f, dt, run });
            }
        }
    }
    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
    let csv_id = outputs.declare("--out", &args.out.join("stability.csv"), Some("csv"))?;
    let svg_id = outputs.declare("--out", &args.out.join("stability.svg"), Some("svg"))?;
    outputs.open()?;

    // the runs are independent: every one on its own core, results in input order; progress
    // bars only when one runs at a time
    let quiet = args.quiet || !std::io::stderr().is_terminal() || master::parallel::threads(jobs) > 1;
    let identity = format!(
        "stability {} {:?} {:?} {:?} {:?} {:?}",
        fingerprint(&scene),
        args.schemes.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
        args.ratios,
        args.dts,
        args.t_end,
        args.options
    );
    let journal = Journal::open(&journal::path(&args.out, "stability.csv"), &identity, args.resume)?;
    let cell = |case: &Case<'_>| -> anyhow::Result<(Verdict, f64, String)> {
        if !feasible(case.variant)? {
            return Ok((Verdict::Infeasible, f64::NAN, "a cable would have to push".to_string()));
        }
        eprintln!("{} …", case.label());
        match case.run.execute(quiet) {
            Ok(t) => {
                // a run that ends but keeps growing is not stable either
                let n = t.disp_mm.len();
                let peak =
                    |r: std::ops::Range<usize>| t.disp_mm[r].iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                let (early, late) = (peak(0..n / 3), peak(2 * n / 3..n));
                if late > 10.0 * early.max(1e-9) {
                    Ok((Verdict::Unstable, t.mean_iterations(), format!("growing: peak {early:.2e} → {late:.2e} mm")))
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
    // steps × the scheme's cost per step (an infeasible variant's cells are estimated as runs:
    // which variants are infeasible is known only once their cells start)
    let cost = |case: &Case<'_>| args.t_end / case.dt * case.scheme.relative_cost();
    let results = journal::map_journaled(
        &cases,
        jobs,
        cost,
        &journal,
        Case::label,
        to_cells,
        |_, c| from_cells(c),
        |_, case| cell(case).with_context(|| case.label()),
    )?;
    let mut rows = Vec::new(); // (scheme, ratio, dt, verdict, iterations, note)
    for (case, (verdict, iterations, note)) in cases.iter().zip(results) {
        rows.push((case.scheme, case.ratio, case.dt, verdict, iterations, note));
    }
    let label = Verdict::label;
    let mut csv = String::from("scheme,mass_factor,dt_s,verdict,mean_iterations,note\n");
    for (s, f, dt, v, it, note) in &rows {
        let it = if it.is_nan() { String::new() } else { format!("{it:.3}") };
        csv.push_str(&format!("{},{f},{dt},{},{it},\"{}\"\n", s.as_str(), label(*v), note.replace('"', "'")));
    }
    outputs.write(csv_id, |w| w.write_all(csv.as_bytes()))?;

    let mut text = format!(
        "{}: stable (S), unstable (U), not converged (N), infeasible pose (–); iterations per step where the scheme iterates\n",
        scene.name
    );
    let mut panels = Vec::new();
    for &name in &args.schemes {
        let mut cells = Vec::new();
        let mut table =
            Table::new(std::iter::once("mass factor".to_string()).chain(dts.iter().map(|d| format!("h = {d}"))));
        for (iy, &f) in ratios.iter().enumerate() {
            let mut row = vec![format!("×{f}")];
            for (ix, &dt) in dts.iter().enumerate() {
                let r = rows.iter().find(|r| r.0 == name && r.1 == f && r.2 == dt).expect("every cell was run");
                let iterating = name.iterates();
                let note = if r.3 == Verdict::Stable && iterating { format!("{:.1}", r.4) } else { String::new() };
                cells.push(Cell { ix, iy, category: r.3 as usize, text: note });
                row.push(match r.3 {
                    Verdict::Stable if iterating => format!("S {:.1}", r.4),
                    Verdict::Stable => "S".into(),
                    Verdict::Unstable => "U".into(),
                    Verdict::NotConverged => "N".into(),
                    Verdict::Infeasible => "–".into(),
                });
            }
            table.row(row);
        }
        panels.push(MapPanel { title: name.as_str(), cells });
        text.push_str(&format!("\n{}:\n{}", name.as_str(), table.render()));
    }
    let categories = [
        ("stable", CATEGORY_COLORS[0]),
        ("unstable", CATEGORY_COLORS[1]),
        ("not converged", CATEGORY_COLORS[2]),
        ("infeasible pose", CATEGORY_COLORS[3]),
    ];
    let svg = stability_map(
        &format!(
            "{}: stability over the platform's mass factor and the macro step ({} s runs)",
            scene.name, args.t_end
        ),
        "macro step h (s)",
        "platform mass factor",
        dts,
        ratios,
        &categories,
        &panels,
    )
    .context("drawing the stability map")?;
    outputs.write(svg_id, |w| w.write_all(svg.as_bytes()))?;
    let (csv_path, svg_path) = (outputs.path(csv_id).to_owned(), outputs.path(svg_id).to_owned());
    outputs.commit()?;
    journal.finish()?;
    let mut out = std::io::stdout().lock();
    write!(out, "{text}")?;
    writeln!(out)?;
    writeln!(out, "{} and {} written", csv_path.display(), svg_path.display())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A journal cell reads back as written; iterations a run cannot give with its verdict (a
    /// stable run without them, a stopped one with them, none at all below one, infinite) do not.
    #[test]
    fn only_an_outcome_a_run_can_give_reads_back_from_the_journal() {
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
