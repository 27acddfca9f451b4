//! `master modes`: natural frequencies and mode shapes about the static equilibrium.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use cable::model::CableCabin;
use feedcore::scene::ValidScene;
use studies::hypotheses::{Case, Hypothesis, Platform};
use studies::limits::{Footprint, check_memory};
use studies::report::Modal;
use studies::table::Table;

use super::args::SceneFile;
use super::output::{Outputs, run_inputs};
use super::scheme_args::named;
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Number of modes (lowest first); default: the scene's `analyses.modes`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub(crate) count: Option<u32>,
    /// Print JSON: frequencies_hz (ascending) and per mode its cabin participation and the
    /// cabin's part of the mass-normalized shape [dx, dy, dz, rx, ry, rz].
    #[arg(long)]
    pub(crate) json: bool,
    /// A linearisation hypothesis (docs/reproduction.md, "Table 2"), for comparisons with the
    /// paper only: the full tangent stiffness is the physics.
    #[arg(long, default_value = "full", value_parser = named::<Hypothesis>())]
    pub(crate) hypothesis: Hypothesis,
    /// How the Stewart platform enters: rigidly at its start pose (locked), as its mass alone
    /// added to the cabin at its centre point (added-mass), or not at all (absent; the statics
    /// without its weight).
    #[arg(long, default_value = "locked", value_parser = named::<Platform>())]
    pub(crate) platform: Platform,
    /// Young's modulus of the cables, Pa, instead of the scene's (the statics form-found again).
    #[arg(long, value_parser = super::scheme_args::positive)]
    pub(crate) youngs_modulus: Option<f64>,
    /// Draw each mode's shape over the equilibrium as SVG (small multiples, oblique view; each
    /// scaled, with its frequency, period and cabin share).
    #[arg(long)]
    pub(crate) plot: Option<PathBuf>,
    /// Write each mode's shape for ParaView into this folder: `<scene>_modes.pvd` and one
    /// `<scene>_modes/<scene>_mode_<k>.vtu` per mode, the net at the equilibrium with the mass-normalized
    /// shape as the point vector `mode_shape` (for "Warp By Vector"); docs/scenes.md.
    #[arg(long, value_name = "DIR")]
    pub(crate) vtk: Option<PathBuf>,
}

/// `master modes` with a hypothesis, another platform or another E: the frequencies alone.
fn run_case(args: &Args, scene: &ValidScene, count: usize) -> CmdResult {
    let case = Case::of(scene, args.hypothesis, args.platform, args.youngs_modulus, count)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&case.json())?)?;
    } else {
        write!(out, "{}", case.text())?;
    }
    Ok(())
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let mut out = std::io::stdout().lock();
    let count = args.count.map_or(scene.analyses.modes, |c| c as usize);
    if count == 0 {
        anyhow::bail!(
            "{}: the scene asks for no modes (analyses.modes = 0); give --count N",
            args.file.scene.display()
        );
    }
    if args.hypothesis != Hypothesis::Full || args.platform != Platform::Locked || args.youngs_modulus.is_some() {
        if args.plot.is_some() || args.vtk.is_some() {
            anyhow::bail!(
                "--plot and --vtk show the full model's mode shapes; leave out --hypothesis, --platform and \
                 --youngs-modulus (which give frequencies only)"
            );
        }
        return run_case(args, &scene, count);
    }
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let svg = args.plot.as_ref().map(|p| outputs.declare("--plot", p, Some("svg"))).transpose()?;
    outputs.open()?;
    let series = match &args.vtk {
        Some(dir) => {
            Some(studies::vtk::modes_series_in(dir, &scene.name).with_context(|| format!("--vtk {}", dir.display()))?)
        }
        None => None,
    };
    let built = CableCabin::modes_built(&scene, count);
    check_memory(&scene, Footprint::CableModel, built, &caps().run)
        .with_context(|| format!("{}: the modal analysis cannot start", args.file.scene.display()))?;
    let modal = Modal::of(&scene, count)?;
    if let Some(id) = svg {
        let figure = studies::view3d::modes_figure_of(&modal).context("drawing the mode shapes")?;
        outputs.write(id, |w| w.write_all(figure.as_bytes()))?;
    }
    let index = match (series, &args.vtk) {
        (Some(series), Some(dir)) => {
            Some(studies::vtk::modes_series(&modal, series).with_context(|| format!("--vtk {}", dir.display()))?)
        }
        _ => None,
    };
    outputs.commit()?;
    let (model, modes) = (&modal.model, modal.model.modes.as_ref().expect("modes were asked for"));
    if args.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&modal.json())?)?;
        return Ok(());
    }
    writeln!(out, "Natural modes about the static equilibrium: {} ({})", scene.name, args.file.scene.display())?;
    writeln!(
        out,
        "cable–cabin system with the Stewart platform locked at its start; {} elements per cable",
        scene.cables.elements
    )?;
    writeln!(out)?;
    let mut t = Table::new(["mode", "f Hz", "period s", "cabin share", "main motion"]);
    for (k, m) in modal.modes.iter().enumerate() {
        let f = m.frequency_hz;
        t.row([
            (k + 1).to_string(),
            format!("{f:.5}"),
            format!("{:.3}", 1.0 / f),
            format!("{:.2}", m.cabin_share),
            m.motion.clone(),
        ]);
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    writeln!(
        out,
        "Rayleigh damping ζ = {} at {:.4} and {:.4} Hz: α = {:.4e} 1/s, β = {:.4e} s.",
        model.damping.ratio,
        model.damping.frequencies_hz[0],
        model.damping.frequencies_hz[1],
        model.damping.alpha,
        model.damping.beta
    )?;
    writeln!(
        out,
        "\"cabin share\": fraction of the mode's kinetic energy carried by the cabin (the rest is in the cables)."
    )?;
    writeln!(
        out,
        "Shift-invert Lanczos: {} solves in {} pass(es); frequencies within {:.1e} relative (residual bound), \
         stiffness asymmetry {:.1e} (the equilibrium's residual moment).",
        modes.stats.solves,
        modes.stats.passes,
        0.5 * modes.residual,
        modes.stiffness_asymmetry
    )?;
    let (setup_s, estimate) = (modal.setup_s, modal.memory_estimate_bytes);
    let peak = modal.peak_memory_bytes.map_or("unknown".to_string(), |b| format!("{:.1} MB", b as f64 / 1e6));
    writeln!(
        out,
        "Form-finding and modal analysis {setup_s:.3} s; peak memory of the process {peak} (estimated before \
         the start: {:.1} MB).",
        estimate as f64 / 1e6
    )?;
    if let Some(p) = &args.plot {
        writeln!(out, "plot: {}", p.display())?;
    }
    if let Some(p) = &index {
        writeln!(out, "mode shapes for ParaView: {}", p.display())?;
    }
    Ok(())
}
