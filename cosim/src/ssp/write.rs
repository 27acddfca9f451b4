//! Writing an SSP 1.0 archive: `SystemStructure.ssd` (components with their connectors and
//! inline parameter values, connections, default experiment, and what an adaptive step should
//! watch as this master's annotation) and the FMUs under `resources/`.
//! The XML is small and flat, so it is written directly (with fmi's attribute escaping)
//! rather than through an XML library.

use std::fmt::Write as _;
use std::io::{Read, Seek, Write};
use std::path::Path;

use fmi::VarType;
use fmi::xml::escape;

use crate::error::SetupError;
use crate::system::fmu::ResolvedConnection;
use crate::system::spec::Value;

/// A connector of a component in the description.
#[derive(Clone, Debug, PartialEq)]
pub struct SspConnector {
    pub name: String,
    /// `input`, `output` or `parameter`.
    pub kind: &'static str,
    pub var_type: VarType,
}

/// A component and the FMU archive it packs.
#[derive(Clone, Debug, PartialEq)]
pub struct SspComponent {
    pub name: String,
    /// The `.fmu` archive's bytes, stored as `resources/<name>.fmu`.
    pub fmu: Vec<u8>,
    pub connectors: Vec<SspConnector>,
    /// Parameter values by variable name, in the order to apply them.
    pub parameters: Vec<(String, Value)>,
}

/// A system to write.
#[derive(Clone, Debug, PartialEq)]
pub struct SspSystem {
    pub name: String,
    pub components: Vec<SspComponent>,
    pub connections: Vec<ResolvedConnection>,
    pub start_time: f64,
    pub stop_time: f64,
    /// What an adaptive step should watch (written as [`super::ADAPTIVE_ANNOTATION`] when not
    /// empty).
    pub watch: Vec<String>,
    /// The motion starts with a kink (written as [`super::START_ANNOTATION`] when true).
    pub kink_at_start: bool,
}

fn type_element(t: VarType) -> &'static str {
    match t {
        VarType::Real => "Real",
        VarType::Integer => "Integer",
        VarType::Boolean => "Boolean",
        VarType::String => "String",
    }
}

/// The text of `SystemStructure.ssd`.
pub fn ssd_text(s: &SspSystem) -> String {
    let mut x = String::new();
    // `write!` to a String cannot fail.
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" version="1.0" name="{}" generationTool="feedsim master {}">"#,
        escape(&s.name),
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(x, r#"  <ssd:System name="{}">"#, escape(&s.name));
    let _ = writeln!(x, "    <ssd:Elements>");
    for c in &s.components {
        let _ = writeln!(
            x,
            r#"      <ssd:Component name="{}" type="application/x-fmu-sharedlibrary" source="resources/{}.fmu">"#,
            escape(&c.name),
            escape(&c.name)
        );
        if !c.connectors.is_empty() {
            let _ = writeln!(x, "        <ssd:Connectors>");
            for k in &c.connectors {
                let _ = writeln!(
                    x,
                    r#"          <ssd:Connector name="{}" kind="{}"><ssc:{}/></ssd:Connector>"#,
                    escape(&k.name),
                    k.kind,
                    type_element(k.var_type)
                );
            }
            let _ = writeln!(x, "        </ssd:Connectors>");
        }
        if !c.parameters.is_empty() {
            let _ = writeln!(x, "        <ssd:ParameterBindings>");
            let _ = writeln!(x, "          <ssd:ParameterBinding>");
            let _ = writeln!(x, "            <ssd:ParameterValues>");
            let _ = writeln!(x, r#"              <ssv:ParameterSet version="1.0" name="{}">"#, escape(&c.name));
            let _ = writeln!(x, "                <ssv:Parameters>");
            for (name, value) in &c.parameters {
                let (t, v) = match value {
                    Value::Typed(fmi::Value::Real(v)) => ("Real", format!("{v:?}")),
                    Value::Typed(fmi::Value::Integer(v)) => ("Integer", v.to_string()),
                    Value::Typed(fmi::Value::Boolean(v)) => ("Boolean", v.to_string()),
                    Value::Typed(fmi::Value::String(v)) | Value::Text(v) => ("String", escape(v)),
                };
                let _ = writeln!(
                    x,
                    r#"                  <ssv:Parameter name="{}"><ssv:{t} value="{v}"/></ssv:Parameter>"#,
                    escape(name)
                );
            }
            let _ = writeln!(x, "                </ssv:Parameters>");
            let _ = writeln!(x, "              </ssv:ParameterSet>");
            let _ = writeln!(x, "            </ssd:ParameterValues>");
            let _ = writeln!(x, "          </ssd:ParameterBinding>");
            let _ = writeln!(x, "        </ssd:ParameterBindings>");
        }
        let _ = writeln!(x, "      </ssd:Component>");
    }
    let _ = writeln!(x, "    </ssd:Elements>");
    if !s.connections.is_empty() {
        let _ = writeln!(x, "    <ssd:Connections>");
        for c in &s.connections {
            let open = format!(
                r#"<ssd:Connection startElement="{}" startConnector="{}" endElement="{}" endConnector="{}""#,
                escape(&c.from.component),
                escape(&c.from.variable),
                escape(&c.to.component),
                escape(&c.to.variable)
            );
            match c.transform {
                None => {
                    let _ = writeln!(x, "      {open}/>");
                }
                Some(t) => {
                    let _ = writeln!(
                        x,
                        r#"      {open}><ssc:LinearTransformation factor="{:?}" offset="{:?}"/></ssd:Connection>"#,
                        t.factor, t.offset
                    );
                }
            }
        }
        let _ = writeln!(x, "    </ssd:Connections>");
    }
    if !s.watch.is_empty() || s.kink_at_start {
        // the schema: <ssd:Annotations> last in the system, an <ssc:Annotation> holds one element
        let _ = writeln!(x, "    <ssd:Annotations>");
        if s.kink_at_start {
            let _ = writeln!(x, r#"      <ssc:Annotation type="{}">"#, super::START_ANNOTATION);
            let _ = writeln!(x, r#"        <Start kink="true"/>"#);
            let _ = writeln!(x, "      </ssc:Annotation>");
        }
        if !s.watch.is_empty() {
            let _ = writeln!(x, r#"      <ssc:Annotation type="{}">"#, super::ADAPTIVE_ANNOTATION);
            let _ = writeln!(x, "        <Adaptive>");
            for w in &s.watch {
                let _ = writeln!(x, r#"          <Watch name="{}"/>"#, escape(w));
            }
            let _ = writeln!(x, "        </Adaptive>");
            let _ = writeln!(x, "      </ssc:Annotation>");
        }
        let _ = writeln!(x, "    </ssd:Annotations>");
    }
    let _ = writeln!(x, "  </ssd:System>");
    let _ = writeln!(x, r#"  <ssd:DefaultExperiment startTime="{:?}" stopTime="{:?}"/>"#, s.start_time, s.stop_time);
    let _ = writeln!(x, "</ssd:SystemStructureDescription>");
    x
}

/// Writes the archive to `path` (through a temporary file renamed at the end).
pub fn write_ssp(path: &Path, s: &SspSystem) -> Result<(), SetupError> {
    let err = |message: String| SetupError::File { path: path.to_owned(), message };
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".part");
    let part = path.with_file_name(name);
    let file = std::fs::File::create(&part).map_err(|e| err(format!("cannot write: {e}")))?;
    write_archive(file, s).map_err(|e| err(format!("cannot write: {e}")))?;
    std::fs::rename(&part, path).map_err(|e| err(format!("cannot write: {e}")))
}

/// Writes the archive to `out` (a file, or a buffer in memory); returns it.
pub fn write_archive<W: Write + Seek>(out: W, s: &SspSystem) -> Result<W, zip::result::ZipError> {
    let mut zip = zip::ZipWriter::new(out);
    let deflated = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    zip.start_file("SystemStructure.ssd", deflated)?;
    zip.write_all(ssd_text(s).as_bytes())?;
    for c in &s.components {
        // an FMU is already compressed
        let stored = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        zip.start_file(format!("resources/{}.fmu", c.name), stored)?;
        zip.write_all(&c.fmu)?;
    }
    zip.finish()
}

/// The bytes of the FMU archive `fmu` with `bytes` added as `resources/<name>` (replacing a
/// file of that name).
pub fn with_resource(fmu: &Path, name: &str, bytes: &[u8]) -> Result<Vec<u8>, SetupError> {
    let err = |m: String| SetupError::File { path: fmu.to_owned(), message: m };
    let file = std::fs::File::open(fmu).map_err(|e| err(format!("cannot open: {e}")))?;
    let mut src =
        zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(|e| err(format!("not a zip archive: {e}")))?;
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let target = format!("resources/{name}");
    for i in 0..src.len() {
        let mut f = src.by_index(i).map_err(|e| err(format!("cannot read entry {i}: {e}")))?;
        let entry = f.name().map_err(|e| err(format!("entry {i}: {e}")))?.into_owned();
        if entry == target {
            continue;
        }
        let options = zip::write::SimpleFileOptions::default().compression_method(f.compression());
        if f.is_dir() {
            out.add_directory(entry, options).map_err(|e| err(e.to_string()))?;
            continue;
        }
        let mut data = Vec::with_capacity(f.size() as usize);
        f.read_to_end(&mut data).map_err(|e| err(format!("cannot read `{entry}`: {e}")))?;
        out.start_file(entry, options).map_err(|e| err(e.to_string()))?;
        out.write_all(&data).map_err(|e| err(e.to_string()))?;
    }
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    out.start_file(target, options).map_err(|e| err(e.to_string()))?;
    out.write_all(bytes).map_err(|e| err(e.to_string()))?;
    Ok(out.finish().map_err(|e| err(e.to_string()))?.into_inner())
}
