//! The CSV of a sweep: `# key = value` header lines that say what was swept (scene, grid,
//! requests, the shard), a column line, and one row per point in index order. A shard's file
//! holds its points only; [`merge`] checks that the parts belong to one sweep, are disjoint and
//! complete, and joins them into the table the whole sweep would have written.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::{Shard, SweepError};

/// A sweep's table, cells kept as written (so a merge reproduces them exactly).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// `key = value` header entries, in order; `shard` and `points` among them.
    pub header: Vec<(String, String)>,
    pub columns: Vec<String>,
    /// Rows by point index.
    pub rows: BTreeMap<usize, Vec<String>>,
}

impl Table {
    pub fn get(&self, key: &str) -> Option<&str> {
        self.header.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn set(&mut self, key: &str, value: String) {
        match self.header.iter_mut().find(|(k, _)| k == key) {
            Some(e) => e.1 = value,
            None => self.header.push((key.to_string(), value)),
        }
    }

    /// The index of a column.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// Writes the table (header lines, column line, rows in index order).
    pub fn write_to(&self, out: &mut dyn Write) -> std::io::Result<()> {
        for (k, v) in &self.header {
            writeln!(out, "# {k} = {v}")?;
        }
        writeln!(out, "{}", self.columns.join(","))?;
        for row in self.rows.values() {
            let cells: Vec<String> = row.iter().map(|c| quoted(c)).collect();
            writeln!(out, "{}", cells.join(","))?;
        }
        out.flush()
    }

    pub fn read(path: &Path) -> Result<Table, SweepError> {
        let file = path.display().to_string();
        // a regular file only: a pipe named like a part would block the merge
        let bytes = feedcore::files::read_limited(path, u64::MAX).map_err(|e| {
            let source = match e {
                feedcore::files::ReadError::Io(e) => e,
                _ => std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
            };
            SweepError::Io { file: file.clone(), source }
        })?;
        let text = String::from_utf8(bytes).map_err(|e| SweepError::Io {
            file: file.clone(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        })?;
        let err = |line: usize, reason: String| SweepError::Table {
            file: file.clone(),
            reason: format!("line {line}: {reason}"),
        };
        let mut t = Table { header: vec![], columns: vec![], rows: BTreeMap::new() };
        for (n, line) in text.lines().enumerate().map(|(n, l)| (n + 1, l)) {
            if let Some(entry) = line.strip_prefix("# ") {
                let (k, v) =
                    entry.split_once(" = ").ok_or_else(|| err(n, "a header line is `# key = value`".into()))?;
                t.header.push((k.to_string(), v.to_string()));
            } else if t.columns.is_empty() {
                t.columns = line.split(',').map(String::from).collect();
                if t.columns.first().map(String::as_str) != Some("index") {
                    return Err(err(n, "the column line must start with `index`".into()));
                }
            } else if !line.is_empty() {
                let cells = split(line).map_err(|e| err(n, e))?;
                if cells.len() != t.columns.len() {
                    return Err(err(n, format!("{} cells for {} columns", cells.len(), t.columns.len())));
                }
                let index: usize = cells[0].parse().map_err(|_| err(n, format!("index `{}`", cells[0])))?;
                if t.rows.insert(index, cells).is_some() {
                    return Err(err(n, format!("point {index} appears twice")));
                }
            }
        }
        if t.columns.is_empty() {
            return Err(err(0, "no column line: not a sweep table".into()));
        }
        Ok(t)
    }
}

/// The CSV form of a cell: quoted when it holds a comma or a quote.
pub fn quoted(cell: &str) -> String {
    if cell.contains([',', '"', '\n']) {
        format!("\"{}\"", cell.replace('"', "\"\"").replace('\n', " "))
    } else {
        cell.into()
    }
}

/// Splits a CSV line (quoted cells may hold commas; `""` is a quote).
pub fn split(line: &str) -> Result<Vec<String>, String> {
    let mut cells = vec![String::new()];
    let mut chars = line.chars().peekable();
    let mut in_quotes = false;
    while let Some(ch) = chars.next() {
        let cell = cells.last_mut().expect("never empty");
        match (ch, in_quotes) {
            ('"', false) if cell.is_empty() => in_quotes = true,
            ('"', true) if chars.peek() == Some(&'"') => {
                cell.push('"');
                chars.next();
            }
            ('"', true) => in_quotes = false,
            (',', false) => cells.push(String::new()),
            (c, _) => cell.push(c),
        }
    }
    if in_quotes { Err("a quoted cell is not closed".into()) } else { Ok(cells) }
}

/// The file a shard writes into `dir` (the whole sweep: `sweep.csv`).
pub fn file_name(dir: &Path, shard: Shard) -> PathBuf {
    if shard == Shard::ALL {
        dir.join("sweep.csv")
    } else {
        dir.join(format!("sweep.part-{}-of-{}.csv", shard.index, shard.count))
    }
}

/// The part files among `paths` (files, or directories holding `sweep.part-*.csv`).
pub fn part_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, SweepError> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries =
                std::fs::read_dir(p).map_err(|source| SweepError::Io { file: p.display().to_string(), source })?;
            let mut found: Vec<PathBuf> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
                    name.starts_with("sweep.part-") && name.ends_with(".csv")
                })
                .collect();
            if found.is_empty() {
                return Err(SweepError::Merge(format!("{} holds no sweep.part-*.csv", p.display())));
            }
            found.sort();
            files.extend(found);
        } else {
            files.push(p.clone());
        }
    }
    Ok(files)
}

/// Joins shard tables into the whole sweep's table. The parts must come from one sweep (same
/// header apart from the shard, same columns), be distinct shards of the same count, and
/// together hold every point once.
pub fn merge(parts: &[(PathBuf, Table)]) -> Result<Table, SweepError> {
    let (first_file, first) = parts.first().ok_or_else(|| SweepError::Merge("no parts given".into()))?;
    let shard_of = |file: &Path, t: &Table| -> Result<Shard, SweepError> {
        let spec = t.get("shard").ok_or_else(|| SweepError::Merge(format!("{}: no `shard` header", file.display())))?;
        Shard::parse(spec)
    };
    let count = shard_of(first_file, first)?.count;
    let without_shard = |t: &Table| t.header.iter().filter(|(k, _)| k != "shard").cloned().collect::<Vec<_>>();
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let mut merged = Table { header: first.header.clone(), columns: first.columns.clone(), rows: BTreeMap::new() };
    for (file, t) in parts {
        if without_shard(t) != without_shard(first) || t.columns != first.columns {
            return Err(SweepError::Merge(format!(
                "{} and {} come from different sweeps (their headers or columns differ)",
                first_file.display(),
                file.display()
            )));
        }
        let shard = shard_of(file, t)?;
        if shard.count != count {
            return Err(SweepError::Merge(format!(
                "{} is shard {shard}, {} a shard of {count}",
                file.display(),
                first_file.display()
            )));
        }
        if let Some(other) = seen.insert(shard.index, file) {
            return Err(SweepError::Merge(format!(
                "shard {shard} is given twice: {} and {}",
                other.display(),
                file.display()
            )));
        }
        for (i, row) in &t.rows {
            if !shard.contains(*i) {
                return Err(SweepError::Merge(format!(
                    "{}: point {i} does not belong to shard {shard}",
                    file.display()
                )));
            }
            merged.rows.insert(*i, row.clone());
        }
    }
    let missing: Vec<String> = (0..count).filter(|i| !seen.contains_key(i)).map(|i| format!("{i}/{count}")).collect();
    if !missing.is_empty() {
        return Err(SweepError::Merge(format!("shard(s) {} missing", missing.join(", "))));
    }
    let points: usize = first
        .get("points")
        .and_then(|p| p.parse().ok())
        .ok_or_else(|| SweepError::Merge(format!("{}: no `points` header", first_file.display())))?;
    let absent: Vec<usize> = (0..points).filter(|i| !merged.rows.contains_key(i)).collect();
    if !absent.is_empty() || merged.rows.len() != points {
        let shown: Vec<String> = absent.iter().take(10).map(|i| i.to_string()).collect();
        return Err(SweepError::Merge(format!(
            "the parts hold {} of {points} points; missing e.g. {} (an interrupted shard?)",
            merged.rows.len(),
            shown.join(", ")
        )));
    }
    merged.set("shard", Shard::ALL.to_string());
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(shard: Shard, points: usize) -> Table {
        let mut t = Table {
            header: vec![
                ("scene".into(), "s".into()),
                ("points".into(), points.to_string()),
                ("shard".into(), shard.to_string()),
            ],
            columns: vec!["index".into(), "x_m".into(), "note".into()],
            rows: BTreeMap::new(),
        };
        for i in (0..points).filter(|i| shard.contains(*i)) {
            t.rows.insert(i, vec![i.to_string(), format!("{:?}", i as f64 * 0.1), format!("a \"quoted\", note {i}")]);
        }
        t
    }

    #[test]
    fn write_read_round_trip_and_merge_of_all_shards() {
        let dir = std::env::temp_dir().join(format!("sweep-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let whole = table(Shard::ALL, 11);
        let mut parts = Vec::new();
        for i in 0..3 {
            let s = Shard { index: i, count: 3 };
            let path = file_name(&dir, s);
            table(s, 11).write_to(&mut std::fs::File::create(&path).unwrap()).unwrap();
            let back = Table::read(&path).unwrap();
            assert_eq!(back, table(s, 11));
            parts.push((path, back));
        }
        assert_eq!(merge(&parts).unwrap(), whole);
        let files = part_files(std::slice::from_ref(&dir)).unwrap();
        assert_eq!(files.len(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_or_repeated_or_foreign_shard_is_named() {
        let p = |i: usize, n: usize, points: usize| {
            (PathBuf::from(format!("p{i}")), table(Shard { index: i, count: n }, points))
        };
        let e = merge(&[p(0, 3, 11), p(2, 3, 11)]).unwrap_err().to_string();
        assert!(e.contains("shard(s) 1/3 missing"), "{e}");
        let e = merge(&[p(0, 2, 11), p(0, 2, 11)]).unwrap_err().to_string();
        assert!(e.contains("given twice"), "{e}");
        let e = merge(&[p(0, 2, 11), p(1, 2, 12)]).unwrap_err().to_string();
        assert!(e.contains("different sweeps"), "{e}");
        let e = merge(&[p(0, 2, 11), p(1, 3, 11)]).unwrap_err().to_string();
        assert!(e.contains("a shard of 2"), "{e}");
        // an interrupted shard: rows lost
        let (f, mut t) = p(1, 2, 11);
        t.rows.remove(&5);
        let e = merge(&[p(0, 2, 11), (f, t)]).unwrap_err().to_string();
        assert!(e.contains("10 of 11 points") && e.contains('5'), "{e}");
    }
}
