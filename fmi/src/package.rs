//! Writing `.fmu` archives: `modelDescription.xml`, the binary (`binaries/linux64/<id>.so` for
//! FMI 2.0, `binaries/x86_64-linux/<id>.so` for FMI 3.0), `resources/...`.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use zip::CompressionMethod;
use zip::write::SimpleFileOptions;

use crate::description::{DescriptionError, ModelDescription, ModelInfo};
use crate::export::{Model, Resource};
use crate::xml::{model_description_xml, parse_model_description};

/// The platform folder of the binaries this build produces.
pub(crate) const PLATFORM: &str = "linux64";

/// Why an archive was not written.
#[derive(Debug, thiserror::Error)]
pub enum PackageError {
    #[error("the model's description: {0}")]
    Model(String),
    #[error("{identifier}: {source}")]
    Description { identifier: String, source: DescriptionError },
    #[error("{identifier}: modelDescription.xml would not read back as the model declares it ({why}); a bug in fmi")]
    RoundTrip { identifier: String, why: String },
    #[error("cannot read the shared library {path}: {source}")]
    Library { path: PathBuf, source: std::io::Error },
    #[error("resource name `{0}` must be a relative path inside resources/")]
    ResourceName(String),
    #[error("cannot create {path}: {source}")]
    Directory { path: PathBuf, source: std::io::Error },
    #[error("cannot write {path}: {source}")]
    Write { path: PathBuf, source: zip::result::ZipError },
    #[error("cannot move {from} to {to}: {source}")]
    Rename { from: PathBuf, to: PathBuf, source: std::io::Error },
}

/// Write `out_dir/<modelIdentifier>.fmu` for model `M` from its in-process description, its
/// resources and the cdylib `library` built from it. Returns the archive's path.
pub fn package_model<M: Model>(out_dir: &Path, library: &Path) -> Result<PathBuf, PackageError> {
    let description = M::description().map_err(|e| PackageError::Model(e.to_string()))?;
    let path = out_dir.join(format!("{}.fmu", description.model_identifier));
    write_fmu(&path, &description, library, &M::resources())?;
    Ok(path)
}

/// As [`package_model`], the FMI 3.0 archive (the same library: it exports both versions).
pub fn package_model3<M: Model>(out_dir: &Path, library: &Path) -> Result<PathBuf, PackageError> {
    let description = M::description().map_err(|e| PackageError::Model(e.to_string()))?;
    let path = out_dir.join(format!("{}.fmu", description.model_identifier));
    let xml = crate::fmi3::checked_xml3(&description)?;
    let binary = format!("binaries/{}/{}.so", crate::fmi3::PLATFORM, description.model_identifier);
    write_archive(&path, &xml, &binary, library, &M::resources())?;
    Ok(path)
}

/// The `modelDescription.xml` of a description, validated, and only if it reads back (through
/// the importer's parser) as the description itself: what importers will see.
pub fn checked_xml(description: &ModelDescription) -> Result<String, PackageError> {
    let identifier = description.model_identifier.clone();
    let invalid = |source| PackageError::Description { identifier: identifier.clone(), source };
    let declared = ModelInfo::new(description.clone()).map_err(invalid)?.description;
    let xml = model_description_xml(&declared).map_err(invalid)?;
    let round_trip = |why: String| PackageError::RoundTrip { identifier: identifier.clone(), why };
    // FMI 2.0 gives the number of event indicators, not which variables they are
    let mut expected = declared.clone();
    if let Some(me) = expected.model_exchange.as_mut() {
        me.event_indicator_variables.clear();
    }
    match parse_model_description(&xml) {
        Ok(read) if read == expected => Ok(xml),
        Ok(read) => {
            let differs = read.variables.iter().zip(&declared.variables).find(|(r, d)| r != d);
            Err(round_trip(match differs {
                Some((_, d)) => format!("variable `{}` reads back different", d.name),
                None => "it reads back different".into(),
            }))
        }
        Err(e) => Err(round_trip(e.to_string())),
    }
}

/// Write an `.fmu` archive at `out` (written to a temporary name first, then renamed). The
/// description is validated, and its XML must read back as it (what importers will see).
pub fn write_fmu(
    out: &Path,
    description: &ModelDescription,
    library: &Path,
    resources: &[Resource],
) -> Result<(), PackageError> {
    let xml = checked_xml(description)?;
    let binary = format!("binaries/{PLATFORM}/{}.so", description.model_identifier);
    write_archive(out, &xml, &binary, library, resources)
}

/// Writes the archive `out` (to a temporary name first, then renamed): `xml` as
/// `modelDescription.xml`, `library` as `binary_name`, the resources.
fn write_archive(
    out: &Path,
    xml: &str,
    binary_name: &str,
    library: &Path,
    resources: &[Resource],
) -> Result<(), PackageError> {
    let binary = std::fs::read(library).map_err(|source| PackageError::Library { path: library.into(), source })?;
    for r in resources {
        check_resource_name(&r.name)?;
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PackageError::Directory { path: dir.into(), source })?;
    }
    let tmp = out.with_extension("fmu.partial");
    let result = (|| -> Result<(), zip::result::ZipError> {
        let mut zip = zip::ZipWriter::new(File::create(&tmp)?);
        let file = SimpleFileOptions::default().compression_method(CompressionMethod::Deflated).unix_permissions(0o644);
        zip.start_file("modelDescription.xml", file)?;
        zip.write_all(xml.as_bytes())?;
        // stored, not deflated: every load unpacks the library, and inflating it costs more than
        // the rest of loading the FMU together (about 90 M instructions for 2.9 MB); the archive
        // grows from about 1 to 3 MB
        let stored = file.compression_method(CompressionMethod::Stored).unix_permissions(0o755);
        zip.start_file(binary_name, stored)?;
        zip.write_all(&binary)?;
        zip.add_directory("resources/", file.unix_permissions(0o755))?;
        for r in resources {
            zip.start_file(format!("resources/{}", r.name), file)?;
            zip.write_all(&r.bytes)?;
        }
        zip.finish()?.sync_all()?;
        Ok(())
    })();
    match result {
        Ok(()) => {
            std::fs::rename(&tmp, out).map_err(|source| PackageError::Rename { from: tmp, to: out.into(), source })
        }
        Err(source) => {
            let _ = std::fs::remove_file(&tmp);
            Err(PackageError::Write { path: out.into(), source })
        }
    }
}

/// A resource name is a relative, `/`-separated path without `..`, `.` or backslashes.
fn check_resource_name(name: &str) -> Result<(), PackageError> {
    let ok = !name.is_empty()
        && !name.starts_with('/')
        && !name.contains('\\')
        && name.split('/').all(|p| !p.is_empty() && p != "." && p != "..");
    if ok { Ok(()) } else { Err(PackageError::ResourceName(name.to_owned())) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_names() {
        for ok in ["a.toml", "scenes/lt50m_C.toml"] {
            assert!(check_resource_name(ok).is_ok());
        }
        for bad in ["", "/etc/passwd", "../x", "a/../b", "a\\b", "a//b", "./a"] {
            assert!(check_resource_name(bad).is_err(), "{bad}");
        }
    }
}
