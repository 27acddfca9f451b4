//! Reading SSP 1.0: an `.ssp` archive (its `SystemStructure.ssd`) or an `.ssd` file with the
//! FMUs it names beside it, into a [`SystemSpec`].
//!
//! Supported: one system of FMU components; their connectors (Real, Integer, Boolean, String;
//! type and unit checked against the FMU); connections between component connectors, with an
//! optional `LinearTransformation` on Real ones; parameter bindings inline
//! (`ParameterValues`) or in `.ssv` files, with an optional prefix; `DefaultExperiment`.
//! Refused with a message: nested systems, connections to the system's own connectors,
//! parameter mappings, enumeration and boolean/integer mapping transformations. Annotations are
//! ignored but this master's own ([`super::ADAPTIVE_ANNOTATION`]).

use std::path::{Path, PathBuf};

use fmi2::VarType;
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

/// Reads an `.ssp` archive or an `.ssd` file.
pub fn load(path: &Path) -> Result<LoadedSsp, SetupError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    match ext {
        "ssp" => {
            let file = std::fs::File::open(path).map_err(|e| invalid(path, format!("cannot open: {e}")))?;
            let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
                .map_err(|e| invalid(path, format!("not a valid zip archive: {e}")))?;
            let dir =
                TempDir::new("ssp").map_err(|e| invalid(path, format!("cannot create a temporary directory: {e}")))?;
            zip.extract(dir.path()).map_err(|e| invalid(path, format!("cannot unpack: {e}")))?;
            let ssd = dir.path().join("SystemStructure.ssd");
            if !ssd.is_file() {
                return Err(invalid(path, "the archive holds no SystemStructure.ssd at its root".into()));
            }
            let mut loaded = read_ssd(&ssd, &path.display().to_string())?;
            loaded._unpacked = Some(dir);
            Ok(loaded)
        }
        "ssd" => read_ssd(path, &path.display().to_string()),
        _ => Err(invalid(path, "give an SSP 1.0 system: an `.ssp` archive or an `.ssd` file".into())),
    }
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

fn read_ssd(ssd: &Path, origin: &str) -> Result<LoadedSsp, SetupError> {
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
            spec.components.push(Component { name: name.to_owned(), source: resolve_uri(&base, source) });
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
                    read_binding(&doc, ssd, &base, name, b, &mut spec.parameters)?;
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

/// A relative URI against the directory of the `.ssd` (percent-decoded; `file:` accepted).
fn resolve_uri(base: &Path, uri: &str) -> PathBuf {
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
    let p = PathBuf::from(String::from_utf8_lossy(&bytes).into_owned());
    if p.is_absolute() { p } else { base.join(p) }
}

fn read_binding(
    doc: &Document,
    ssd: &Path,
    base: &Path,
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
    if let Some(source) = b.attribute("source") {
        let file = resolve_uri(base, source);
        let text = std::fs::read_to_string(&file).map_err(|e| invalid(&file, format!("cannot read: {e}")))?;
        let ssv = Document::parse(&text).map_err(|e| invalid(&file, format!("not well-formed XML: {e}")))?;
        read_parameter_set(&ssv, &file, ssv.root_element(), component, prefix, out)
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
            "Real" => fmi2::Value::Real(text.trim().parse().map_err(|_| bad("a Real"))?),
            "Integer" => fmi2::Value::Integer(text.trim().parse().map_err(|_| bad("an Integer"))?),
            "Boolean" => fmi2::Value::Boolean(match text.trim() {
                "true" | "1" => true,
                "false" | "0" => false,
                _ => return Err(bad("a Boolean")),
            }),
            "String" => fmi2::Value::String(text.to_owned()),
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
}
