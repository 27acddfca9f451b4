//! Shared set-up of the master's system tests: the FMUs packaged from the built libraries into
//! a private directory, and scenes whose [system] section points there.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use feedcore::scene::{Scene, ValidScene};
use fmi::import::Interface;
use studies::cosim::SystemSpec;
use studies::cosim::system::spec::{Component, Connection, Endpoint, Linear, Matching, Parameter, Value};

/// The directory holding `lib<crate>.so`: next to the test binary's `deps/` (cargo puts both
/// in `target/<profile>/`).
pub(crate) fn library(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    for dir in [deps, deps.parent().unwrap()] {
        let p = dir.join(format!("lib{name}.so"));
        if p.is_file() {
            return p;
        }
    }
    panic!("lib{name}.so not found next to {}: run `cargo build --release --workspace` first", exe.display());
}

/// The cable, Stewart and control FMUs, packaged once per test binary; their FMI 3.0 twins in
/// `fmi3/` below.
pub(crate) fn fmu_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("master-tests-{}", std::process::id()));
        let (cable, stewart) = (library("cable_fmu_cdylib"), library("stewart_fmu_cdylib"));
        fmi::package::package_model::<cable_fmu::CableFmu>(&dir, &cable).unwrap();
        fmi::package::package_model::<stewart_fmu::StewartFmu>(&dir, &stewart).unwrap();
        fmi::package::package_model3::<cable_fmu::CableFmu>(&dir.join("fmi3"), &cable).unwrap();
        fmi::package::package_model3::<stewart_fmu::StewartFmu>(&dir.join("fmi3"), &stewart).unwrap();
        // the second level's own FMU, beside the Stewart FMU (`export-ssp --controller fmu`)
        let control = library("control_fmu_cdylib");
        fmi::package::package_model::<control_fmu::ControlFmu>(&dir, &control).unwrap();
        fmi::package::package_model3::<control_fmu::ControlFmu>(&dir.join("fmi3"), &control).unwrap();
        dir
    })
}

/// The zoo's FMUs the Model Exchange tests use, and the hostile one, packaged once per test
/// binary; their FMI 3.0 versions in `fmi3/` below.
pub(crate) fn zoo_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("master-tests-zoo-{}", std::process::id()));
        fn both<M: fmi::export::Model>(dir: &Path, lib: &str) {
            let lib = library(lib);
            fmi::package::package_model::<M>(dir, &lib).unwrap();
            fmi::package::package_model3::<M>(&dir.join("fmi3"), &lib).unwrap();
        }
        both::<zoo_fmus::dahlquist::DahlquistFmu>(&dir, "zoo_dahlquist");
        both::<zoo_fmus::feedthrough::FeedthroughFmu>(&dir, "zoo_feedthrough");
        both::<zoo_fmus::bouncing_ball::BouncingBallFmu>(&dir, "zoo_bouncing_ball");
        both::<zoo_fmus::hostile::HostileFmu>(&dir, "zoo_hostile_me");
        dir
    })
}

/// The chain of docs/systems.md with `d1` as Model Exchange, or the loop with `d` as Model
/// Exchange, or the bouncing ball (Model Exchange, state events) into a feedthrough, or the
/// sampled system (Co-Simulation); FMI `version`.
pub(crate) fn me_system(which: &str, version: u8) -> SystemSpec {
    let zoo = if version == 3 { zoo_dir().join("fmi3") } else { zoo_dir().to_owned() };
    let component = |name: &str, fmu: &str, me: bool| Component {
        name: name.into(),
        source: zoo.join(format!("{fmu}.fmu")),
        interface: me.then_some(Interface::ModelExchange),
        step: None,
    };
    let e = |c: &str, v: &str| Endpoint { component: c.into(), variable: v.into() };
    let connect = |from: Endpoint, to: Endpoint, factor: Option<f64>| Connection {
        from,
        to,
        matching: Matching::Exact,
        transform: factor.map(|factor| Linear { factor, offset: 0.0 }),
    };
    let real = |c: &str, v: &str, x: f64| Parameter { target: e(c, v), value: Value::Typed(fmi::Value::Real(x)) };
    let (components, connections, parameters) = match which {
        "chain" => (
            vec![
                component("d1", "dahlquist", true),
                component("f", "feedthrough", false),
                component("d2", "dahlquist", false),
            ],
            vec![
                connect(e("d1", "x"), e("f", "real_continuous_in"), None),
                connect(e("f", "real_continuous_out"), e("d2", "u"), None),
            ],
            vec![real("d1", "x0", 0.0), real("d1", "u", 1.0), real("d2", "k", 2.0), real("d2", "x0", 0.0)],
        ),
        "loop" => (
            vec![component("d", "dahlquist", true), component("f", "feedthrough", false)],
            vec![
                connect(e("d", "der_x"), e("f", "real_continuous_in"), Some(-2.0)),
                connect(e("f", "real_continuous_out"), e("d", "u"), None),
            ],
            vec![],
        ),
        // tests/systems/sampled.ssd: a sampler `c` on Dahlquist's `p` (the periods are set by the
        // caller: `Coupled::set_periods`)
        "sampled" => (
            vec![component("p", "dahlquist", false), component("c", "feedthrough", false)],
            vec![
                connect(e("p", "x"), e("c", "real_continuous_in"), None),
                connect(e("c", "real_continuous_out"), e("p", "u"), Some(-2.0)),
            ],
            vec![],
        ),
        _ => (
            vec![component("ball", "bouncing_ball", true), component("f", "feedthrough", false)],
            vec![connect(e("ball", "h"), e("f", "real_continuous_in"), None)],
            vec![],
        ),
    };
    SystemSpec {
        origin: format!("{which} (FMI {version})"),
        components,
        connections,
        parameters,
        connectors: Vec::new(),
        observed: Vec::new(),
        watch: Vec::new(),
        kink_at_start: false,
    }
}

/// The `.ssd` text of SSP 1.0 system `name`: these elements and connections (SSD text, a line
/// each) and a default experiment from 0 to `stop_time`.
pub(crate) fn ssd_text(name: &str, elements: &str, connections: &str, stop_time: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="{name}">
  <ssd:System name="{name}">
    <ssd:Elements>
{elements}
    </ssd:Elements>
    <ssd:Connections>
{connections}
    </ssd:Connections>
  </ssd:System>
  <ssd:DefaultExperiment startTime="0" stopTime="{stop_time}"/>
</ssd:SystemStructureDescription>
"#
    )
}

/// A component's `<ssd:ParameterBindings>` of one inline parameter set `name`: each parameter as
/// (name, SSV type, value).
pub(crate) fn parameter_bindings(name: &str, parameters: &[(&str, &str, String)]) -> String {
    let parameters: Vec<String> = parameters
        .iter()
        .map(|(p, t, v)| {
            format!(r#"                  <ssv:Parameter name="{p}"><ssv:{t} value="{v}"/></ssv:Parameter>"#)
        })
        .collect();
    format!(
        r#"        <ssd:ParameterBindings>
          <ssd:ParameterBinding>
            <ssd:ParameterValues>
              <ssv:ParameterSet version="1.0" name="{name}">
                <ssv:Parameters>
{}
                </ssv:Parameters>
              </ssv:ParameterSet>
            </ssd:ParameterValues>
          </ssd:ParameterBinding>
        </ssd:ParameterBindings>"#,
        parameters.join("\n")
    )
}

pub(crate) fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(format!("{}/../scenes/{name}", env!("CARGO_MANIFEST_DIR")))
}

/// A reference scene, edited by `edit`, written to a private file whose [system] names the
/// packaged FMUs; returns the scene and its file.
pub(crate) fn scene(name: &str, tag: &str, edit: impl FnOnce(&mut Scene)) -> (ValidScene, PathBuf) {
    let file = scene_file(name, tag, edit);
    (Scene::load(&file).unwrap(), file)
}

/// As [`scene`], without validating the edited scene (for scenes the command must refuse).
pub(crate) fn scene_file(name: &str, tag: &str, edit: impl FnOnce(&mut Scene)) -> PathBuf {
    let mut s = Scene::load(scene_path(name)).unwrap().to_scene();
    edit(&mut s);
    let dir = fmu_dir();
    for f in s.system.iter_mut().flat_map(|system| &mut system.fmus) {
        f.path = dir.join(format!("{}_fmu.fmu", f.name)).display().to_string();
    }
    let file = dir.join(format!("{tag}-{name}"));
    std::fs::write(&file, s.to_toml()).unwrap();
    file
}
