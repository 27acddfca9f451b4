//! `master replay`: runs a model's physics library in-process on an input table, as an FMU
//! would be run by an importer (inputs held over each step), and writes the outputs. The fmpy
//! cross-checks compare the packaged FMUs against it.

use std::io::Write;
use std::path::PathBuf;

use cable::model::{CableCabin, Payload};
use feedcore::scene::{Scene, ValidScene};
use nalgebra::Vector6;

use super::BoxResult as CmdResult;
use super::output::Outputs;

#[derive(clap::Args)]
pub(crate) struct Args {
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

pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    // written whole or not at all: a failed replay leaves no output that looks complete
    let mut outputs = Outputs::new([args.scene.clone(), args.inputs.clone()]);
    let out = outputs.declare("--out", &args.out, None)?;
    outputs.open()?;
    let mut f = outputs.stream(out)?;
    super::boxed(replay(args, &mut f))?;
    outputs.finish(out, f)?;
    outputs.commit()
}

fn replay(args: &Args, f: &mut dyn Write) -> CmdResult {
    let mut scene = Scene::load(&args.scene)?;
    if let Some(tol) = args.newton_tol {
        scene = scene.edited(|s| s.solver.newton_tol = tol)?;
    }
    let (header, rows) = read_csv(&args.inputs)?;
    if header.first().map(String::as_str) != Some("time") || rows.len() < 2 {
        return Err(format!("{}: needs a `time` column first and at least two rows", args.inputs.display()).into());
    }
    match args.model.as_str() {
        "cable_fmu" => replay_cable(&scene, &header, &rows, f),
        "stewart_fmu" => replay_stewart(&scene, &header, &rows, f),
        other => Err(format!("unknown model `{other}` (known: cable_fmu, stewart_fmu)").into()),
    }
}

/// The columns of `header` that hold the inputs `names`.
fn columns(header: &[String], names: &[String]) -> Result<Vec<usize>, String> {
    let find = |n: &String| header.iter().position(|h| h == n).ok_or(format!("input column `{n}` missing"));
    names.iter().map(find).collect()
}

/// `time` and the outputs' names: the header of the output CSV.
fn head(outputs: Vec<String>) -> String {
    std::iter::once("time".to_owned()).chain(outputs).collect::<Vec<_>>().join(",")
}

fn replay_cable(scene: &ValidScene, header: &[String], rows: &[Vec<f64>], f: &mut dyn Write) -> CmdResult {
    let cols = columns(header, &cable_fmu::input_names())?;
    let wrench = |r: &[f64]| Vector6::from_iterator(cols.iter().map(|&c| r[c]));
    let model = CableCabin::from_scene(scene)?;
    // As the FMU: at rest at the target pose under the first wrench (form-found for it).
    let w0 = wrench(&rows[0]);
    let under = if w0 == model.static_payload_wrench() { None } else { Some(model.under_wrench(&w0)?) };
    let mut dy = under.as_ref().unwrap_or(&model).dynamics_with(Payload::External, rows[0][0], &w0)?;
    writeln!(f, "{}", head(cable_fmu::output_names()))?;
    let mut tensions = vec![(0.0, 0.0); dy.system().cables()];
    let mut write_row = |dy: &cable::dynamics::Dynamics, f: &mut dyn Write| -> std::io::Result<()> {
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
    write_row(&dy, f)?;
    for w in rows.windows(2) {
        dy.step(w[1][0] - w[0][0], &wrench(&w[1]))?;
        write_row(&dy, f)?;
    }
    Ok(())
}

fn replay_stewart(scene: &ValidScene, header: &[String], rows: &[Vec<f64>], f: &mut dyn Write) -> CmdResult {
    let cols = columns(header, &stewart_fmu::input_names())?;
    let model = stewart::Stewart::from_scene(scene)?;
    writeln!(f, "{}", head(stewart_fmu::output_names()))?;
    for r in rows {
        let u: [f64; stewart_fmu::INPUTS] = std::array::from_fn(|i| r[cols[i]]);
        let cabin = stewart_fmu::cabin_motion(&u).map_err(|e| e.to_string())?;
        let t = r[0];
        let w = model.wrench(&cabin, t)?.to_vector();
        let e = model.evaluate(&cabin, t)?;
        let pq = e.platform.orientation;
        let mut v = vec![t];
        v.extend(w.iter());
        v.extend(e.actuator_forces.iter());
        v.extend(e.platform.position.iter());
        v.extend([pq.w, pq.i, pq.j, pq.k]);
        v.extend(e.leg_lengths.iter());
        let comp = model.compensation().ok_or("the model has no feed point")?;
        let (err, rot) = comp.feed_error(&e.platform.position, &pq, t);
        v.extend(err.iter().chain(rot.iter()));
        // no sensor state is replayed: the estimate is the reference pose, as in the FMU
        let (p, q) = comp.reference();
        v.extend(p.iter().chain([q.w, q.i, q.j, q.k].iter()));
        writeln!(f, "{}", v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(","))?;
    }
    Ok(())
}
