//! `master calibrate`: scene keys fitted to measured natural frequencies (model updating).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use feedcore::scene::{Scene, ValidScene};
use serde_json::json;
use studies::calibrate::{Key, MAX_MEASURED_BYTES, Problem, TensionBound, get_key, read_measured};
use studies::table::Table;

use super::output::{Outputs, run_inputs};
use super::{CmdResult, load_scene};

#[derive(clap::Args)]
pub(crate) struct Args {
    /// Scene file (TOML); give --scene once per scene the measured modes come from (the CSV's
    /// `scene` column holds each scene's `name`).
    #[arg(long = "scene", required = true)]
    pub(crate) scenes: Vec<PathBuf>,
    /// Measured natural frequencies: CSV `scene,mode,f_hz[,weight][,zeta][,dx,dy,dz,rx,ry,rz]`.
    /// Without shapes the k-th measured mode of a scene is paired with its k-th computed one
    /// (lowest first); with the cabin's part of each measured shape (`master modes --json`,
    /// cabin_shape), with the computed mode of the most similar shape (MAC), so that a swap of
    /// close modes does not mislead the fit. A measured damping ratio `zeta` is fitted too (the
    /// scene's Rayleigh damping at the paired mode).
    #[arg(long)]
    pub(crate) measured: PathBuf,
    /// Largest measured file read, bytes (only regular files are read).
    #[arg(long, default_value_t = MAX_MEASURED_BYTES, value_name = "BYTES")]
    pub(crate) max_measured_bytes: u64,
    /// Real-valued scene keys to fit, shared by every scene (comma-separated dotted names, e.g.
    /// anchors.radius_m,cables.youngs_modulus_pa).
    #[arg(long, value_delimiter = ',', required = true)]
    pub(crate) fit: Vec<String>,
    /// Bounds of a fitted key, KEY=LO:HI (repeatable); default: half to twice its start value.
    #[arg(long)]
    pub(crate) bounds: Vec<String>,
    /// A statement about a cable's tension every trial must keep (repeatable), in the static
    /// equilibrium of a scene named as in the CSV, cables from 0: SCENE:CABLE<=N bounds its larger
    /// end tension ("nearly slack"), SCENE:CABLE>=N its smaller one ("taut").
    #[arg(long, value_parser = |s: &str| TensionBound::parse(s))]
    pub(crate) tension: Vec<TensionBound>,
    /// Directory for the updated scenes (each under its file name; the FMU paths of its [system]
    /// made absolute so that it runs from there).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Print JSON: fitted, start, std_error, correlation, at_bound, residuals (per scene and mode:
    /// measured, computed, computed_mode; measured_zeta, computed_zeta where measured), cost,
    /// start_cost, iterations, singular_values, condition, unidentifiable.
    #[arg(long)]
    pub(crate) json: bool,
}

/// The bounds of `key`: from `--bounds KEY=LO:HI`, else half to twice `start`.
fn bounds_of(key: &str, start: f64, given: &[String]) -> anyhow::Result<(f64, f64)> {
    for b in given {
        let Some((k, range)) = b.split_once('=') else {
            bail!("--bounds {b}: expected KEY=LO:HI");
        };
        if k.trim() != key {
            continue;
        }
        let parse = |t: &str| t.trim().parse::<f64>().ok().filter(|x| x.is_finite());
        let (lo, hi) = range
            .split_once(':')
            .and_then(|(a, b)| Some((parse(a)?, parse(b)?)))
            .with_context(|| format!("--bounds {b}: LO:HI must be two finite numbers"))?;
        if !(lo < hi) {
            bail!("--bounds {b}: LO must be below HI");
        }
        return Ok((lo, hi));
    }
    Ok(if start > 0.0 { (0.5 * start, 2.0 * start) } else { (2.0 * start, 0.5 * start) })
}

/// `scene` (read from `file`) with the FMU paths of its [system] absolute.
fn portable(scene: &ValidScene, file: &Path) -> anyhow::Result<Scene> {
    let mut s = scene.to_scene();
    if let Some(sys) = s.system.as_mut() {
        let base = file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let base = std::fs::canonicalize(base).with_context(|| format!("{}: its folder", file.display()))?;
        for f in &mut sys.fmus {
            if !Path::new(&f.path).is_absolute() {
                f.path = base.join(&f.path).display().to_string();
            }
        }
    }
    Ok(s)
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let mut scenes = Vec::new();
    let mut inputs = vec![args.measured.clone()];
    for file in &args.scenes {
        let s = load_scene(file)?;
        if scenes.iter().any(|(o, _): &(ValidScene, String)| o.name == s.name) {
            bail!(
                "--scene {}: another scene is also named `{}`; the measured modes name scenes by `name`",
                file.display(),
                s.name
            );
        }
        inputs.extend(run_inputs(file, &s));
        scenes.push((s, file.display().to_string()));
    }
    let mut keys = Vec::new();
    for k in &args.fit {
        let start = get_key(&scenes[0].0, k).map_err(|e| anyhow::anyhow!("--fit {k}: {}: {e}", scenes[0].1))?;
        let (lo, hi) = bounds_of(k, start, &args.bounds)?;
        keys.push(Key { path: k.clone(), lo, hi });
    }
    for b in &args.bounds {
        let k = b.split_once('=').map_or(b.as_str(), |(k, _)| k.trim());
        if !args.fit.iter().any(|f| f == k) {
            bail!("--bounds {b}: `{k}` is not among the fitted keys (--fit)");
        }
    }
    let measured_file = args.measured.display().to_string();
    let tensions = args.tension.clone();
    let problem = Problem {
        scenes,
        measured: read_measured(&args.measured, args.max_measured_bytes)?,
        measured_file,
        tensions,
        keys,
    };
    problem.check()?;
    let mut outputs = Outputs::new(inputs);
    let ids: Vec<_> = args
        .scenes
        .iter()
        .map(|f| {
            let name = f.file_name().with_context(|| format!("--scene {}: no file name", f.display()))?;
            outputs.declare("--out", &args.out.join(name), Some("toml"))
        })
        .collect::<anyhow::Result<_>>()?;
    let fit = problem.fit()?;
    outputs.open()?;
    for ((id, scene), file) in ids.iter().zip(&fit.scenes).zip(&args.scenes) {
        let text = portable(scene, file)?.to_toml();
        outputs.write(*id, |w| w.write_all(text.as_bytes()))?;
    }
    outputs.commit()?;

    let names: Vec<&str> = problem.keys.iter().map(|k| k.path.as_str()).collect();
    let mut out = std::io::stdout().lock();
    if args.json {
        let by_key = |v: &[f64]| -> serde_json::Map<String, serde_json::Value> {
            names.iter().zip(v).map(|(k, x)| ((*k).to_owned(), json!(x))).collect()
        };
        let by_key_maybe = |v: &[Option<f64>]| -> serde_json::Map<String, serde_json::Value> {
            names.iter().zip(v).map(|(k, x)| ((*k).to_owned(), json!(x))).collect()
        };
        let residuals: Vec<_> = problem
            .measured
            .iter()
            .zip(fit.computed_hz.iter().zip(&fit.paired_mode).zip(&fit.computed_zeta))
            .map(|(m, ((c, k), z))| {
                let mut r =
                    json!({"scene": m.scene, "mode": m.mode, "measured": m.f_hz, "computed": c, "computed_mode": k});
                if let Some(measured) = m.zeta {
                    r["measured_zeta"] = json!(measured);
                    r["computed_zeta"] = json!(z);
                }
                r
            })
            .collect();
        let j = json!({
            "fitted": by_key(&fit.values),
            "start": by_key(&fit.start),
            "std_error": fit.std_error.as_deref().map(by_key_maybe),
            "at_bound": fit.at_bound,
            "correlation": fit.correlation,
            "residuals": residuals,
            "cost": fit.cost,
            "start_cost": fit.start_cost,
            "iterations": fit.iterations,
            "singular_values": fit.singular_values,
            "condition": fit.condition,
            "unidentifiable": fit.unidentifiable,
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&j)?)?;
        return Ok(());
    }
    writeln!(out, "Calibration to {} measured modes, {} iterations", problem.measured.len(), fit.iterations)?;
    writeln!(out)?;
    let mut t = Table::new(["key", "start", "fitted", "std error"]);
    for (i, k) in names.iter().enumerate() {
        let sd = match fit.std_error.as_ref().map(|s| s[i]) {
            _ if fit.at_bound.iter().any(|b| b == k) => "at its bound".to_owned(),
            Some(Some(s)) => format!("{s:.4e}"),
            _ => "—".to_owned(),
        };
        t.row([(*k).to_owned(), format!("{:.6e}", fit.start[i]), format!("{:.6e}", fit.values[i]), sd]);
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    let by_shape = problem.measured.iter().any(|m| m.shape.is_some());
    let with_zeta = problem.measured.iter().any(|m| m.zeta.is_some());
    let mut header = vec!["scene", "mode", "measured Hz", "computed Hz", "miss %"];
    if with_zeta {
        header.extend(["measured ζ", "computed ζ"]);
    }
    let mut t = Table::new(header);
    for (((m, c), k), z) in problem.measured.iter().zip(&fit.computed_hz).zip(&fit.paired_mode).zip(&fit.computed_zeta)
    {
        // paired by shape, the computed mode's number follows the measured one's
        let mode = if by_shape { format!("{} ↔ {k}", m.mode) } else { m.mode.to_string() };
        let mut row = vec![
            m.scene.clone(),
            mode,
            format!("{:.5}", m.f_hz),
            format!("{c:.5}"),
            format!("{:+.3}", 100.0 * (c - m.f_hz) / m.f_hz),
        ];
        if with_zeta {
            let measured = m.zeta.map_or("—".to_owned(), |z| format!("{z:.5}"));
            let computed = if m.zeta.is_some() { format!("{z:.5}") } else { "—".to_owned() };
            row.extend([measured, computed]);
        }
        t.row(row);
    }
    write!(out, "{}", t.render())?;
    writeln!(out)?;
    writeln!(
        out,
        "cost (half the sum of the squared weighted relative misses): {:.4e} at the start, {:.4e} fitted",
        fit.start_cost, fit.cost
    )?;
    writeln!(out, "condition of the scaled Jacobian: {:.3e}", fit.condition)?;
    if fit.std_error.is_none() {
        writeln!(out, "no standard errors: no more measured modes than free keys, or a key the data do not determine")?;
    }
    if !fit.at_bound.is_empty() {
        writeln!(out, "at a bound (the data would take them further): {}", fit.at_bound.join(", "))?;
    }
    if !fit.unidentifiable.is_empty() {
        writeln!(out, "not identifiable from these modes: {}", fit.unidentifiable.join(", "))?;
    }
    writeln!(out, "updated scenes: {}", args.out.display())?;
    Ok(())
}
