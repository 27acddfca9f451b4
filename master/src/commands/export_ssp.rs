//! `master export-ssp --scene F --out F.ssp`: the scene's co-simulated system as an SSP 1.0
//! archive — both FMUs, every connection (one output to one input), the parameter values — that
//! `master run --system` runs with the same result as `--scene`, and other SSP tools load.
//!
//! `--fmi 3` packs the FMI 3.0 twins of the scene's FMUs (`fmi3/<name>.fmu` beside each, as
//! `master package` writes them) instead.
//!
//! `--controller fmu` takes the second level out of the Stewart FMU into a third component,
//! `control` (`control_fmu.fmu` beside the Stewart FMU): the cabin's motion feeds it, its command
//! the Stewart FMU (`command_input = true`); every component carries its step (libcosim's
//! `osp:StepSizeHint` annotation): the scene's step for the cable and Stewart FMUs, the
//! controller's command period for `control`.
//!
//! The scene file itself travels inside each FMU that reads it (`resources/exported_scene.toml`,
//! the parameter set to that relative name, which the FMU resolves against its resources), so
//! the archive stands alone.

use std::io::{Cursor, Write};
use std::path::PathBuf;

use anyhow::Context;
use cosim::ssp::write::{SspComponent, SspConnector, SspSystem, with_resource, write_archive};
use cosim::system::fmu::resolve;
use cosim::system::spec::{Component, Connection, Endpoint, Matching, Parameter, Value};
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
    /// The second level: `builtin` (in the Stewart FMU), `fmu` (a third component, `control`:
    /// control_fmu beside the Stewart FMU, at its command period; the Stewart FMU follows its
    /// command), or the path of a controller FMU of your own (`.fmu`: inputs `cabin.*`, outputs
    /// `command.r`, `command.rot`, as control_fmu's; docs/controllers.md), put in as `control` at
    /// the scene's command period.
    #[arg(long, default_value = "builtin", value_name = "builtin|fmu|FILE.fmu")]
    pub(crate) controller: String,
}

/// What `--controller` puts in.
enum Controller {
    Builtin,
    /// control_fmu, beside the Stewart FMU.
    Shipped,
    /// An FMU of the user's.
    Own(PathBuf),
}

impl Controller {
    fn parse(text: &str) -> anyhow::Result<Controller> {
        match text {
            "builtin" => Ok(Controller::Builtin),
            "fmu" => Ok(Controller::Shipped),
            path if path.ends_with(".fmu") => {
                let path = PathBuf::from(path);
                anyhow::ensure!(path.is_file(), "--controller {}: no such file", path.display());
                Ok(Controller::Own(path))
            }
            other => anyhow::bail!(
                "--controller {other}: give `builtin`, `fmu` (the shipped control_fmu) or the path of a controller FMU \
                 (FILE.fmu)"
            ),
        }
    }
}

/// The name of the controller's component with `--controller fmu`.
pub(crate) const CONTROL: &str = "control";

/// The scene's system with its second level as a component of its own: `control` (control_fmu
/// beside the Stewart FMU) between the cable FMU's cabin motion and the Stewart FMU's command;
/// every component with its step. Returns the system and the names of the parameters that hand
/// the scene over.
fn with_controller(
    scene: &feedcore::scene::ValidScene,
    mut spec: cosim::SystemSpec,
    reads_scene: &mut Vec<String>,
    own: Option<&std::path::Path>,
) -> anyhow::Result<cosim::SystemSpec> {
    let control = scene.control.as_ref().with_context(|| {
        format!("--controller fmu: scene `{}` has no [control] (the second level to take out, its rate)", scene.name)
    })?;
    anyhow::ensure!(
        control.sensor == feedcore::scene::SensorKind::Sampled,
        "--controller fmu: scene `{}` has [control] sensor = {:?}; a controller of its own samples the cabin: \
         sensor = \"sampled\"",
        scene.name,
        control.sensor
    );
    let model = stewart::Stewart::from_scene(scene)?;
    let period = model.compensation().context("the platform has no second level")?.step_period().0;
    let component = |name: &str| spec.components.iter().position(|c| c.name == name);
    let (Some(cable), Some(platform)) = (component("cable"), component("stewart")) else {
        anyhow::bail!("--controller fmu: the scene's [system] must name its FMUs `cable` and `stewart`");
    };
    let source = match own {
        Some(path) => path.to_owned(),
        None => spec.components[platform].source.with_file_name("control_fmu.fmu"),
    };
    anyhow::ensure!(
        source.is_file(),
        "{}: the controller's FMU is missing (`master package --out DIR` writes it beside the Stewart FMU)",
        source.display()
    );
    let dt = scene.solver.dt_s;
    spec.components[cable].step = Some(dt);
    spec.components[platform].step = Some(dt);
    spec.components.push(Component { name: CONTROL.into(), source, interface: None, step: Some(period) });
    let end = |component: &str, variable: &str| Endpoint { component: component.into(), variable: variable.into() };
    for (from, to) in
        [(end("cable", "cabin"), end(CONTROL, "cabin")), (end(CONTROL, "command"), end("stewart", "command"))]
    {
        spec.connections.push(Connection { from, to, matching: Matching::Prefix, transform: None });
    }
    spec.parameters
        .push(Parameter { target: end("stewart", "command_input"), value: Value::Typed(fmi::Value::Boolean(true)) });
    if own.is_some() {
        // a controller of the user's takes what it takes from its own parameters
        return Ok(spec);
    }
    let scene_value = spec
        .parameters
        .iter()
        .find(|p| p.target.component == "stewart" && p.target.variable == "scene")
        .map(|p| p.value.clone())
        .context("the scene's [system] hands the Stewart FMU no scene")?;
    spec.parameters.push(Parameter { target: end(CONTROL, "scene"), value: scene_value });
    if reads_scene.iter().any(|k| k == "stewart.scene") {
        reads_scene.push(format!("{CONTROL}.scene"));
    }
    Ok(spec)
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
    let controller = Controller::parse(&args.controller)?;
    let mut spec = scene_spec(&scene, &args.file.scene)?;
    if args.fmi == 3 {
        for c in &mut spec.components {
            c.source = fmi3_twin(&c.source)?;
        }
    }
    let sys = scene.system.as_ref().expect("scene_spec needs a [system]");
    // the parameters that hand the FMUs the scene (`@scene`)
    let mut reads_scene: Vec<String> =
        sys.parameters.iter().filter(|(_, v)| *v == "@scene").map(|(k, _)| k.clone()).collect();
    match &controller {
        Controller::Builtin => {}
        Controller::Shipped => spec = with_controller(&scene, spec, &mut reads_scene, None)?,
        Controller::Own(path) => spec = with_controller(&scene, spec, &mut reads_scene, Some(path))?,
    }
    let resolved = resolve(&spec)?;
    let scene_bytes =
        std::fs::read(&args.file.scene).with_context(|| format!("{}: cannot read", args.file.scene.display()))?;
    let mut components = Vec::new();
    for c in &spec.components {
        let reads = reads_scene.iter().any(|k| k.split_once('.').is_some_and(|(f, _)| f == c.name));
        let fmu = if reads {
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
            let value = if reads_scene.contains(&key) {
                Value::Typed(fmi::Value::String(SCENE_RESOURCE.into()))
            } else {
                p.value.clone()
            };
            parameters.push((p.target.variable.clone(), value));
        }
        components.push(SspComponent { name: c.name.clone(), fmu, connectors, parameters, step: c.step });
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
