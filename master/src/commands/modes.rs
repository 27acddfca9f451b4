//! `master modes`: natural frequencies and mode shapes about the static equilibrium.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use cable::model::CableCabin;
use cable::modes::{Dropped, modes_dropping, straight_cable_frequencies};
use feedcore::scene::{SceneError, StewartMode, ValidScene};
use serde_json::json;
use studies::limits::{Footprint, check_memory};
use studies::report::Modal;
use studies::table::Table;

use super::output::{Outputs, run_inputs};
use super::{CmdResult, caps, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML), e.g. scenes/lt50m_B.toml.
    #[arg(long)]
    pub(crate) scene: PathBuf,
    /// Number of modes (lowest first); default: the scene's `analyses.modes`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub(crate) count: Option<u32>,
    /// Print JSON: frequencies_hz (ascending) and per mode its cabin participation and the
    /// cabin's part of the mass-normalized shape [dx, dy, dz, rx, ry, rz].
    #[arg(long)]
    pub(crate) json: bool,
    /// A linearisation hypothesis (docs/reproduction.md, "Table 2"), for comparisons with the
    /// paper only: the full tangent stiffness is the physics.
    #[arg(long, value_enum, default_value_t = Hypothesis::Full)]
    pub(crate) hypothesis: Hypothesis,
    /// How the Stewart platform enters: rigidly at its start pose (locked), as its mass alone
    /// added to the cabin at its centre point (added-mass), or not at all (absent; the statics
    /// without its weight).
    #[arg(long, value_enum, default_value_t = Platform::Locked)]
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

/// Linearisations the paper's Table 2 may have used; every one leaves out physics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Hypothesis {
    /// The full tangent stiffness (the physics).
    Full,
    /// Without `Σ [pᵢ]×[dᵢ]×`, the stiffness of the cable-end forces turning with the cabin.
    NoRotationalGeometricStiffness,
    /// Without `−[m g]×[c]×`, the stiffness of the weight acting at the turning centre of mass.
    NoWeightRotationalStiffness,
    /// Without both (K stays symmetric: at equilibrium their unsymmetric parts cancel).
    NoRotationalLoadStiffness,
    /// The cabin on six massless straight cables (axial EA/L₀ and geometric T/L stiffness): six modes.
    StraightCables,
    /// As straight-cables without the cables' geometric stiffness T/L: six modes.
    StraightCablesNoGeometricStiffness,
}

impl Hypothesis {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Hypothesis::Full => "full",
            Hypothesis::NoRotationalGeometricStiffness => "no-rotational-geometric-stiffness",
            Hypothesis::NoWeightRotationalStiffness => "no-weight-rotational-stiffness",
            Hypothesis::NoRotationalLoadStiffness => "no-rotational-load-stiffness",
            Hypothesis::StraightCables => "straight-cables",
            Hypothesis::StraightCablesNoGeometricStiffness => "straight-cables-no-geometric-stiffness",
        }
    }
}

/// How the Stewart platform enters the modal analysis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Platform {
    /// Rigidly attached at its start pose (its mass, centre of mass and inertia).
    Locked,
    /// Its mass added to the cabin's at the cabin centre point (no offset, no added inertia).
    AddedMass,
    /// Left out (neither its weight nor its inertia).
    Absent,
}

/// The scene as a modal case sees it: the platform as `platform` says, E replaced.
pub(crate) fn case_scene(
    scene: &ValidScene,
    platform: Platform,
    youngs_modulus: Option<f64>,
) -> Result<ValidScene, SceneError> {
    let platform_mass = scene.stewart_geometry().total_mass();
    scene.edited(|s| {
        if let Some(e) = youngs_modulus {
            s.cables.youngs_modulus_pa = e;
        }
        match platform {
            Platform::Locked => {}
            Platform::AddedMass => {
                s.cabin.mass_kg += platform_mass;
                s.analyses.stewart = StewartMode::Absent;
            }
            Platform::Absent => s.analyses.stewart = StewartMode::Absent,
        }
    })
}

/// The lowest `count` frequencies (Hz) of `scene` under a hypothesis, platform and modulus
/// (the straight-cable models have six).
pub(crate) fn case_frequencies(
    scene: &ValidScene,
    hypothesis: Hypothesis,
    platform: Platform,
    youngs_modulus: Option<f64>,
    count: usize,
) -> anyhow::Result<Vec<f64>> {
    let s = case_scene(scene, platform, youngs_modulus)?;
    let model = CableCabin::build(&studies::calibrate::modal_scene(&s)?, 0)?;
    let sys = model.system(cable::model::Payload::Locked);
    let cfg = model.equilibrium_config();
    let dropped = |cable_end_rotation, weight_rotation| Dropped { cable_end_rotation, weight_rotation };
    let f = match hypothesis {
        Hypothesis::Full => modes_dropping(&sys, &cfg, count, Dropped::default())?.frequencies_hz,
        Hypothesis::NoRotationalGeometricStiffness => {
            modes_dropping(&sys, &cfg, count, dropped(true, false))?.frequencies_hz
        }
        Hypothesis::NoWeightRotationalStiffness => {
            modes_dropping(&sys, &cfg, count, dropped(false, true))?.frequencies_hz
        }
        Hypothesis::NoRotationalLoadStiffness => modes_dropping(&sys, &cfg, count, dropped(true, true))?.frequencies_hz,
        Hypothesis::StraightCables => straight_cable_frequencies(&sys, &cfg, true),
        Hypothesis::StraightCablesNoGeometricStiffness => straight_cable_frequencies(&sys, &cfg, false),
    };
    Ok(f.into_iter().take(count).collect())
}

/// `master modes` with a hypothesis, another platform or another E: the frequencies alone.
fn run_case(args: &Args, scene: &ValidScene, count: usize) -> CmdResult {
    let f = case_frequencies(scene, args.hypothesis, args.platform, args.youngs_modulus, count)?;
    let platform = clap::ValueEnum::to_possible_value(&args.platform).map_or("?".into(), |v| v.get_name().to_owned());
    let e = args.youngs_modulus.unwrap_or(scene.cables.youngs_modulus_pa);
    let mut out = std::io::stdout().lock();
    if args.json {
        let j = json!({"scene": scene.name, "hypothesis": args.hypothesis.name(), "platform": platform,
                       "youngs_modulus_pa": e, "frequencies_hz": f});
        writeln!(out, "{}", serde_json::to_string_pretty(&j)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "Natural frequencies of {} under the hypothesis {} (platform {platform}, E = {e:e} Pa)",
        scene.name,
        args.hypothesis.name()
    )?;
    writeln!(out, "A comparison with the paper's linearisation, not the physics: docs/reproduction.md.")?;
    writeln!(out)?;
    let mut t = Table::new(["mode", "f Hz"]);
    for (k, f) in f.iter().enumerate() {
        t.row([(k + 1).to_string(), format!("{f:.5}")]);
    }
    write!(out, "{}", t.render())?;
    Ok(())
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.scene)?;
    let mut out = std::io::stdout().lock();
    let count = args.count.map_or(scene.analyses.modes, |c| c as usize);
    if count == 0 {
        anyhow::bail!("{}: the scene asks for no modes (analyses.modes = 0); give --count N", args.scene.display());
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
    let mut outputs = Outputs::new(run_inputs(&args.scene, &scene));
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
        .with_context(|| format!("{}: the modal analysis cannot start", args.scene.display()))?;
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
    writeln!(out, "Natural modes about the static equilibrium: {} ({})", scene.name, args.scene.display())?;
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
