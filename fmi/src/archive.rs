//! Unpacking single entries of a zip archive (an `.fmu`, an `.ssp`) within a budget of bytes,
//! counted as written: an importer unpacks what it needs and nothing else, and an entry that
//! declares a small size but inflates to gigabytes is stopped at the budget.

use std::io::{Read, Seek};
use std::path::Path;

/// Why an entry was not unpacked.
#[derive(Debug, thiserror::Error)]
pub enum UnpackError {
    #[error("entry `{0}` points outside the archive")]
    Outside(String),
    #[error("unpacking `{name}` exceeds the {limit} bytes the archive's entries may take together")]
    TooLarge { name: String, limit: u64 },
    #[error("entry `{name}`: {message}")]
    Io { name: String, message: String },
}

/// Unpacks the entry `name` into `dir` (a folder entry: the folder), taking what it writes from
/// `budget` (what is left of `limit`).
pub fn unpack_entry<R: Read + Seek>(
    zip: &mut zip::ZipArchive<R>,
    name: &str,
    dir: &Path,
    budget: &mut u64,
    limit: u64,
) -> Result<(), UnpackError> {
    let io = |message: String| UnpackError::Io { name: name.to_owned(), message };
    let mut entry = zip.by_name(name).map_err(|e| io(e.to_string()))?;
    let Some(relative) = entry.enclosed_name() else {
        return Err(UnpackError::Outside(name.to_owned()));
    };
    let target = dir.join(relative);
    if entry.is_dir() {
        return std::fs::create_dir_all(&target).map_err(|e| io(format!("cannot create {}: {e}", target.display())));
    }
    if let Some(parent) = target.parent() {
        std::fs::create_dir_all(parent).map_err(|e| io(format!("cannot create {}: {e}", parent.display())))?;
    }
    let mut out = std::fs::File::create(&target).map_err(|e| io(format!("cannot create {}: {e}", target.display())))?;
    // the sizes an entry declares may lie: count what is written
    let written = std::io::copy(&mut (&mut entry).take(budget.saturating_add(1)), &mut out)
        .map_err(|e| io(format!("cannot unpack: {e}")))?;
    if written > *budget {
        return Err(UnpackError::TooLarge { name: name.to_owned(), limit });
    }
    *budget -= written;
    Ok(())
}
