//! `master statics`: form-finding statics of the scene's target pose.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use cable::statics::CableState;
use feedcore::scene::ELASTIC_STRAIN_LIMIT;
use studies::limits::{Footprint, check_memory};
use studies::report::Statics;
use studies::table::Table;

use super::args::SceneFile;
use super::output::{Outputs, run_inputs};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Print JSON instead of a table: cabin_position [x, y, z] (m), cabin_orientation
    /// [w, x, y, z] (unit quaternion, body to world), and per cable unstretched_length_m,
    /// tension_anchor_n, tension_cabin_n, slack, nearly_slack, state, lowest_point_z_m, and
    /// utilisation (the larger end tension over cables.breaking_load_n; null without it) and
    /// overloaded, and strain (of the larger end tension; the text warns beyond 1 %).
    #[arg(long)]
    pub(crate) json: bool,
    /// Draw the net at the equilibrium as SVG: an oblique view, plan, front and side and a
    /// close-up of the cabin and the platform, each element coloured by its tension (colour
    /// bar), slack elements dashed, slack and nearly slack cables labelled.
    #[arg(long)]
    pub(crate) plot: Option<PathBuf>,
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    outputs.open()?;
    let mut out = std::io::stdout().lock();
    check_memory(&scene, Footprint::CableModel, 0, &caps().run)
        .with_context(|| format!("{}: the form-finding cannot start", args.file.scene.display()))?;
    let statics = Statics::of(&scene)?;
    if let Some(id) = svg {
        let figure = studies::view3d::statics_figure(&statics).context("drawing the net")?;
        outputs.write(id, |w| w.write_all(figure.as_bytes()))?;
    }
    outputs.commit()?;
    let (net, eq) = (&statics.net, &statics.equilibrium);
    let q = eq.orientation;
    let utilisation = |c: &cable::statics::CableReport| statics.utilisation(c);
    let overloaded = statics.overloaded();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&statics.json())?)?;
        return Ok(());
    }
    writeln!(out, "Form-finding statics: {} ({})", scene.name, args.file.scene.display())?;
    writeln!(
        out,
        "cabin centre point at ({:.4}, {:.4}, {:.4}) m, orientation (w, x, y, z) = ({:.9}, {:.9}, {:.9}, {:.9})",
        eq.position.x, eq.position.y, eq.position.z, q.w, q.i, q.j, q.k
    )?;
    writeln!(
        out,
        "suspended: {:.1} kg (cabin {:.1} kg, Stewart platform locked at its start {:.1} kg), {} elements per cable",
        net.suspended().mass,
        net.cabin.mass,
        net.payload.mass,
        net.spec.elements
    )?;
    writeln!(out)?;
    let mut header = vec!["cable", "azimuth °", "unstretched m", "T anchor N", "T cabin N", "lowest z m", "state"];
    if scene.cables.breaking_load_n.is_some() {
        header.push("utilisation");
    }
    let mut t = Table::new(header);
    for (i, c) in eq.cables.iter().enumerate() {
        let state = match c.state {
            CableState::Taut => "taut",
            CableState::NearlySlack => "nearly slack (sags below its cabin end)",
            CableState::Slack => "SLACK",
        };
        let mut row = vec![
            i.to_string(),
            format!("{:.0}", scene.anchors.angle_deg[i]),
            format!("{:.6}", c.unstretched_length),
            format!("{:.1}", c.tension_anchor),
            format!("{:.1}", c.tension_cabin),
            format!("{:.3}", c.lowest_point_z),
            state.to_string(),
        ];
        if let Some(u) = utilisation(c) {
            row.push(format!("{u:.3}{}", if u > 1.0 { " OVERLOAD" } else { "" }));
        }
        t.row(row);
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    writeln!(
        out,
        "Tensions are the axial forces of the end elements; residual of the cabin equations {:.1e} N.",
        eq.residual
    )?;
    let strained: Vec<usize> = (0..eq.cables.len())
        .filter(|&i| scene.cables.strain(eq.cables[i].largest_tension()) > ELASTIC_STRAIN_LIMIT)
        .collect();
    if !strained.is_empty() {
        let largest = eq.cables.iter().map(|c| scene.cables.strain(c.largest_tension())).fold(0.0, f64::max);
        writeln!(
            out,
            "warning: cables {strained:?} are stretched beyond 1 % (up to {:.3e} %): beyond a steel rope's elastic \
             range, where the model's linear-elastic cables do not hold; these tensions are not physical",
            largest * 100.0
        )?;
    }
    if let (false, Some(b)) = (overloaded.is_empty(), scene.cables.breaking_load_n) {
        writeln!(
            out,
            "warning: cables {overloaded:?} carry more than their breaking load {b} N (cables.breaking_load_n)"
        )?;
    }
    if let Some(p) = &args.plot {
        writeln!(out, "plot: {}", p.display())?;
    }
    Ok(())
}
