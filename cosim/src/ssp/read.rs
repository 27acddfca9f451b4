//! Reading SSP 1.0: an `.ssp` archive (its `SystemStructure.ssd`) or an `.ssd` file with the
//! FMUs it names beside it, into a [`SystemSpec`].
//!
//! Supported: one system of FMU components; their connectors (Real, Integer, Boolean, String;
//! type and unit checked against the FMU); connections between component connectors, with an
//! optional `LinearTransformation` on Real ones; parameter bindings inline
//! (`ParameterValues`) or in `.ssv` files, with an optional prefix; `DefaultExperiment`.
//! Refused with a message: nested systems, connections to the system's own connectors,
//! parameter mappings, enumeration and boolean/integer mapping transformations, duplicate
//! component names; files outside the archive (or the `.ssd`'s folder) unless
//! [`ReadLimits::allow_external`]. Of an archive only what the system names is unpacked. A
//! component's `implementation` (Model Exchange or Co-Simulation) is honoured. Annotations are
//! ignored but this master's own ([`super::ADAPTIVE_ANNOTATION`], [`super::START_ANNOTATION`],
//! [`super::INTERFACE_ANNOTATION`]).

use std::path::{Path, PathBuf};

use fmi::VarType;
use roxmltree::{Document, Node};

use crate::error::SetupError;
use crate::system::spec::{Component, Connection, Connector, Endpoint, Linear, Matching, Parameter, SystemSpec, Value};

use super::TempDir;

/// A system read from SSP, with its default experiment.
pub struct LoadedSsp {
    pub spec: SystemSpec,
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    /// The unpacked archive (kept while the FMUs are loaded from it).
    _unpacked: Option<TempDir>,
}

fn invalid(file: &Path, message: String) -> SetupError {
    SetupError::File { path: file.to_owned(), message }
}

/// What reading a system may cost, and where its files may come from.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadLimits {
    /// The most entries an `.ssp` archive may hold.
    pub max_entries: usize,
    /// The most bytes unpacked from an archive: the entries the system references.
    pub max_unpacked_bytes: u64,
    /// Whether a component or parameter file may lie outside the archive (or, for an `.ssd`,
    /// outside its folder): off, so a system cannot make the master load a library from
    /// anywhere on the machine.
    pub allow_external: bool,
}

impl Default for ReadLimits {
    fn default() -> ReadLimits {
        ReadLimits { max_entries: 10_000, max_unpacked_bytes: 1 << 30, allow_external: false }
    }
}

/// The name of the system description at an archive's root.
const SSD_ENTRY: &str = "SystemStructure.ssd";

/// Reads an `.ssp` archive or an `.ssd` file, within the default [`ReadLimits`].
pub fn load(path: &Path) -> Result<LoadedSsp, SetupError> {
    load_within(path, &ReadLimits::default())
}

/// Reads an `.ssp` archive or an `.ssd` file. Of an archive only what its system references is
/// unpacked (the description, the FMUs, the parameter files), within `limits`.
pub fn load_within(path: &Path, limits: &ReadLimits) -> Result<LoadedSsp, SetupError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    match ext {
        "ssp" => {
            let file = std::fs::File::open(path).map_err(|e| invalid(path, format!("cannot open: {e}")))?;
            let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
                .map_err(|e| invalid(path, format!("not a valid zip archive: {e}")))?;
            let dir =
                TempDir::new("ssp").map_err(|e| invalid(path, format!("cannot create a temporary directory: {e}")))?;
            // a file inside the archive is named as the archive's entry, not by where it was unpacked
            let inside = |e: SetupError| match e {
                SetupError::File { path: file, message } if file.starts_with(dir.path()) => {
                    let entry = file.strip_prefix(dir.path()).unwrap_or(&file).display().to_string();
                    invalid(path, format!("{entry}: {message}"))
                }
                other => other,
            };
            unpack_referenced(path, &mut zip, dir.path(), limits).map_err(inside)?;
            let mut loaded =
                read_ssd(&dir.path().join(SSD_ENTRY), &path.display().to_string(), limits).map_err(inside)?;
            loaded._unpacked = Some(dir);
            Ok(loaded)
        }
        "ssd" => read_ssd(path, &path.display().to_string(), limits),
        _ => Err(invalid(path, "give an SSP 1.0 system: an `.ssp` archive or an `.ssd` file".into())),
    }
}

/// Unpacks into `dir` the archive's `SystemStructure.ssd` and the entries its components and
/// parameter bindings name (an FMU, or a folder of an unpacked one), nothing else.
fn unpack_referenced<R: std::io::Read + std::io::Seek>(
    archive: &Path,
    zip: &mut zip::ZipArchive<R>,
    dir: &Path,
    limits: &ReadLimits,
) -> Result<(), SetupError> {
    if zip.len() > limits.max_entries {
        return Err(invalid(
            archive,
            format!(
                "{} entries, more than the {} allowed (--max-archive-entries raises the cap)",
                zip.len(),
                limits.max_entries
            ),
        ));
    }
    if zip.has_duplicate_names() {
        return Err(invalid(
            archive,
            format!(
                "the archive lists an entry name twice (two {SSD_ENTRY}, or two files of one name): \
                 which one is meant is ambiguous; rebuild the archive"
            ),
        ));
    }
    let names: Vec<String> = zip.file_names().filter_map(Result::ok).map(|n| n.into_owned()).collect();
    if !names.iter().any(|n| n == SSD_ENTRY) {
        return Err(invalid(archive, format!("the archive holds no {SSD_ENTRY} at its root")));
    }
    let mut budget = limits.max_unpacked_bytes;
    let mut unpack = |name: &str, budget: &mut u64| -> Result<(), SetupError> {
        fmi::archive::unpack_entry(zip, name, dir, budget, limits.max_unpacked_bytes).map_err(|e| match e {
            fmi::archive::UnpackError::TooLarge { .. } => invalid(
                archive,
                format!(
                    "unpacking `{name}` exceeds the {} MB the system's entries may take together \
                     (--max-unpacked-mb raises the cap)",
                    limits.max_unpacked_bytes >> 20
                ),
            ),
            other => invalid(archive, other.to_string()),
        })
    };
    unpack(SSD_ENTRY, &mut budget)?;
    let ssd = dir.join(SSD_ENTRY);
    let text = std::fs::read_to_string(&ssd).map_err(|e| invalid(&ssd, format!("cannot read: {e}")))?;
    // each entry once, however many components share it
    let mut wanted = std::collections::BTreeSet::new();
    for source in referenced_sources(&ssd, &text)? {
        let Some(inside) = inside(&decode_uri(&source)) else {
            if limits.allow_external {
                continue; // read from where it points, as allowed
            }
            return Err(invalid(archive, outside_message(&source, "the archive")));
        };
        let key = inside.to_string_lossy().replace('\\', "/");
        let folder = format!("{key}/");
        let mut named = names.iter().filter(|n| n.trim_end_matches('/') == key || n.starts_with(&folder)).peekable();
        if named.peek().is_none() {
            return Err(invalid(archive, format!("`{source}`, named in {SSD_ENTRY}, is not in the archive")));
        }
        wanted.extend(named);
    }
    for name in wanted {
        unpack(name, &mut budget)?;
    }
    Ok(())
}

/// The `source` of every component and parameter binding of a description.
fn referenced_sources(ssd: &Path, text: &str) -> Result<Vec<String>, SetupError> {
    let doc = Document::parse(text).map_err(|e| invalid(ssd, format!("not well-formed XML: {e}")))?;
    let referencing = |n: &Node| matches!(n.tag_name().name(), "Component" | "ParameterBinding");
    Ok(doc
        .descendants()
        .filter(|n| n.is_element() && referencing(n))
        .filter_map(|n| n.attribute("source").map(str::to_owned))
        .collect())
}

/// `path` without `.` and with `..` resolved, if it is relative and stays inside its folder.
fn inside(path: &Path) -> Option<PathBuf> {
    use std::path::Component::*;
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Normal(p) => out.push(p),
            CurDir => {}
            ParentDir if out.pop() => {}
            ParentDir | RootDir | Prefix(_) => return None,
        }
    }
    (!out.as_os_str().is_empty()).then_some(out)
}

fn outside_message(source: &str, container: &str) -> String {
    format!(
        "`{source}` lies outside {container}: a system loads its FMUs and parameter files from its own \
         files only, unless --allow-external-fmus says otherwise"
    )
}

/// The position of a node, for messages.
fn at(doc: &Document, n: Node) -> String {
    let p = doc.text_pos_at(n.range().start);
    format!("line {}", p.row)
}

fn children<'a, 'i>(n: Node<'a, 'i>, name: &'static str) -> impl Iterator<Item = Node<'a, 'i>> {
    n.children().filter(move |c| c.is_element() && c.tag_name().name() == name)
}

fn child<'a, 'i>(n: Node<'a, 'i>, name: &'static str) -> Option<Node<'a, 'i>> {
    children(n, name).next()
}

/// The interface a component is to run as: SSP's own `implementation` attribute
/// (`ModelExchange` or `CoSimulation`: that one must be used; `any`, the default, leaves the
/// choice to the master), or this master's annotation [`super::INTERFACE_ANNOTATION`] (`<Interface
/// implementation="…"/>`, which other tools skip). Both, differing, is a contradiction.
fn component_interface<'a, 'i>(
    component: Node<'a, 'i>,
) -> Result<Option<fmi::import::Interface>, (Node<'a, 'i>, String)> {
    use fmi::import::Interface;
    let parse = |n: Node<'a, 'i>| match n.attribute("implementation") {
        None | Some("any") => Ok(None),
        Some("ModelExchange") => Ok(Some(Interface::ModelExchange)),
        Some("CoSimulation") => Ok(Some(Interface::CoSimulation)),
        Some(other) => Err((n, format!("implementation `{other}`: ModelExchange, CoSimulation or any"))),
    };
    let standard = parse(component)?;
    let mut ours = None;
    let annotations = child(component, "Annotations").into_iter().flat_map(|a| children(a, "Annotation"));
    for a in annotations.filter(|a| a.attribute("type") == Some(super::INTERFACE_ANNOTATION)) {
        for i in children(a, "Interface") {
            if i.attribute("implementation").is_none() {
                return Err((i, "<Interface> without `implementation`".into()));
            }
            ours = parse(i)?;
            if let (Some(s), Some(o)) = (standard, ours)
                && s != o
            {
                return Err((i, format!("the annotation asks for {o:?}, the `implementation` attribute for {s:?}")));
            }
        }
    }
    Ok(standard.or(ours))
}

fn read_ssd(ssd: &Path, origin: &str, limits: &ReadLimits) -> Result<LoadedSsp, SetupError> {
    let text = std::fs::read_to_string(ssd).map_err(|e| invalid(ssd, format!("cannot read: {e}")))?;
    let doc = Document::parse(&text).map_err(|e| invalid(ssd, format!("not well-formed XML: {e}")))?;
    let root = doc.root_element();
    let fail = |n: Node, m: String| invalid(ssd, format!("{}: {m}", at(&doc, n)));
    if root.tag_name().name() != "SystemStructureDescription" {
        return Err(fail(
            root,
            format!("root element <{}>, expected <ssd:SystemStructureDescription>", root.tag_name().name()),
        ));
    }
    let version = root.attribute("version").unwrap_or("");
    if !(version == "1.0" || version.starts_with("1.0.")) {
        return Err(fail(root, format!("SSP version `{version}`; this master reads SSP 1.0")));
    }
    let base = ssd.parent().unwrap_or(Path::new(".")).to_owned();
    let resolve = |n: Node, source: &str| resolve_source(&base, source, limits.allow_external).map_err(|m| fail(n, m));
    let system = child(root, "System").ok_or_else(|| fail(root, "no <ssd:System>".into()))?;
    if child(system, "ParameterBindings").is_some() {
        return Err(fail(
            system,
            "parameter bindings on the system itself are not supported; bind them to its components".into(),
        ));
    }
    let mut spec = SystemSpec {
        origin: origin.to_owned(),
        components: Vec::new(),
        connections: Vec::new(),
        parameters: Vec::new(),
        connectors: Vec::new(),
        observed: Vec::new(),
        watch: Vec::new(),
        kink_at_start: false,
    };
    // declared connector kinds, to orient connections output → input
    let mut kinds: Vec<(Endpoint, String)> = Vec::new();
    if let Some(elements) = child(system, "Elements") {
        for e in elements.children().filter(|c| c.is_element()) {
            let name = e.attribute("name").ok_or_else(|| fail(e, "an element without `name`".into()))?;
            match e.tag_name().name() {
                "Component" => {}
                "System" => {
                    return Err(fail(e, format!("`{name}` is a nested system; only flat systems are supported")));
                }
                other => return Err(fail(e, format!("element <{other}> `{name}` is not supported"))),
            }
            let mime = e.attribute("type").unwrap_or("application/x-fmu-sharedlibrary");
            if mime != "application/x-fmu-sharedlibrary" {
                return Err(fail(e, format!("component `{name}` has type `{mime}`; only FMUs are supported")));
            }
            let source = e.attribute("source").ok_or_else(|| fail(e, format!("component `{name}` has no `source`")))?;
            if spec.components.iter().any(|c| c.name == name) {
                return Err(fail(e, format!("a second component named `{name}`: component names must be unique")));
            }
            let interface = component_interface(e).map_err(|(n, m)| fail(n, format!("component `{name}`: {m}")))?;
            spec.components.push(Component { name: name.to_owned(), source: resolve(e, source)?, interface });
            if let Some(connectors) = child(e, "Connectors") {
                for c in children(connectors, "Connector") {
                    let cname = c.attribute("name").ok_or_else(|| fail(c, "a connector without `name`".into()))?;
                    let endpoint = Endpoint { component: name.to_owned(), variable: cname.to_owned() };
                    kinds.push((endpoint.clone(), c.attribute("kind").unwrap_or("").to_owned()));
                    let Some(ty) = c.children().find(|t| t.is_element() && t.tag_name().name() != "ConnectorGeometry")
                    else {
                        continue; // the type is optional: the FMU's
                    };
                    let var_type = match ty.tag_name().name() {
                        "Real" => VarType::Real,
                        "Integer" => VarType::Integer,
                        "Boolean" => VarType::Boolean,
                        "String" => VarType::String,
                        other => {
                            return Err(fail(ty, format!("connector `{endpoint}`: type <{other}> is not supported")));
                        }
                    };
                    spec.connectors.push(Connector {
                        endpoint,
                        var_type,
                        unit: ty.attribute("unit").map(str::to_owned),
                    });
                }
            }
            if let Some(bindings) = child(e, "ParameterBindings") {
                for b in children(bindings, "ParameterBinding") {
                    let file = b.attribute("source").map(|source| resolve(b, source)).transpose()?;
                    read_binding(&doc, ssd, file.as_deref(), name, b, &mut spec.parameters)?;
                }
            }
        }
    }
    if let Some(connections) = child(system, "Connections") {
        for c in children(connections, "Connection") {
            let end = |el: &str, co: &str| -> Result<Endpoint, SetupError> {
                let element = c.attribute(el).ok_or_else(|| {
                    fail(
                        c,
                        format!(
                            "a connection without `{el}`: connections to the system's own connectors are not supported"
                        ),
                    )
                })?;
                let connector = c.attribute(co).ok_or_else(|| fail(c, format!("a connection without `{co}`")))?;
                Ok(Endpoint { component: element.to_owned(), variable: connector.to_owned() })
            };
            let (mut from, mut to) = (end("startElement", "startConnector")?, end("endElement", "endConnector")?);
            let kind = |e: &Endpoint| kinds.iter().find(|k| &k.0 == e).map(|k| k.1.as_str());
            if kind(&from) == Some("input") && kind(&to) == Some("output") {
                std::mem::swap(&mut from, &mut to);
            }
            let mut transform = None;
            for t in c.children().filter(|t| t.is_element()) {
                match t.tag_name().name() {
                    "LinearTransformation" => {
                        let num = |a: &str, default: f64| -> Result<f64, SetupError> {
                            t.attribute(a).map_or(Ok(default), |v| {
                                v.trim()
                                    .parse()
                                    .map_err(|_| fail(t, format!("LinearTransformation `{a}` = `{v}` is not a number")))
                            })
                        };
                        transform = Some(Linear { factor: num("factor", 1.0)?, offset: num("offset", 0.0)? });
                    }
                    "ConnectionGeometry" | "Annotations" => {}
                    other => {
                        return Err(fail(t, format!("connection {from} → {to}: <{other}> is not supported")));
                    }
                }
            }
            spec.connections.push(Connection { from, to, matching: Matching::Exact, transform });
        }
    }
    // this master's own annotations (others are left alone, as SSP allows)
    let ours = |kind: &'static str| {
        child(system, "Annotations")
            .into_iter()
            .flat_map(|a| children(a, "Annotation"))
            .filter(move |a| a.attribute("type") == Some(kind))
    };
    for start in ours(super::START_ANNOTATION).flat_map(|a| children(a, "Start")) {
        spec.kink_at_start = match start.attribute("kink") {
            Some("true" | "1") => true,
            Some("false" | "0") => false,
            other => return Err(fail(start, format!("<Start kink=…> is `{}`; true or false", other.unwrap_or("")))),
        };
    }
    for adaptive in ours(super::ADAPTIVE_ANNOTATION).flat_map(|a| children(a, "Adaptive")) {
        for w in children(adaptive, "Watch") {
            let name = w.attribute("name").ok_or_else(|| fail(w, "<Watch> without `name`".into()))?;
            spec.watch.push(name.to_owned());
        }
    }
    let experiment = child(root, "DefaultExperiment");
    let time = |a: &str| -> Result<Option<f64>, SetupError> {
        match experiment.and_then(|e| e.attribute(a)) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| invalid(ssd, format!("DefaultExperiment `{a}` = `{v}` is not a number"))),
        }
    };
    Ok(LoadedSsp { start_time: time("startTime")?, stop_time: time("stopTime")?, spec, _unpacked: None })
}

/// A URI's path: `file:` stripped, percent-decoded.
fn decode_uri(uri: &str) -> PathBuf {
    let path = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")).unwrap_or(uri);
    let mut bytes = Vec::with_capacity(path.len());
    let raw = path.as_bytes();
    let mut i = 0;
    while i < raw.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if raw[i] == b'%'
            && i + 2 < raw.len()
            && let (Some(h), Some(l)) = (hex(raw[i + 1]), hex(raw[i + 2]))
        {
            bytes.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        bytes.push(raw[i]);
        i += 1;
    }
    PathBuf::from(String::from_utf8_lossy(&bytes).into_owned())
}

/// A `source` URI against the directory of the `.ssd`: inside it (no `..` out of it, no symbolic
/// link out of it) unless `allow_external`.
fn resolve_source(base: &Path, uri: &str, allow_external: bool) -> Result<PathBuf, String> {
    let path = decode_uri(uri);
    if allow_external {
        return Ok(if path.is_absolute() { path } else { base.join(path) });
    }
    let within = inside(&path).map(|p| base.join(p)).ok_or_else(|| outside_message(uri, "the system's folder"))?;
    // a link may lead out of the folder: compare where both really are (a missing file is the
    // loader's to report)
    if let (Ok(real), Ok(folder)) = (within.canonicalize(), base.canonicalize())
        && !real.starts_with(&folder)
    {
        return Err(outside_message(uri, "the system's folder"));
    }
    Ok(within)
}

/// A parameter binding: from `file` (its `source`, resolved) or inline values.
fn read_binding(
    doc: &Document,
    ssd: &Path,
    file: Option<&Path>,
    component: &str,
    b: Node,
    out: &mut Vec<Parameter>,
) -> Result<(), SetupError> {
    let fail = |n: Node, m: String| invalid(ssd, format!("{}: {m}", at(doc, n)));
    if child(b, "ParameterMapping").is_some()
        || b.attribute("type").is_some_and(|t| t != "application/x-ssp-parameter-set")
    {
        return Err(fail(b, format!("component `{component}`: only parameter sets without mappings are supported")));
    }
    let prefix = b.attribute("prefix").unwrap_or("");
    if let Some(file) = file {
        let text = std::fs::read_to_string(file).map_err(|e| invalid(file, format!("cannot read: {e}")))?;
        let ssv = Document::parse(&text).map_err(|e| invalid(file, format!("not well-formed XML: {e}")))?;
        read_parameter_set(&ssv, file, ssv.root_element(), component, prefix, out)
    } else if let Some(values) = child(b, "ParameterValues") {
        let set = child(values, "ParameterSet").ok_or_else(|| {
            fail(values, format!("component `{component}`: <ssd:ParameterValues> without <ssv:ParameterSet>"))
        })?;
        read_parameter_set(doc, ssd, set, component, prefix, out)
    } else {
        Err(fail(b, format!("component `{component}`: a parameter binding with neither `source` nor values")))
    }
}

fn read_parameter_set(
    doc: &Document,
    file: &Path,
    set: Node,
    component: &str,
    prefix: &str,
    out: &mut Vec<Parameter>,
) -> Result<(), SetupError> {
    let fail = |n: Node, m: String| invalid(file, format!("{}: {m}", at(doc, n)));
    if set.tag_name().name() != "ParameterSet" {
        return Err(fail(set, format!("<{}>, expected <ssv:ParameterSet>", set.tag_name().name())));
    }
    let Some(params) = child(set, "Parameters") else { return Ok(()) };
    for p in children(params, "Parameter") {
        let name = p.attribute("name").ok_or_else(|| fail(p, "a parameter without `name`".into()))?;
        let target = Endpoint { component: component.to_owned(), variable: format!("{prefix}{name}") };
        let v = p
            .children()
            .find(|c| c.is_element())
            .ok_or_else(|| fail(p, format!("parameter `{target}` has no value")))?;
        let text = v.attribute("value").ok_or_else(|| fail(v, format!("parameter `{target}`: no `value`")))?;
        let bad = |what: &str| fail(v, format!("parameter `{target}`: `{text}` is not {what}"));
        let value = Value::Typed(match v.tag_name().name() {
            "Real" => fmi::Value::Real(text.trim().parse().map_err(|_| bad("a Real"))?),
            "Integer" => fmi::Value::Integer(text.trim().parse().map_err(|_| bad("an Integer"))?),
            "Boolean" => fmi::Value::Boolean(match text.trim() {
                "true" | "1" => true,
                "false" | "0" => false,
                _ => return Err(bad("a Boolean")),
            }),
            "String" => fmi::Value::String(text.to_owned()),
            other => return Err(fail(v, format!("parameter `{target}`: type <{other}> is not supported"))),
        });
        out.push(Parameter { target, value });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ssp::write::{SspSystem, ssd_text};

    /// What an adaptive step should watch, and a kink at the start, go through
    /// `SystemStructure.ssd` as this master's annotations; annotations of other types are left
    /// alone, and a description without ours suggests nothing.
    #[test]
    fn the_adaptive_annotation_is_written_and_read_back() {
        let dir = TempDir::new("annotation").unwrap();
        let ssd = dir.path().join("SystemStructure.ssd");
        let mut system = SspSystem {
            name: "pair".into(),
            components: Vec::new(),
            connections: Vec::new(),
            start_time: 0.0,
            stop_time: 1.0,
            watch: vec!["a.x".into(), "b.v[1]".into()],
            kink_at_start: true,
        };
        let text = ssd_text(&system);
        let other = r#"<ssc:Annotation type="com.example.other"><Watch name="not.ours"/></ssc:Annotation>"#;
        std::fs::write(&ssd, text.replace("    <ssc:Annotations>\n", &format!("    <ssc:Annotations>\n{other}\n")))
            .unwrap();
        let spec = load(&ssd).unwrap().spec;
        assert_eq!((&spec.watch, spec.kink_at_start), (&system.watch, true));
        system.watch.clear();
        system.kink_at_start = false;
        std::fs::write(&ssd, ssd_text(&system)).unwrap();
        assert!(!ssd_text(&system).contains("Annotation"));
        let spec = load(&ssd).unwrap().spec;
        assert!(spec.watch.is_empty() && !spec.kink_at_start);
    }

    /// A description of one system whose components (name, source) bind nothing, but `a`, which
    /// takes its parameters from `binding` when given.
    fn description(components: &[(&str, &str)], binding: Option<&str>) -> String {
        let mut x = String::from(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" version="1.0" name="s">
  <ssd:System name="s">
    <ssd:Elements>
"#,
        );
        for (name, source) in components {
            let bindings = match binding {
                Some(b) if *name == "a" => {
                    format!("<ssd:ParameterBindings><ssd:ParameterBinding source=\"{b}\"/></ssd:ParameterBindings>")
                }
                _ => String::new(),
            };
            x.push_str(&format!(
                "      <ssd:Component name=\"{name}\" source=\"{source}\">{bindings}</ssd:Component>\n"
            ));
        }
        x.push_str("    </ssd:Elements>\n  </ssd:System>\n</ssd:SystemStructureDescription>\n");
        x
    }

    /// A component's interface: SSP's `implementation` attribute, or this master's annotation
    /// (other annotations of the component left alone); `any` and nothing leave it open; a
    /// contradiction or a value SSP does not define is refused naming the line.
    #[test]
    fn a_components_interface_is_read_from_its_attribute_or_our_annotation() {
        use fmi::import::Interface::{CoSimulation, ModelExchange};
        let dir = TempDir::new("interface").unwrap();
        let ssd = dir.path().join("s.ssd");
        let annotated = |kind: &str| {
            format!(
                "<ssd:Annotations><ssc:Annotation type=\"com.example.other\"><Interface implementation=\"nonsense\"/>\
                 </ssc:Annotation><ssc:Annotation type=\"org.feedsim.interface\"><Interface implementation=\"{kind}\"/>\
                 </ssc:Annotation></ssd:Annotations>"
            )
        };
        let read = |components: &[(&str, &str)]| {
            let mut text = description(&components.iter().map(|c| (c.0, "x.fmu")).collect::<Vec<_>>(), None);
            for (name, extra) in components {
                let open = format!("<ssd:Component name=\"{name}\" source=\"x.fmu\">");
                let (attribute, inner) = extra.split_once('|').unwrap_or((extra, ""));
                let with = format!("<ssd:Component name=\"{name}\" source=\"x.fmu\"{attribute}>{inner}");
                text = text.replace(&open, &with);
            }
            std::fs::write(&ssd, text).unwrap();
            load(&ssd)
        };
        let me = annotated("ModelExchange");
        let spec = read(&[
            ("a", ""),
            ("b", " implementation=\"ModelExchange\""),
            ("c", " implementation=\"CoSimulation\""),
            ("d", " implementation=\"any\""),
            ("e", &format!("|{me}")),
            ("f", &format!(" implementation=\"ModelExchange\"|{me}")),
            ("g", &format!("|{}", annotated("CoSimulation"))),
        ])
        .unwrap()
        .spec;
        let interfaces: Vec<_> = spec.components.iter().map(|c| c.interface).collect();
        let expected = [
            None,
            Some(ModelExchange),
            Some(CoSimulation),
            None,
            Some(ModelExchange),
            Some(ModelExchange),
            Some(CoSimulation),
        ];
        assert_eq!(interfaces, expected);
        let e = read(&[("a", &format!(" implementation=\"CoSimulation\"|{me}"))]).err().unwrap().to_string();
        assert!(
            e.contains("line 5") && e.contains("component `a`") && e.contains("contradiction")
                || e.contains("asks for"),
            "{e}"
        );
        let e = read(&[("a", " implementation=\"ME\"")]).err().unwrap().to_string();
        assert!(e.contains("implementation `ME`: ModelExchange, CoSimulation or any"), "{e}");
    }

    const SSV: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="b">
  <ssv:Parameters><ssv:Parameter name="k"><ssv:Real value="60"/></ssv:Parameter></ssv:Parameters>
</ssv:ParameterSet>
"#;

    /// An `.ssp` archive of the given entries in `dir` (deflated: a large entry of zeros stays small).
    fn archive(dir: &Path, entries: &[(&str, &[u8])]) -> PathBuf {
        let path = dir.join("system.ssp");
        let mut zip = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
        let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
        for (name, bytes) in entries {
            zip.start_file(*name, deflated).unwrap();
            std::io::Write::write_all(&mut zip, bytes).unwrap();
        }
        zip.finish().unwrap();
        path
    }

    fn refused(path: &Path, limits: &ReadLimits) -> String {
        match load_within(path, limits) {
            Ok(_) => panic!("{} was read", path.display()),
            Err(e) => e.to_string(),
        }
    }

    /// An archive's entries that its system does not name are never unpacked (an archive of a
    /// few megabytes may hold gigabytes of zeros); what it names is unpacked within the cap, and
    /// a component's unpacked FMU folder whole.
    #[test]
    fn an_archive_unpacks_only_what_its_system_references() {
        let dir = TempDir::new("referenced").unwrap();
        let ssd = description(&[("a", "a.fmu"), ("b", "fmus/b"), ("c", "a.fmu")], Some("params/a.ssv"));
        let zeros = vec![0u8; 64 << 20];
        let entries: [(&str, &[u8]); 6] = [
            ("SystemStructure.ssd", ssd.as_bytes()),
            ("a.fmu", b"the FMU's bytes"),
            ("fmus/b/modelDescription.xml", b"<fmiModelDescription/>"),
            ("fmus/b/binaries/linux64/b.so", b"a library"),
            ("params/a.ssv", SSV.as_bytes()),
            ("zeros.bin", &zeros),
        ];
        let ssp = archive(dir.path(), &entries);
        assert!(std::fs::metadata(&ssp).unwrap().len() < 1 << 20, "64 MiB of zeros deflate to little");
        let limits = ReadLimits { max_unpacked_bytes: 1 << 20, ..ReadLimits::default() };
        let loaded = load_within(&ssp, &limits).unwrap();
        let root = loaded.spec.components[0].source.parent().unwrap().to_owned();
        for file in ["a.fmu", "fmus/b/modelDescription.xml", "fmus/b/binaries/linux64/b.so", "params/a.ssv"] {
            assert!(root.join(file).is_file(), "{file} unpacked");
        }
        assert!(!root.join("zeros.bin").exists(), "an entry nothing names stays packed");
        assert_eq!(loaded.spec.components[1].source, root.join("fmus/b"));
        assert_eq!(loaded.spec.parameters.len(), 1);
        // no cap at all: the budget counted without overflow
        let unlimited = ReadLimits { max_unpacked_bytes: u64::MAX, ..ReadLimits::default() };
        assert_eq!(load_within(&ssp, &unlimited).unwrap().spec.parameters.len(), 1);

        let small = ReadLimits { max_unpacked_bytes: 100, ..ReadLimits::default() };
        let e = refused(&ssp, &small);
        assert!(e.contains("system.ssp") && e.contains("--max-unpacked-mb"), "{e}");
        let few = ReadLimits { max_entries: 5, ..ReadLimits::default() };
        let e = refused(&ssp, &few);
        assert!(e.contains("6 entries, more than the 5 allowed") && e.contains("--max-archive-entries"), "{e}");
        // the zeros, named, exceed the cap: counted as written, whatever the entry declares
        let named = description(&[("a", "zeros.bin")], None);
        let ssp = archive(dir.path(), &[("SystemStructure.ssd", named.as_bytes()), ("zeros.bin", &zeros)]);
        let e = refused(&ssp, &ReadLimits { max_unpacked_bytes: 1 << 20, ..ReadLimits::default() });
        assert!(e.contains("unpacking `zeros.bin` exceeds the 1 MB"), "{e}");
    }

    /// A component or parameter file outside the archive would let an archive load any library
    /// on the machine: refused, naming the source, unless allowed.
    #[test]
    fn an_archive_cannot_reach_outside_itself() {
        let dir = TempDir::new("outside").unwrap();
        let elsewhere = dir.path().join("elsewhere.fmu");
        std::fs::write(&elsewhere, b"a library").unwrap();
        let absolute = elsewhere.display().to_string();
        let cases = [("a", "../../elsewhere.fmu", None), ("a", "sub/../../x.fmu", None), ("a", &absolute, None)];
        for (name, source, binding) in cases.iter().copied().chain([("a", "a.fmu", Some("../b.ssv"))]) {
            let ssd = description(&[(name, source)], binding);
            let ssp = archive(dir.path(), &[("SystemStructure.ssd", ssd.as_bytes()), ("a.fmu", b"x")]);
            let e = refused(&ssp, &ReadLimits::default());
            let named = binding.unwrap_or(source);
            assert!(e.contains(&format!("`{named}` lies outside the archive")), "{e}");
            assert!(e.contains("--allow-external-fmus"), "{e}");
        }
        let ssd = description(&[("a", &absolute)], None);
        let ssp = archive(dir.path(), &[("SystemStructure.ssd", ssd.as_bytes())]);
        let allowed = ReadLimits { allow_external: true, ..ReadLimits::default() };
        assert_eq!(load_within(&ssp, &allowed).unwrap().spec.components[0].source, elsewhere);
        let ssd = description(&[("a", "missing.fmu")], None);
        let ssp = archive(dir.path(), &[("SystemStructure.ssd", ssd.as_bytes())]);
        assert!(
            refused(&ssp, &ReadLimits::default())
                .contains("`missing.fmu`, named in SystemStructure.ssd, is not in the archive")
        );
    }

    /// An `.ssd` reads its FMUs and parameter files from its own folder: `..`, absolute paths
    /// and symbolic links out of it are refused unless allowed.
    #[test]
    fn an_ssd_cannot_reach_outside_its_folder() {
        let dir = TempDir::new("ssd-outside").unwrap();
        let folder = dir.path().join("system");
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(dir.path().join("x.fmu"), b"a library").unwrap();
        std::fs::write(folder.join("inside.fmu"), b"an FMU").unwrap();
        std::os::unix::fs::symlink(dir.path().join("x.fmu"), folder.join("link.fmu")).unwrap();
        let absolute = dir.path().join("x.fmu").display().to_string();
        let ssd = folder.join("s.ssd");
        for source in ["../x.fmu", "link.fmu", absolute.as_str()] {
            std::fs::write(&ssd, description(&[("a", source)], None)).unwrap();
            let e = refused(&ssd, &ReadLimits::default());
            assert!(e.contains(&format!("`{source}` lies outside the system's folder")), "{e}");
            let allowed = ReadLimits { allow_external: true, ..ReadLimits::default() };
            assert!(load_within(&ssd, &allowed).is_ok(), "{source} allowed");
        }
        std::fs::write(&ssd, description(&[("a", "./inside.fmu")], None)).unwrap();
        assert_eq!(load(&ssd).unwrap().spec.components[0].source, folder.join("inside.fmu"));
    }

    /// Two components of one name would write two CSV columns of one header; two descriptions in
    /// one archive leave open which system is meant.
    #[test]
    fn duplicate_names_are_refused() {
        let dir = TempDir::new("duplicates").unwrap();
        let ssd = dir.path().join("s.ssd");
        std::fs::write(dir.path().join("a.fmu"), b"x").unwrap();
        std::fs::write(&ssd, description(&[("a", "a.fmu"), ("a", "a.fmu")], None)).unwrap();
        let e = refused(&ssd, &ReadLimits::default());
        assert!(e.contains("line 6: a second component named `a`"), "{e}");

        // the zip writer refuses a duplicate name: write another, then give both entries one name
        let one = description(&[("a", "a.fmu")], None);
        let ssp =
            archive(dir.path(), &[("SystemStructure.ssd", one.as_bytes()), ("SystemStructure.ssX", one.as_bytes())]);
        let mut bytes = std::fs::read(&ssp).unwrap();
        let (from, to) = (b"SystemStructure.ssX", b"SystemStructure.ssd");
        let mut k = 0;
        while let Some(at) = bytes[k..].windows(from.len()).position(|w| w == from) {
            bytes[k + at..k + at + to.len()].copy_from_slice(to);
            k += at + to.len();
        }
        std::fs::write(&ssp, bytes).unwrap();
        let e = refused(&ssp, &ReadLimits::default());
        assert!(e.contains("lists an entry name twice"), "{e}");
    }
}
