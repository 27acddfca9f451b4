//! Loading an FMU's binary, and what a binary may leave to its host.
//!
//! An FMU written in Python with pythonfmu leaves the Python C API (`Py…` symbols) undefined in
//! its binary: it loads only into a process that already has the Python library's symbols
//! global (a Python interpreter, fmpy). When a binary fails to load for want of such a symbol,
//! the Python library is loaded with its symbols global — the one named
//! ([`name_python_library`], `--python-library`), else the one the `python3` on `PATH` reports
//! (`sysconfig`'s `LIBDIR`/`LDLIBRARY`) — and the binary is loaded again. Nothing is looked up
//! for a binary that loads by itself. Every failure carries the loader's own reason.

use std::error::Error as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use libloading::Library;

/// The Python library named by the user, and the one loaded (kept for the process's life: the
/// FMUs that use it hold its symbols).
static NAMED: Mutex<Option<PathBuf>> = Mutex::new(None);
static LOADED: Mutex<Option<(PathBuf, Library)>> = Mutex::new(None);

/// Names the Python library to load for an FMU that needs one (`None`: that of the `python3`
/// on `PATH`).
pub fn name_python_library(path: Option<PathBuf>) {
    *NAMED.lock().unwrap_or_else(|p| p.into_inner()) = path;
}

/// The loader's whole reason for `e` (libloading's message says only "dlopen failed"; the
/// reason, e.g. the missing symbol, is its source).
pub(crate) fn reason(e: &libloading::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// A Python C API symbol the loader found missing, from its reason.
fn missing_python_symbol(reason: &str) -> Option<&str> {
    let symbol = reason.split("undefined symbol: ").nth(1)?.split([' ', ',', ';', ')']).next()?;
    (symbol.starts_with("Py") || symbol.starts_with("_Py")).then_some(symbol)
}

/// Loads the binary at `path`; one that leaves the Python C API to its host gets the Python
/// library first.
///
/// # Safety
/// Loading runs the binary's initializers (and, when it needs it, the Python library's).
pub(crate) unsafe fn load(path: &Path) -> Result<Library, String> {
    // SAFETY: the caller's promise.
    let first = match unsafe { Library::new(path) } {
        Ok(lib) => return Ok(lib),
        Err(e) => reason(&e),
    };
    let Some(symbol) = missing_python_symbol(&first) else {
        return Err(format!("cannot load the binary: {first}"));
    };
    let needs = format!(
        "cannot load the binary: {first}: it leaves the Python C API (`{symbol}`) to its host, as an FMU written in \
         Python with pythonfmu does"
    );
    // SAFETY: as above.
    let python = unsafe { load_python() }.map_err(|why| format!("{needs}; {why}"))?;
    // SAFETY: as above.
    unsafe { Library::new(path) }.map_err(|e| {
        format!("{needs}; with the Python library {} loaded it still fails: {}", python.display(), reason(&e))
    })
}

/// Loads the Python library (once) with its symbols global; returns its path.
///
/// # Safety
/// Loading runs the library's initializers.
unsafe fn load_python() -> Result<PathBuf, String> {
    let mut loaded = LOADED.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((path, _)) = loaded.as_ref() {
        return Ok(path.clone());
    }
    let named = NAMED.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let (path, from) = match named {
        Some(p) => (p, "--python-library"),
        None => (python_on_path()?, "the `python3` on PATH"),
    };
    if !path.is_file() {
        return Err(format!(
            "the Python library {} ({from}) is no file: name one with --python-library PATH (libpython3.X.so, \
             as `python3 -c \"import sysconfig; print(sysconfig.get_config_var('LIBDIR'))\"` shows)",
            path.display()
        ));
    }
    use libloading::os::unix::{Library as Unix, RTLD_GLOBAL, RTLD_NOW};
    // SAFETY: the caller's promise.
    let lib = unsafe { Unix::open(Some(&path), RTLD_NOW | RTLD_GLOBAL) }
        .map_err(|e| format!("cannot load the Python library {} ({from}): {}", path.display(), reason(&e)))?;
    *loaded = Some((path.clone(), lib.into()));
    Ok(path)
}

/// The shared Python library of the `python3` on `PATH`, as its `sysconfig` reports it.
fn python_on_path() -> Result<PathBuf, String> {
    let script = "import os, sysconfig; v = sysconfig.get_config_var; \
                  print(os.path.join(v('LIBDIR') or '', v('LDLIBRARY') or ''))";
    let out = std::process::Command::new("python3").args(["-c", script]).output().map_err(|e| {
        format!(
            "no `python3` on PATH to find the Python library with ({e}): name it with --python-library PATH \
             (libpython3.X.so)"
        )
    })?;
    if !out.status.success() {
        return Err(format!(
            "`python3` on PATH could not say where its library is ({}): name it with --python-library PATH",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let path = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    if path.extension().is_none_or(|e| e != "so") && !path.to_string_lossy().contains(".so.") {
        return Err(format!(
            "`python3` on PATH has no shared Python library ({} is a static one): name one with --python-library PATH",
            path.display()
        ));
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_python_symbol_is_read_from_the_loaders_reason() {
        let reason = "dlopen failed: /tmp/x/binaries/linux64/Controller.so: undefined symbol: PyBool_FromLong";
        assert_eq!(missing_python_symbol(reason), Some("PyBool_FromLong"));
        assert_eq!(missing_python_symbol("dlopen failed: x.so: undefined symbol: cblas_dgemm"), None);
        assert_eq!(missing_python_symbol("dlopen failed: libfoo.so: cannot open shared object file"), None);
    }

    /// A binary that is no shared library: the message holds the loader's reason, not only
    /// libloading's "dlopen failed".
    #[test]
    fn a_failed_load_says_why() {
        let dir = std::env::temp_dir().join(format!("fmi-host-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.so");
        std::fs::write(&bad, b"not an ELF file").unwrap();
        // SAFETY: the file is no library; nothing runs.
        let err = unsafe { load(&bad) }.map(|_| ()).unwrap_err();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(err.contains("cannot load the binary") && err.contains("bad.so:"), "{err}");
        assert!(err.len() > "cannot load the binary: dlopen failed".len() + 10, "{err}");
    }
}
