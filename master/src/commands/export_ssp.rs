//! `master export-ssp --scene F --out F.ssp`: the scene's co-simulated system as an SSP 1.0
//! archive — both FMUs, every connection (one output to one input), the parameter values — that
//! `master run --system` runs with the same result as `--scene`, and other SSP tools load.
//!
//! `--fmi 3` packs the FMI 3.0 twins of the scene's FMUs (`fmi3/<name>.fmu` beside each, as
//! `master package` writes them) instead.
//!
//! The scene file itself travels inside each FMU that reads it (`resources/exported_scene.toml`,
//! the parameter set to that relative name, which the FMU resolves against its resources), so
//! the archive stands alone.

use std::io::{Cursor, Write};
use std::path::PathBuf;

use anyhow::Context;
use cosim::ssp::write::{SspComponent, SspConnector, SspSystem, with_resource, write_archive};
use cosim::system::fmu::resolve;
use cosim::system::spec::Value;
use studies::system::scene_spec;

use super::args::SceneFile;
use super::output::{Outputs, run_inputs};
use super::{CmdResult, load_scene};

/// The name of the scene file inside the FMUs' resources.
pub(crate) const SCENE_RESOURCE: &str = "exported_scene.toml";

#[derive(clap::Args)]
pub(crate) struct Args {
    #[command(flatten)]
    pub(crate) file: SceneFile,
    /// The SSP archive to write (`.ssp`).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// The FMI version of the FMUs packed: 2 (the scene's FMUs) or 3 (their FMI 3.0 twins,
    /// `fmi3/<name>.fmu` beside each).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(2..=3))]
    pub(crate) fmi: u32,
}

/// The FMI 3.0 twin of a workspace FMU: `<dir>/fmi3/<name>.fmu`, as `master package` writes it.
fn fmi3_twin(fmu: &std::path::Path) -> anyhow::Result<PathBuf> {
    let twin = fmu
        .parent()
        .map(|d| d.join(super::package::FMI3_DIR))
        .zip(fmu.file_name())
        .map(|(d, n)| d.join(n))
        .with_context(|| format!("{}: not a file path", fmu.display()))?;
    anyhow::ensure!(
        twin.is_file(),
        "{}: the FMI 3.0 twin of {} is missing (`master package --out DIR` writes both versions)",
        twin.display(),
        fmu.display()
    );
    Ok(twin)
}

pub(crate) fn run(args: &Args) -> CmdResult {
    let scene = load_scene(&args.file.scene)?;
    let mut outputs = Outputs::new(run_inputs(&args.file.scene, &scene));
    let id = outputs.declare("--out", &args.out, Some("ssp"))?;
    let mut spec = scene_spec(&scene, &args.file.scene)?;
    if args.fmi == 3 {
        for c in &mut spec.components {
            c.source = fmi3_twin(&c.source)?;
        }
    }
    let sys = scene.system.as_ref().expect("scene_spec needs a [system]");
    let resolved = resolve(&spec)?;
    let scene_bytes =
        std::fs::read(&args.file.scene).with_context(|| format!("{}: cannot read", args.file.scene.display()))?;
    let mut components = Vec::new();
    for c in &spec.components {
        let reads_scene =
            sys.parameters.iter().any(|(k, v)| v == "@scene" && k.split_once('.').is_some_and(|(f, _)| f == c.name));
        let fmu = if reads_scene {
            with_resource(&c.source, SCENE_RESOURCE, &scene_bytes)?
        } else {
            std::fs::read(&c.source).with_context(|| format!("{}: cannot read", c.source.display()))?
        };
        let mut connectors: Vec<SspConnector> = Vec::new();
        let mut add = |name: &str, kind: &'static str, var_type| {
            if !connectors.iter().any(|k| k.name == name) {
                connectors.push(SspConnector { name: name.to_owned(), kind, var_type });
            }
        };
        for l in &resolved.connections {
            if l.from.component == c.name {
                add(&l.from.variable, "output", l.var_type);
            }
            if l.to.component == c.name {
                add(&l.to.variable, "input", l.var_type);
            }
        }
        let mut parameters = Vec::new();
        for (p, var_type, _) in resolved.parameters.iter().filter(|p| p.0.target.component == c.name) {
            add(&p.target.variable, "parameter", *var_type);
            let key = format!("{}.{}", c.name, p.target.variable);
            let value = if sys.parameters.get(&key).is_some_and(|v| v == "@scene") {
                Value::Typed(fmi::Value::String(SCENE_RESOURCE.into()))
            } else {
                p.value.clone()
            };
            parameters.push((p.target.variable.clone(), value));
        }
        components.push(SspComponent { name: c.name.clone(), fmu, connectors, parameters });
    }
    let system = SspSystem {
        name: scene.name.clone(),
        components,
        connections: resolved.connections,
        start_time: 0.0,
        stop_time: scene.solver.t_end_s,
        // an adaptive run of the archive watches what one of the scene does, and a fixed-step
        // run takes its first step as the scene's does
        watch: studies::simulate::CABIN_POSE.map(String::from).to_vec(),
        kink_at_start: spec.kink_at_start,
    };
    let archive = write_archive(Cursor::new(Vec::new()), &system).context("packing the archive")?.into_inner();
    outputs.open()?;
    outputs.write(id, |w| w.write_all(&archive))?;
    outputs.commit()?;
    writeln!(
        std::io::stdout().lock(),
        "{}: {} components, {} connections, {} parameter values",
        args.out.display(),
        system.components.len(),
        system.connections.len(),
        system.components.iter().map(|c| c.parameters.len()).sum::<usize>()
    )?;
    Ok(())
}
