//! Reading a file the user points at: a regular file only (a FIFO would block, a device never
//! end), and never more than a limit of it, whatever its size says.

use std::io::Read;
use std::path::Path;

/// Why a file was not read.
#[derive(Debug)]
pub enum ReadError {
    /// It cannot be opened or read.
    Io(std::io::Error),
    /// A directory, device, pipe or socket.
    NotRegular,
    /// Larger than the limit: its size, or `None` if it grew past the limit while read.
    TooLarge { size: Option<u64>, limit: u64 },
}

impl ReadError {
    /// The size as a message says it: the number, or "more than" the limit.
    pub fn size_text(size: Option<u64>, limit: u64) -> String {
        size.map_or(format!("more than {limit}"), |s| s.to_string())
    }
}

/// The bytes of the regular file `path`, at most `max_bytes` of them.
pub fn read_limited(path: &Path, max_bytes: u64) -> Result<Vec<u8>, ReadError> {
    let meta = std::fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular);
    }
    if meta.len() > max_bytes {
        return Err(ReadError::TooLarge { size: Some(meta.len()), limit: max_bytes });
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes))
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::TooLarge { size: None, limit: max_bytes });
    }
    Ok(bytes)
}
