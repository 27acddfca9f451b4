//! The finished points of a long command (a sweep, a stability map, a bench, a compensation
//! study), each written as it finishes, so that an interrupted or killed command loses nothing
//! done: `<out>/<name>.partial` — an identity line, then one line per point (its index and
//! cells, CSV). It is removed when the command completes; `--resume` reads it back and skips
//! what is done, and the result is the uninterrupted one. The `.partial` name says what it is:
//! never a table that looks complete.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::sweep::table::{quoted, split};

/// What a journal line begins with.
const IDENTITY: &str = "# master journal: ";

/// Why a journal cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error(
        "{0}: the points of an interrupted run are here; continue it with --resume, or remove the file to start \
         afresh"
    )]
    Exists(PathBuf),
    #[error(
        "{path}: a journal of other work ({found}); this run is {expected}: remove it, or give the run it belongs to"
    )]
    Foreign { path: PathBuf, found: String, expected: String },
    #[error("{path}, line {line}: {message}")]
    Malformed { path: PathBuf, line: usize, message: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// The journal of one command's points.
pub struct Journal {
    path: PathBuf,
    file: Mutex<File>,
    done: BTreeMap<usize, Vec<String>>,
}

impl Journal {
    /// The journal at `path` for the work `identity` describes (every input that decides the
    /// results, in one line). With `resume` the points an earlier run finished are read (a
    /// journal of other work is refused); without, an existing journal is refused rather than
    /// overwritten. A missing journal starts empty either way.
    pub fn open(path: &Path, identity: &str, resume: bool) -> Result<Journal, JournalError> {
        let io = |source| JournalError::Io { path: path.to_owned(), source };
        let identity = identity.replace('\n', " ");
        let mut done = BTreeMap::new();
        if path.exists() {
            if !resume {
                return Err(JournalError::Exists(path.to_owned()));
            }
            let reader = BufReader::new(File::open(path).map_err(io)?);
            for (k, line) in reader.lines().enumerate() {
                let line = line.map_err(io)?;
                let malformed =
                    |message: String| JournalError::Malformed { path: path.to_owned(), line: k + 1, message };
                if k == 0 {
                    let found = line.strip_prefix(IDENTITY).ok_or_else(|| malformed("not a journal".into()))?;
                    if found != identity {
                        return Err(JournalError::Foreign {
                            path: path.to_owned(),
                            found: found.to_owned(),
                            expected: identity.clone(),
                        });
                    }
                    continue;
                }
                // a line cut short by a kill is the point in hand: done again
                let Ok(mut cells) = split(&line) else { continue };
                if cells.len() < 2 || !line.ends_with('\u{1e}') {
                    continue;
                }
                cells.pop();
                let index = cells.remove(0).parse().map_err(|_| malformed("a point without its index".into()))?;
                done.insert(index, cells);
            }
        }
        let mut file = std::fs::OpenOptions::new().create(true).append(true).open(path).map_err(io)?;
        if done.is_empty() {
            file.set_len(0).map_err(io)?;
            writeln!(file, "{IDENTITY}{identity}").map_err(io)?;
        } else {
            // a line cut short goes, so that the next point starts a line of its own
            let bytes = std::fs::read(path).map_err(io)?;
            let whole = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            file.set_len(whole as u64).map_err(io)?;
        }
        Ok(Journal { path: path.to_owned(), file: Mutex::new(file), done })
    }

    /// The cells of point `index` if an earlier run finished it.
    pub fn done(&self, index: usize) -> Option<&[String]> {
        self.done.get(&index).map(Vec::as_slice)
    }

    /// How many points an earlier run finished.
    pub fn resumed(&self) -> usize {
        self.done.len()
    }

    /// Writes point `index` (a line that ends with a record separator, so that a line cut short
    /// by a kill is recognised, and dropped on resume).
    pub fn record(&self, index: usize, cells: &[String]) -> Result<(), JournalError> {
        let mut line = index.to_string();
        for c in cells {
            line.push(',');
            line.push_str(&quoted(c));
        }
        line.push_str(",\u{1e}\n");
        let mut file = self.file.lock().unwrap_or_else(|p| p.into_inner());
        // unbuffered: the line is the kernel's once written, so a killed process keeps it
        file.write_all(line.as_bytes()).map_err(|source| JournalError::Io { path: self.path.clone(), source })
    }

    /// The work is complete: the journal goes.
    pub fn finish(self) -> Result<(), JournalError> {
        std::fs::remove_file(&self.path).map_err(|source| JournalError::Io { path: self.path, source })
    }
}

/// `<dir>/<name>.partial`.
pub fn path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.partial"))
}

/// `compute(i, &items[i])` for every item on `jobs` threads, the costliest first (`cost`: an
/// estimate of the run time), results in order: each written to
/// `journal` as it finishes (as `encode` gives its cells) and taken from it (`decode`) where an
/// earlier run finished it. After Ctrl-C no item starts, a result finished meanwhile is not
/// kept (it may have been cut short), and the whole is [`Interrupted`](crate::interrupt::Interrupted),
/// naming the journal that keeps the rest for `--resume`.
pub fn map_journaled<T, R>(
    items: &[T],
    jobs: Option<usize>,
    cost: impl Fn(&T) -> f64,
    journal: &Journal,
    encode: impl Fn(&R) -> Vec<String> + Sync,
    decode: impl Fn(&[String]) -> anyhow::Result<R> + Sync,
    compute: impl Fn(usize, &T) -> anyhow::Result<R> + Sync + Send,
) -> anyhow::Result<Vec<R>>
where
    T: Sync,
    R: Send,
{
    let results = crate::parallel::map_longest_first(items, jobs, cost, |i, item| -> anyhow::Result<Option<R>> {
        if let Some(cells) = journal.done(i) {
            return decode(cells).map(Some);
        }
        if crate::interrupt::interrupted() {
            return Ok(None);
        }
        let result = compute(i, item);
        if crate::interrupt::interrupted() {
            return Ok(None);
        }
        let result = result?;
        journal.record(i, &encode(&result))?;
        Ok(Some(result))
    })?;
    match results.into_iter().collect::<anyhow::Result<Option<Vec<R>>>>()? {
        Some(all) => Ok(all),
        None => Err(anyhow::Error::new(crate::interrupt::Interrupted).context(format!(
            "the finished points are kept in {}; continue with the same command and --resume",
            journal.path.display()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points come back as written; a line cut short by a kill is dropped (and does not swallow
    /// the next point's line); another identity is refused; without resume an existing journal
    /// is kept, not overwritten.
    #[test]
    fn points_survive_a_cut_line_and_other_work_is_refused() {
        let dir = std::env::temp_dir().join(format!("master-journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = path(&dir, "t.csv");
        let _ = std::fs::remove_file(&path);
        let cells = |x: &str| vec![x.to_owned(), "with, comma".to_owned(), "NaN".to_owned()];
        let j = Journal::open(&path, "work A", false).unwrap();
        j.record(0, &cells("a")).unwrap();
        j.record(2, &cells("c")).unwrap();
        drop(j);
        // a kill in the middle of point 1's line
        let mut f = std::fs::OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"1,b,\"with").unwrap();
        drop(f);
        assert!(matches!(Journal::open(&path, "work A", false), Err(JournalError::Exists(_))));
        assert!(matches!(Journal::open(&path, "work B", true), Err(JournalError::Foreign { .. })));
        let j = Journal::open(&path, "work A", true).unwrap();
        assert_eq!((j.resumed(), j.done(0), j.done(1)), (2, Some(cells("a").as_slice()), None));
        assert_eq!(j.done(2), Some(cells("c").as_slice()));
        j.record(1, &cells("b")).unwrap();
        drop(j);
        let j = Journal::open(&path, "work A", true).unwrap();
        assert_eq!(j.resumed(), 3);
        assert_eq!(j.done(1), Some(cells("b").as_slice()));
        j.finish().unwrap();
        assert!(!path.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
