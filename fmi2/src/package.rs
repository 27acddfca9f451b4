//! Writing `.fmu` archives: `modelDescription.xml`, `binaries/linux64/<id>.so`, `resources/...`.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use zip::CompressionMethod;
use zip::write::SimpleFileOptions;

use crate::description::ModelDescription;
use crate::export::{Model, Resource};
use crate::xml::model_description_xml;

/// The platform folder of the binaries this build produces.
pub const PLATFORM: &str = "linux64";

/// Write `out_dir/<modelIdentifier>.fmu` for model `M` from its in-process description, its
/// resources and the cdylib `library` built from it. Returns the archive's path.
pub fn package_model<M: Model>(out_dir: &Path, library: &Path) -> Result<PathBuf, String> {
    let description = M::description().map_err(|e| format!("the model's description: {e}"))?;
    let path = out_dir.join(format!("{}.fmu", description.model_identifier));
    write_fmu(&path, &description, library, &M::resources())?;
    Ok(path)
}

/// Write an `.fmu` archive at `out` (written to a temporary name first, then renamed).
pub fn write_fmu(
    out: &Path,
    description: &ModelDescription,
    library: &Path,
    resources: &[Resource],
) -> Result<(), String> {
    let xml = model_description_xml(description).map_err(|e| format!("{}: {e}", description.model_identifier))?;
    let binary =
        std::fs::read(library).map_err(|e| format!("cannot read the shared library {}: {e}", library.display()))?;
    for r in resources {
        check_resource_name(&r.name)?;
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let tmp = out.with_extension("fmu.partial");
    let result = (|| -> Result<(), zip::result::ZipError> {
        let mut zip = zip::ZipWriter::new(File::create(&tmp)?);
        let file = SimpleFileOptions::default().compression_method(CompressionMethod::Deflated).unix_permissions(0o644);
        zip.start_file("modelDescription.xml", file)?;
        zip.write_all(xml.as_bytes())?;
        let id = &description.model_identifier;
        zip.start_file(format!("binaries/{PLATFORM}/{id}.so"), file.unix_permissions(0o755))?;
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
            std::fs::rename(&tmp, out).map_err(|e| format!("cannot move {} to {}: {e}", tmp.display(), out.display()))
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(format!("cannot write {}: {e}", out.display()))
        }
    }
}

/// A resource name is a relative, `/`-separated path without `..`, `.` or backslashes.
fn check_resource_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && !name.starts_with('/')
        && !name.contains('\\')
        && name.split('/').all(|p| !p.is_empty() && p != "." && p != "..");
    if ok { Ok(()) } else { Err(format!("resource name `{name}` must be a relative path inside resources/")) }
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
