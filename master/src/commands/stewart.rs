//! `master stewart`: the Stewart platform on a fixed cabin at the scene's target pose: its added
//! mass, static wrench, and the wrench and actuator-force range over one circle of the platform.

use std::io::Write;

use nalgebra::Vector6;
use serde_json::json;
use stewart::{CabinMotion, Stewart};
use studies::table::Table;

use super::args::SceneFile;
use super::{CmdResult, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// Print JSON instead of tables. Keys (world frame; 6-vectors and matrix rows/columns are
    /// force then moment, moments about the cabin centre point; SI units): added_mass (6×6, the
    /// locked spatial mass matrix, = −∂wrench/∂(a, α)), static_wrench (platform at rest at its
    /// start point), wrench_min and wrench_max (componentwise over the first revolution),
    /// actuator_force_max_n (largest |force| of any actuator), actuator_forces_n {static, min,
    /// max} per leg (tension positive), plus scene, total_mass_kg, cabin_position,
    /// cabin_orientation [w, x, y, z], revolution_s, samples.
    #[arg(long)]
    pub(crate) json: bool,
}

const LABELS: [&str; 6] = ["Fx N", "Fy N", "Fz N", "Mx N·m", "My N·m", "Mz N·m"];

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let mut out = std::io::stdout().lock();
    let st = Stewart::from_scene(&scene)?;
    let (position, orientation) = (scene.target_position(), scene.target_orientation());
    let cabin = CabinMotion::at_rest(position, orientation);
    let rest = st.relative_at_rest()?;
    let (static_wrench, jacobians) = rest.wrench_with_jacobians(&cabin, &st.gravity());
    let added = jacobians.added_mass();
    // The platform at rest at its start point: any time before the start.
    let static_forces = st.evaluate(&cabin, -1.0)?.actuator_forces;
    let range = st.fixed_cabin_range(&position, &orientation, scene.solver.dt_s)?;
    let static_wrench = static_wrench.to_vector();

    if args.json {
        let rows: Vec<Vec<f64>> = (0..6).map(|i| added.row(i).iter().copied().collect()).collect();
        let q = orientation;
        let json_out = json!({
            "scene": scene.name,
            "total_mass_kg": st.total_mass(),
            "cabin_position": position.as_slice(),
            "cabin_orientation": [q.w, q.i, q.j, q.k],
            "added_mass": rows,
            "static_wrench": static_wrench.as_slice(),
            "revolution_s": range.duration,
            "samples": range.samples,
            "wrench_min": range.wrench_min.as_slice(),
            "wrench_max": range.wrench_max.as_slice(),
            "actuator_force_max_n": range.actuator_force_max(),
            "actuator_forces_n": {
                "static": static_forces,
                "min": range.actuator_min,
                "max": range.actuator_max,
            },
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&json_out)?)?;
        return Ok(());
    }

    writeln!(out, "Stewart platform on a fixed cabin: {} ({})", scene.name, args.file.scene.display())?;
    writeln!(
        out,
        "cabin centre point at ({:.4}, {:.4}, {:.4}) m; moving mass {:.1} kg; world frame, moments about the cabin centre point",
        position.x,
        position.y,
        position.z,
        st.total_mass()
    )?;
    writeln!(out)?;
    writeln!(out, "Added mass at the starting pose (locked spatial mass matrix; kg, kg·m, kg·m²):")?;
    let mut t = Table::new(["", "ax", "ay", "az", "αx", "αy", "αz"]);
    for (i, label) in ["Fx", "Fy", "Fz", "Mx", "My", "Mz"].iter().enumerate() {
        t.row(std::iter::once(label.to_string()).chain(added.row(i).iter().map(|x| format!("{x:.4}"))));
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    writeln!(
        out,
        "Wrench on the cabin: at rest, and over the first revolution ({:.2} s, {} samples, {} start):",
        range.duration,
        range.samples,
        match scene.motion.start {
            feedcore::scene::Start::Abrupt => "abrupt",
            feedcore::scene::Start::Ramp => "ramped",
            feedcore::scene::Start::Consistent => "abrupt, momentum-consistent",
        }
    )?;
    let mut t = Table::new(["", "static", "min", "max", "max − min"]);
    let (lo, hi): (&Vector6<f64>, &Vector6<f64>) = (&range.wrench_min, &range.wrench_max);
    for i in 0..6 {
        t.row([
            LABELS[i].to_string(),
            format!("{:.4}", static_wrench[i]),
            format!("{:.4}", lo[i]),
            format!("{:.4}", hi[i]),
            format!("{:.4}", hi[i] - lo[i]),
        ]);
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    writeln!(out, "Actuator forces, N (tension positive):")?;
    let mut t = Table::new(["leg", "static", "min", "max"]);
    for k in 0..static_forces.len() {
        t.row([
            (k + 1).to_string(),
            format!("{:.3}", static_forces[k]),
            format!("{:.3}", range.actuator_min[k]),
            format!("{:.3}", range.actuator_max[k]),
        ]);
    }
    write!(out, "{}", t.render())?;
    writeln!(out, "peak actuator force |F| = {:.3} N", range.actuator_force_max())?;
    Ok(())
}
