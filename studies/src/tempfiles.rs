//! The temporary file a result is written to before it is moved into place:
//! `.<name>.<pid>.tmp` beside it, one per process, so that two runs never write into one and
//! what a killed process left is recognised, by the next run, as no live process's.

use std::path::{Path, PathBuf};

/// The temporary file of this process for the result at `target`.
pub fn beside(target: &Path) -> PathBuf {
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    target.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Removes the temporary files for `target` that processes no longer running left (killed
/// before they could clean up), and their temporary folders (a VTK series'); returns how many.
/// Another live process's are left alone.
pub fn remove_stale(target: &Path) -> usize {
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else { return 0 };
    let dir = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let prefix = format!(".{name}.");
    let mut removed = 0;
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = file.strip_prefix(&prefix).and_then(|rest| rest.strip_suffix(".tmp")) else { continue };
        let Ok(pid) = pid.parse::<u32>() else { continue };
        let alive = pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists();
        if alive {
            continue;
        }
        let gone = match entry.file_type() {
            Ok(t) if t.is_file() => std::fs::remove_file(entry.path()).is_ok(),
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(entry.path()).is_ok(),
            _ => false,
        };
        if gone {
            removed += 1;
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dead process's temporary file goes, a live one's and other files stay.
    #[test]
    fn only_the_temporaries_of_processes_gone_are_removed() {
        let dir = std::env::temp_dir().join(format!("master-tempfiles-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("sweep.csv");
        // a process that has ended: its pid is free (unless reused within the test)
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = dir.join(format!(".sweep.csv.{dead}.tmp"));
        let mine = beside(&target);
        let live = dir.join(format!(".sweep.csv.{}.tmp", 1)); // init lives as long as the system
        let others = [dir.join("sweep.csv"), dir.join(".other.csv.7.tmp"), dir.join(".sweep.csv.x.tmp")];
        for f in [&stale, &mine, &live].into_iter().chain(&others) {
            std::fs::write(f, b"").unwrap();
        }
        assert_eq!(remove_stale(&target), 1);
        assert!(!stale.exists() && mine.exists() && live.exists());
        assert!(others.iter().all(|f| f.exists()));
        // a dead process's temporary folder goes too
        std::fs::create_dir(&stale).unwrap();
        std::fs::write(stale.join("x_000000.vtu"), b"").unwrap();
        assert_eq!(remove_stale(&target), 1);
        assert!(!stale.exists() && mine.exists() && live.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
