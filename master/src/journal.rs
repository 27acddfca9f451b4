//! The finished points of a long command (a sweep, a stability map, a bench, a compensation
//! study), each written as it finishes, so that an interrupted or killed command loses nothing
//! done: `<out>/<name>.partial` — an identity line, then one line per point. It is removed when
//! the command completes; `--resume` reads it back and skips what is done, and the result is the
//! uninterrupted one. The `.partial` name says what it is: never a table that looks complete.
//!
//! A point's line is CSV: its index, its key (what the point is: its grid values, its case),
//! its cells, the FNV-1a digest of everything before, and a record separator. On resume a line
//! is used only if it is whole, its digest verifies, its key is the one the point has in this
//! run and the command's decoder accepts its cells; two lines that disagree about one point are
//! both dropped. A dropped line's point is computed again, and the count is said once on
//! stderr: an edited, truncated or foreign journal costs time, never a wrong table.

use std::collections::BTreeMap;
use std::collections::btree_map::Entry;
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use studies::sweep::table::{quoted, split};

/// What a journal's first line begins with.
const IDENTITY: &str = "# master journal: ";

/// The end of a whole point line (a line cut short by a kill lacks it).
const END: &str = "\u{1e}";

/// Longest line read back, bytes: a point's line is a few hundred bytes; anything longer is
/// not ours and is dropped unread.
const MAX_LINE: u64 = 1 << 20;

/// Why a journal cannot be used.
#[derive(Debug, thiserror::Error)]
pub(crate) enum JournalError {
    #[error(
        "{0}: the finished points of an earlier run of this command that did not complete (interrupted, killed \
         or failed) are here; continue it with the same command and --resume, or remove the file to start afresh"
    )]
    Exists(PathBuf),
    #[error(
        "{path}: a journal of other work ({found}); this run is {expected}: remove it, or give the run it belongs to"
    )]
    Foreign { path: PathBuf, found: String, expected: String },
    #[error("{path}: not a journal of `master` ({reason}); remove it, or point --out elsewhere")]
    NotAJournal { path: PathBuf, reason: String },
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// A point an earlier run finished, as its line gives it.
#[derive(Clone, Debug, PartialEq)]
struct Point {
    key: String,
    cells: Vec<String>,
}

/// The journal of one command's points.
pub(crate) struct Journal {
    path: PathBuf,
    identity: String,
    file: Mutex<File>,
    done: BTreeMap<usize, Point>,
    /// Lines not used: cut short, not verifying, disagreeing, not of this run's points.
    dropped: AtomicUsize,
    /// Points whose line the study did not take (another key, cells refused): they are computed
    /// again, so their old lines go from the file once every point has been looked up.
    unused: Mutex<Vec<usize>>,
}

impl Journal {
    /// The journal at `path` for the work `identity` describes (every input that decides the
    /// results, in one line). With `resume` the points an earlier run finished are read (a
    /// journal of other work is refused); without, an existing journal is refused rather than
    /// overwritten. A missing journal starts empty either way.
    pub(crate) fn open(path: &Path, identity: &str, resume: bool) -> Result<Journal, JournalError> {
        let identity = identity.replace('\n', " ");
        let (done, dropped) = match path.symlink_metadata() {
            Err(_) => (BTreeMap::new(), 0),
            Ok(meta) if !meta.is_file() => {
                return Err(JournalError::NotAJournal { path: path.to_owned(), reason: "not a regular file".into() });
            }
            Ok(_) if !resume => return Err(JournalError::Exists(path.to_owned())),
            Ok(_) => read_back(path, &identity)?,
        };
        // what was read is written back whole: the lines dropped go, and the next point starts a
        // line of its own
        studies::tempfiles::remove_stale(path);
        let file = write_back(path, &identity, done.iter())?;
        Ok(Journal {
            path: path.to_owned(),
            identity,
            file: Mutex::new(file),
            done,
            dropped: AtomicUsize::new(dropped),
            unused: Mutex::new(Vec::new()),
        })
    }

    /// How many points an earlier run finished (before any is checked against its key).
    pub(crate) fn resumed(&self) -> usize {
        self.done.len()
    }

    /// Says on stderr, once, how many lines of the journal were not used, if any.
    pub(crate) fn say_dropped(&self) {
        let n = self.dropped.swap(0, Ordering::Relaxed);
        if n > 0 {
            eprintln!(
                "note: {}: {n} line{} dropped (cut short, edited, repeated with other values or not of this run's \
                 points); {} computed again",
                self.path.display(),
                if n == 1 { "" } else { "s" },
                if n == 1 { "its point is" } else { "their points are" },
            );
        }
    }

    /// Writes point `index`, which `key` names, with its cells.
    pub(crate) fn record(&self, index: usize, key: &str, cells: &[String]) -> Result<(), JournalError> {
        let text = line(index, key, cells);
        let mut file = self.file.lock().unwrap_or_else(|p| p.into_inner());
        // unbuffered: the line is the kernel's once written, so a killed process keeps it
        file.write_all(text.as_bytes()).map_err(|source| JournalError::Io { path: self.path.clone(), source })
    }

    /// The work is complete: the journal goes.
    pub(crate) fn finish(self) -> Result<(), JournalError> {
        std::fs::remove_file(&self.path).map_err(|source| JournalError::Io { path: self.path, source })
    }
}

/// Replaces the journal at `path` at once (write and rename) by the identity line and the lines
/// of `points`; the file open for appending the next points.
fn write_back<'a>(
    path: &Path,
    identity: &str,
    points: impl Iterator<Item = (&'a usize, &'a Point)>,
) -> Result<File, JournalError> {
    let io = |source| JournalError::Io { path: path.to_owned(), source };
    let mut text = format!("{IDENTITY}{identity}\n");
    for (index, point) in points {
        text.push_str(&line(*index, &point.key, &point.cells));
    }
    let fresh = studies::tempfiles::beside(path);
    std::fs::write(&fresh, text).map_err(io)?;
    std::fs::rename(&fresh, path).map_err(io)?;
    std::fs::OpenOptions::new().append(true).open(path).map_err(io)
}

/// The points of an earlier run of the work `identity` in the journal at `path`, and how many
/// of its lines were dropped.
fn read_back(path: &Path, identity: &str) -> Result<(BTreeMap<usize, Point>, usize), JournalError> {
    let io = |source| JournalError::Io { path: path.to_owned(), source };
    let mut reader = BufReader::new(File::open(path).map_err(io)?);
    let mut bytes = Vec::new();
    read_line(&mut reader, &mut bytes).map_err(io)?;
    let found = std::str::from_utf8(&bytes)
        .ok()
        .and_then(|l| l.strip_suffix('\n'))
        .and_then(|l| l.strip_prefix(IDENTITY))
        .ok_or_else(|| JournalError::NotAJournal { path: path.to_owned(), reason: "no identity line".into() })?;
    if found != identity {
        return Err(JournalError::Foreign {
            path: path.to_owned(),
            found: found.to_owned(),
            expected: identity.to_owned(),
        });
    }
    let (mut done, mut dropped, mut conflicting) = (BTreeMap::new(), 0, Vec::new());
    while read_line(&mut reader, &mut bytes).map_err(io)? {
        let Some((index, point)) = parse(&bytes) else {
            dropped += 1;
            continue;
        };
        match done.entry(index) {
            Entry::Vacant(e) => {
                e.insert(point);
            }
            // the same point written twice (a resumed run that repeated it): one is enough
            Entry::Occupied(e) if *e.get() == point => {}
            Entry::Occupied(_) => {
                conflicting.push(index);
                dropped += 1;
            }
        }
    }
    for index in conflicting {
        if done.remove(&index).is_some() {
            dropped += 1;
        }
    }
    Ok((done, dropped))
}

/// The next line into `bytes` (its newline kept), at most [`MAX_LINE`] bytes of it: the rest of
/// a longer line is skipped unread into memory. False at the end of the file.
fn read_line(reader: &mut impl BufRead, bytes: &mut Vec<u8>) -> std::io::Result<bool> {
    bytes.clear();
    let n = reader.by_ref().take(MAX_LINE).read_until(b'\n', bytes)?;
    if n as u64 == MAX_LINE && bytes.last() != Some(&b'\n') {
        loop {
            let buf = reader.fill_buf()?;
            if buf.is_empty() {
                break;
            }
            match buf.iter().position(|&b| b == b'\n') {
                Some(at) => {
                    reader.consume(at + 1);
                    break;
                }
                None => {
                    let len = buf.len();
                    reader.consume(len);
                }
            }
        }
    }
    Ok(n > 0)
}

/// The line of one point: index, key, cells, the digest of all that, the end mark.
fn line(index: usize, key: &str, cells: &[String]) -> String {
    let mut text = format!("{index},{}", quoted(key));
    for c in cells {
        text.push(',');
        text.push_str(&quoted(c));
    }
    text.push(',');
    let digest = fmi::digest::digest(text.as_bytes());
    text.push_str(&format!("{digest:016x},{END}\n"));
    text
}

/// The point a line holds, if it is whole and verifies.
fn parse(bytes: &[u8]) -> Option<(usize, Point)> {
    let text = std::str::from_utf8(bytes).ok()?.strip_suffix('\n')?.strip_suffix(END)?.strip_suffix(',')?;
    let (body, digest) = text.rsplit_once(',')?;
    let body_with_comma = &text[..body.len() + 1];
    if u64::from_str_radix(digest, 16).ok()? != fmi::digest::digest(body_with_comma.as_bytes()) || digest.len() != 16 {
        return None;
    }
    let mut cells = split(body).ok()?;
    if cells.len() < 2 {
        return None;
    }
    let index = cells[0].parse().ok()?;
    let key = cells.remove(1);
    cells.remove(0);
    Some((index, Point { key, cells }))
}

/// `<dir>/<name>.partial`.
pub(crate) fn path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.partial"))
}

impl studies::points::Store for Journal {
    fn earlier(&self, index: usize, key: &str) -> Option<Vec<String>> {
        let point = self.done.get(&index)?;
        if point.key != key {
            self.refused(index);
            return None;
        }
        Some(point.cells.clone())
    }

    fn refused(&self, index: usize) {
        self.dropped.fetch_add(1, Ordering::Relaxed);
        self.unused.lock().unwrap_or_else(|p| p.into_inner()).push(index);
    }

    /// Says what was dropped, and takes the lines of the points computed again out of the file
    /// (else their old line and the new one would disagree on the next resume).
    fn looked_up(&self) {
        self.say_dropped();
        let unused = std::mem::take(&mut *self.unused.lock().unwrap_or_else(|p| p.into_inner()));
        if unused.is_empty() {
            return;
        }
        let kept = self.done.iter().filter(|(index, _)| !unused.contains(index));
        // a journal that cannot be rewritten keeps its lines; the next resume drops them again
        if let Ok(file) = write_back(&self.path, &self.identity, kept) {
            *self.file.lock().unwrap_or_else(|p| p.into_inner()) = file;
        }
    }

    fn resumed(&self) -> usize {
        Journal::resumed(self)
    }

    fn record(&self, index: usize, key: &str, cells: &[String]) -> anyhow::Result<()> {
        Ok(Journal::record(self, index, key, cells)?)
    }
}

/// A study's error, with the way on when the caller stopped it: its finished points are in
/// `journal`, and `--resume` continues.
pub(crate) fn resumable(journal: &Journal) -> impl Fn(anyhow::Error) -> anyhow::Error + '_ {
    move |e| {
        if e.is::<studies::cancel::Cancelled>() {
            e.context(format!(
                "the finished points are kept in {}; continue with the same command and --resume",
                journal.path.display()
            ))
        } else {
            e
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use studies::points::Store;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("master-journal-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = path(&dir, "t.csv");
        let _ = std::fs::remove_file(&path);
        path
    }

    fn cells(x: &str) -> Vec<String> {
        vec![x.to_owned(), "with, comma".to_owned(), "NaN".to_owned()]
    }

    /// The cells of point `index` under `key`, as the study's map looks them up (cells it
    /// would refuse refused).
    fn take(j: &Journal, index: usize, key: &str, accept: bool) -> Option<Vec<String>> {
        let cells = j.earlier(index, key)?;
        if !accept || cells.len() != 3 {
            j.refused(index);
            return None;
        }
        Some(cells)
    }

    /// Points come back as written; a line cut short by a kill is dropped (and does not swallow
    /// the next point's line); another identity is refused; without resume an existing journal
    /// is kept, not overwritten.
    #[test]
    fn points_survive_a_cut_line_and_other_work_is_refused() {
        let path = scratch("cut");
        let j = Journal::open(&path, "work A", false).unwrap();
        j.record(0, "x=1", &cells("a")).unwrap();
        j.record(2, "x=3", &cells("c")).unwrap();
        drop(j);
        // a kill in the middle of point 1's line
        let mut f = std::fs::OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"1,x=2,b,\"with").unwrap();
        drop(f);
        assert!(matches!(Journal::open(&path, "work A", false), Err(JournalError::Exists(_))));
        assert!(matches!(Journal::open(&path, "work B", true), Err(JournalError::Foreign { .. })));
        let j = Journal::open(&path, "work A", true).unwrap();
        assert_eq!(j.dropped.load(Ordering::Relaxed), 1);
        assert_eq!(j.resumed(), 2);
        assert_eq!(take(&j, 0, "x=1", true), Some(cells("a")));
        assert_eq!(take(&j, 1, "x=2", true), None);
        assert_eq!(take(&j, 2, "x=3", true), Some(cells("c")));
        j.record(1, "x=2", &cells("b")).unwrap();
        drop(j);
        let j = Journal::open(&path, "work A", true).unwrap();
        assert_eq!((j.resumed(), j.dropped.load(Ordering::Relaxed)), (3, 0));
        assert_eq!(take(&j, 1, "x=2", true), Some(cells("b")));
        j.finish().unwrap();
        assert!(!path.exists());
    }

    /// Every way a line can be wrong drops that line only: an edited cell (the digest fails), a
    /// key of another grid, cells the decoder refuses, two lines that disagree about one point
    /// (both go), binary bytes, an overlong line; a repeated identical line is kept once.
    #[test]
    fn a_line_that_does_not_verify_is_dropped_and_the_rest_kept() {
        let path = scratch("edited");
        let j = Journal::open(&path, "work", false).unwrap();
        for (i, x) in ["a", "b", "c", "d", "e", "f"].iter().enumerate() {
            j.record(i, &format!("x={i}"), &cells(x)).unwrap();
        }
        j.record(5, "x=5", &cells("f")).unwrap(); // the same point again, the same values
        j.record(3, "x=3", &cells("other")).unwrap(); // the same point, other values
        drop(j);
        let text = std::fs::read_to_string(&path).unwrap();
        let text = text.replacen("1,x=1,b,", "1,x=1,inf,", 1);
        let mut bytes = text.into_bytes();
        bytes.extend_from_slice(b"\xff\xfe\x00binary\n");
        bytes.extend(std::iter::repeat_n(b'7', 3 << 20));
        bytes.extend_from_slice(b"\n");
        std::fs::write(&path, &bytes).unwrap();
        let j = Journal::open(&path, "work", true).unwrap();
        // point 1 edited, point 3 twice with other values, the binary and the overlong lines
        assert_eq!(j.dropped.load(Ordering::Relaxed), 1 + 2 + 2, "{:?}", j.done.keys());
        assert_eq!(take(&j, 0, "x=0", true), Some(cells("a")));
        assert_eq!(take(&j, 1, "x=1", true), None);
        assert_eq!(take(&j, 2, "x=9", true), None, "a key of another grid");
        assert_eq!(take(&j, 3, "x=3", true), None);
        assert_eq!(take(&j, 4, "x=4", false), None);
        assert_eq!(take(&j, 5, "x=5", true), Some(cells("f")));
        // the points not taken (another key, refused cells) leave the file, and their new lines
        // meet no old one on the next resume
        j.looked_up();
        j.record(2, "x=9", &cells("c9")).unwrap();
        j.record(4, "x=4", &cells("e")).unwrap();
        drop(j);
        let j = Journal::open(&path, "work", true).unwrap();
        assert_eq!((j.resumed(), j.dropped.load(Ordering::Relaxed)), (4, 0));
        assert_eq!(take(&j, 2, "x=9", true), Some(cells("c9")));
        drop(j);
        // a file that is no journal at all
        std::fs::write(&path, b"\x00\x01\x02").unwrap();
        assert!(matches!(Journal::open(&path, "work", true), Err(JournalError::NotAJournal { .. })));
        std::fs::remove_file(&path).unwrap();
    }
}
