//! `master modes`: natural frequencies and mode shapes about the static equilibrium.

use std::path::PathBuf;

use cable_fmu::model::CableCabin;
use feedcore::scene::Scene;
use master::table::Table;
use nalgebra::Vector6;
use serde_json::json;

use super::CmdResult;

#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML), e.g. scenes/lt50m_B.toml.
    #[arg(long)]
    pub scene: PathBuf,
    /// Number of modes (lowest first); default: the scene's `analyses.modes`.
    #[arg(long)]
    pub count: Option<usize>,
    /// Print JSON: frequencies_hz (ascending) and per mode its cabin participation and the
    /// cabin's part of the mass-normalized shape [dx, dy, dz, rx, ry, rz].
    #[arg(long)]
    pub json: bool,
}

/// Share of the modal kinetic energy carried by the cabin, and a name for its main motion.
fn describe(cabin_mass: &nalgebra::Matrix6<f64>, shape: &Vector6<f64>) -> (f64, String) {
    let share = shape.dot(&(cabin_mass * shape));
    let names = ["x", "y", "z", "rx", "ry", "rz"];
    // compare translations (m) with rotations times the cabin radius (1 m)
    let k = (0..6).max_by(|a, b| shape[*a].abs().total_cmp(&shape[*b].abs())).unwrap_or(0);
    let what = if share < 0.2 { "cables".to_string() } else { format!("cabin {}", names[k]) };
    (share, what)
}

pub fn run(args: &Args) -> CmdResult {
    let scene = Scene::load(&args.scene)?;
    let count = args.count.unwrap_or(scene.analyses.modes).max(1);
    let model = CableCabin::build(&scene, count)?;
    let modes = model.modes.as_ref().expect("modes were asked for");
    let sys = model.system(cable_fmu::model::Payload::Locked);
    let cabin_mass = sys
        .body
        .transformed(&model.equilibrium.orientation.to_rotation_matrix().into_inner(), &model.equilibrium.position)
        .spatial_matrix_about(&model.equilibrium.position);
    let rows: Vec<_> = (0..count.min(modes.frequencies_hz.len()))
        .map(|k| {
            let part = modes.cabin_part(k);
            let (share, what) = describe(&cabin_mass, &part);
            (modes.frequencies_hz[k], share, what, part)
        })
        .collect();
    if args.json {
        let list: Vec<_> = rows
            .iter()
            .map(|(f, share, what, part)| json!({"frequency_hz": f, "cabin_share": share, "motion": what, "cabin_shape": part.as_slice()}))
            .collect();
        let out = json!({
            "scene": scene.name,
            "frequencies_hz": rows.iter().map(|r| r.0).collect::<Vec<_>>(),
            "modes": list,
            "damping": {"ratio": model.damping.ratio, "fit_frequencies_hz": model.damping.frequencies_hz,
                        "alpha_per_s": model.damping.alpha, "beta_s": model.damping.beta},
            "eigen_solver": {"method": "shift-invert Lanczos (M inner product) with a Sturm count",
                             "relative_residual": modes.residual, "stiffness_asymmetry": modes.stiffness_asymmetry,
                             "solves": modes.stats.solves, "passes": modes.stats.passes},
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("Natural modes about the static equilibrium: {} ({})", scene.name, args.scene.display());
    println!(
        "cable–cabin system with the Stewart platform locked at its start; {} elements per cable",
        scene.cables.elements
    );
    println!();
    let mut t = Table::new(["mode", "f Hz", "period s", "cabin share", "main motion"]);
    for (k, (f, share, what, _)) in rows.iter().enumerate() {
        t.row([(k + 1).to_string(), format!("{f:.5}"), format!("{:.3}", 1.0 / f), format!("{share:.2}"), what.clone()]);
    }
    print!("{}", t.render());
    println!();
    println!(
        "Rayleigh damping ζ = {} at {:.4} and {:.4} Hz: α = {:.4e} 1/s, β = {:.4e} s.",
        model.damping.ratio,
        model.damping.frequencies_hz[0],
        model.damping.frequencies_hz[1],
        model.damping.alpha,
        model.damping.beta
    );
    println!(
        "\"cabin share\": fraction of the mode's kinetic energy carried by the cabin (the rest is in the cables)."
    );
    println!(
        "Shift-invert Lanczos: {} solves in {} pass(es); frequencies within {:.1e} relative (residual bound), \
         stiffness asymmetry {:.1e} (the equilibrium's residual moment).",
        modes.stats.solves,
        modes.stats.passes,
        0.5 * modes.residual,
        modes.stiffness_asymmetry
    );
    Ok(())
}
