//! `master replay`: runs a model's physics library in-process on an input table, as an FMU
//! would be run by an importer (inputs held over each step), and writes the outputs. The fmpy
//! cross-checks compare the packaged FMUs against it.

use std::io::Write;
use std::path::PathBuf;

use cable_fmu::model::{CableCabin, Payload};
use feedcore::scene::Scene;
use nalgebra::Vector6;

use super::CmdResult;

#[derive(clap::Args)]
pub struct Args {
    /// The model whose library is run: cable_fmu or stewart_fmu.
    #[arg(long)]
    pub model: String,
    /// Scene file (TOML).
    #[arg(long)]
    pub scene: PathBuf,
    /// CSV with a header `time,<input names>` and one row per communication point t_0 … t_N, as
    /// fmpy records them: row 0 holds the inputs at initialization, row n > 0 the inputs held
    /// over the step that ends at t_n.
    #[arg(long)]
    pub inputs: PathBuf,
    /// Output CSV: `time,<output names>` at t_0 … t_N.
    #[arg(long)]
    pub out: PathBuf,
    /// Override the scene's Newton tolerance (m).
    #[arg(long)]
    pub newton_tol: Option<f64>,
}

/// Reads a numeric CSV with a header line.
fn read_csv(path: &PathBuf) -> Result<(Vec<String>, Vec<Vec<f64>>), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .ok_or(format!("{}: empty file", path.display()))?
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let rows = lines
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.split(',')
                .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{}:{}: `{x}`: {e}", path.display(), i + 2)))
                .collect::<Result<Vec<f64>, String>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some((i, r)) = rows.iter().enumerate().find(|(_, r)| r.len() != header.len()) {
        return Err(format!("{}:{}: {} values for {} columns", path.display(), i + 2, r.len(), header.len()));
    }
    Ok((header, rows))
}

pub fn run(args: &Args) -> CmdResult {
    let mut scene = Scene::load(&args.scene)?;
    if let Some(tol) = args.newton_tol {
        scene.solver.newton_tol = tol;
    }
    let (header, rows) = read_csv(&args.inputs)?;
    if header.first().map(String::as_str) != Some("time") || rows.len() < 2 {
        return Err(format!("{}: needs a `time` column first and at least two rows", args.inputs.display()).into());
    }
    match args.model.as_str() {
        "cable_fmu" => replay_cable(&scene, &header, &rows, &args.out),
        "stewart_fmu" => replay_stewart(&scene, &header, &rows, &args.out),
        other => Err(format!("unknown model `{other}` (known: cable_fmu, stewart_fmu)").into()),
    }
}

fn replay_cable(scene: &Scene, header: &[String], rows: &[Vec<f64>], out: &PathBuf) -> CmdResult {
    let names = ["wrench.f[1]", "wrench.f[2]", "wrench.f[3]", "wrench.m[1]", "wrench.m[2]", "wrench.m[3]"];
    let cols: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).ok_or(format!("input column `{n}` missing")))
        .collect::<Result<_, _>>()?;
    let wrench = |r: &[f64]| Vector6::from_iterator(cols.iter().map(|&c| r[c]));
    let model = CableCabin::from_scene(scene)?;
    let mut dy = model.dynamics_with(Payload::External, rows[0][0], &wrench(&rows[0]))?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(out)?);
    let axes = |p: &str, n: usize| (1..=n).map(|k| format!("{p}[{k}]")).collect::<Vec<_>>();
    let mut cols_out = vec!["time".to_string()];
    for (p, n) in [("cabin.r", 3), ("cabin.q", 4), ("cabin.v", 3), ("cabin.w", 3), ("cabin.a", 3), ("cabin.alpha", 3)] {
        cols_out.extend(axes(p, n));
    }
    cols_out.extend(axes("cable.tension_anchor", 6));
    cols_out.extend(axes("cable.tension_cabin", 6));
    writeln!(f, "{}", cols_out.join(","))?;
    let mut tensions = vec![(0.0, 0.0); dy.system().cables()];
    let mut write_row =
        |dy: &cable_fmu::dynamics::Dynamics, f: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            let c = dy.cabin();
            let q = c.orientation.quaternion();
            dy.end_tensions(&mut tensions);
            let mut v = vec![dy.time()];
            v.extend(c.position.iter());
            v.extend([q.w, q.i, q.j, q.k]);
            for x in [c.velocity, c.angular_velocity, c.acceleration, c.angular_acceleration] {
                v.extend(x.iter());
            }
            v.extend(tensions.iter().map(|t| t.0));
            v.extend(tensions.iter().map(|t| t.1));
            writeln!(f, "{}", v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(","))
        };
    write_row(&dy, &mut f)?;
    for w in rows.windows(2) {
        dy.step(w[1][0] - w[0][0], &wrench(&w[1]))?;
        write_row(&dy, &mut f)?;
    }
    Ok(())
}

fn replay_stewart(scene: &Scene, header: &[String], rows: &[Vec<f64>], out: &PathBuf) -> CmdResult {
    let mut names = Vec::new();
    for (p, n) in [("cabin.r", 3), ("cabin.q", 4), ("cabin.v", 3), ("cabin.w", 3), ("cabin.a", 3), ("cabin.alpha", 3)] {
        names.extend((1..=n).map(|k| format!("{p}[{k}]")));
    }
    let cols: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).ok_or(format!("input column `{n}` missing")))
        .collect::<Result<_, _>>()?;
    let model = stewart_fmu::Stewart::from_scene(scene)?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(out)?);
    let mut head = vec!["time".to_string()];
    for (p, n) in [("wrench.f", 3), ("wrench.m", 3), ("actuator.force", 6), ("platform.r", 3), ("platform.q", 4)] {
        head.extend((1..=n).map(|k| format!("{p}[{k}]")));
    }
    writeln!(f, "{}", head.join(","))?;
    for r in rows {
        let u: Vec<f64> = cols.iter().map(|&c| r[c]).collect();
        let v3 = |i: usize| feedcore::Vec3::new(u[i], u[i + 1], u[i + 2]);
        let q = feedcore::Quat::from_quaternion(nalgebra::Quaternion::new(u[3], u[4], u[5], u[6]));
        let cabin = stewart_fmu::CabinMotion {
            position: v3(0),
            orientation: q,
            velocity: v3(7),
            angular_velocity: v3(10),
            acceleration: v3(13),
            angular_acceleration: v3(16),
        };
        let t = r[0];
        let w = model.wrench(&cabin, t)?.to_vector();
        let e = model.evaluate(&cabin, t)?;
        let pq = e.platform.orientation;
        let mut v = vec![t];
        v.extend(w.iter());
        v.extend(e.actuator_forces.iter());
        v.extend(e.platform.position.iter());
        v.extend([pq.w, pq.i, pq.j, pq.k]);
        writeln!(f, "{}", v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(","))?;
    }
    Ok(())
}
