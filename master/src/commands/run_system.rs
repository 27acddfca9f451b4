//! `master run --system FILE`: any system of FMI 2.0 Co-Simulation FMUs described in SSP 1.0
//! (an `.ssp` archive, or an `.ssd` with its FMUs beside it), run by a coupling scheme. The CSV
//! holds `time` (with --adaptive then `h_s`, the size of the accepted step that ended there) and
//! every output of every component as `<component>.<variable>`; the plot shows every Real
//! output, a panel per component.

use std::io::{IsTerminal, Write};
use std::path::Path;

use anyhow::{Context, bail};
use studies::plot::{Line, PALETTE, Panel, stacked};
use studies::system::{RealHistory, Sinks, SystemFile};

use super::output::Outputs;
use super::run::Args;
use super::{CmdResult, caps};

pub(crate) fn run(args: &Args, file: &Path) -> CmdResult {
    if args.compensation != super::scheme_args::Compensation::On {
        bail!("--compensation applies to a --scene with [control]; a --system runs its FMUs as they are");
    }
    if args.wind_seed.is_some() {
        bail!("--wind-seed applies to a --scene with [wind]; a --system runs its FMUs as they are");
    }
    let method = args.options.method(args.scheme)?;
    let files = args.system_files.files();
    let system = SystemFile::prepare(file, method, args.dt, args.t_end, &files, &caps().run)?;
    let (dt, t_end, adaptive) = (system.dt, system.t_end, system.adaptive());
    let mut outputs = Outputs::new(system.inputs());
    let csv = args.out.as_ref().map(|p| outputs.declare("--out", p, None)).transpose()?;
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    outputs.open()?;

    let quiet = args.quiet.quiet || args.json || !std::io::stderr().is_terminal();
    let mut writer = csv.map(|id| outputs.stream(id)).transpose()?;
    let mut history = RealHistory::default();
    let sinks = Sinks { csv: writer.as_mut().map(|w| w as &mut dyn Write), real: svg.map(|_| &mut history) };
    let outcome = system.execute(&mut crate::progress::Progress::new(quiet), sinks)?;
    if let (Some(id), Some(w)) = (csv, writer) {
        outputs.finish(id, w)?;
    }
    if let Some((t, why)) = &outcome.stopped_early {
        eprintln!("note: the run ended early at t = {} s: {why}", super::run::instant(*t));
    }
    let steps = match adaptive {
        Some(a) => format!("the adaptive step (rtol {:e})", a.tolerances.rtol),
        None => format!("h = {dt} s"),
    };
    if let Some(id) = svg {
        let svg = plot_outputs(&history, &format!("{}: {} at {steps}", file.display(), system.scheme()))?;
        outputs.write(id, |w| w.write_all(svg.as_bytes()))?;
    }
    outputs.commit()?;

    let mut out = std::io::stdout().lock();
    if args.json {
        let v = system.summary(&outcome);
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{} — {} at {steps} to {t_end} s: {} steps in {:.3} s, {:.2} iterations per step, largest interface residual {:.2e}",
        file.display(),
        system.scheme(),
        outcome.steps,
        outcome.wall_time_s,
        outcome.mean_iterations,
        outcome.max_residual
    )?;
    if adaptive.is_some() {
        writeln!(
            out,
            "adaptive step: {} tries rejected, h from {:.3e} to {:.3e} s",
            outcome.rejected_steps, outcome.h_min_used, outcome.h_max_used
        )?;
    }
    for (component, solver, s) in &outcome.model_exchange {
        writeln!(
            out,
            "component `{component}` (Model Exchange, {solver}): {} integrator steps, {} rejected, {} events \
             ({} state, {} time, {} step), {} derivative evaluations",
            s.steps,
            s.rejected,
            s.state_events + s.time_events + s.step_events,
            s.state_events,
            s.time_events,
            s.step_events,
            s.evaluations
        )?;
    }
    if let Some(p) = &args.out {
        writeln!(out, "time histories of {} outputs: {}", outcome.columns.len() - 1, p.display())?;
    }
    if let Some(p) = &args.plot {
        writeln!(out, "plot: {}", p.display())?;
    }
    Ok(())
}

/// Every Real output against time, a panel per component.
fn plot_outputs(history: &RealHistory, title: &str) -> anyhow::Result<String> {
    let component = |name: &str| name.split('.').next().unwrap_or_default().to_string();
    let mut components: Vec<String> = history.names.iter().map(|n| component(n)).collect();
    components.dedup();
    let panels: Vec<Panel> = components
        .iter()
        .map(|c| {
            let lines: Vec<Line> = history
                .names
                .iter()
                .zip(&history.values)
                .filter(|(n, _)| component(n) == *c)
                .map(|(n, y)| Line { name: n, t: &history.t, y: y.clone() })
                .collect();
            // a legend of more lines than the palette has colours would not tell them apart
            Panel { y_label: c.clone(), legend: lines.len() <= PALETTE.len(), lines }
        })
        .collect();
    stacked(title, &panels, 320).context("drawing the outputs")
}
