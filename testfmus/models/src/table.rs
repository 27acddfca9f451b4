//! A signal given as points in a text file, interpolated linearly in time (held constant
//! before the first point and after the last).
//!
//! ```text
//! # comment
//! title = a ramp and a plateau
//! 0    0
//! 1.5  3      (time, value: whitespace or a comma between them)
//! ```

/// Why a file is not a table; `line` counts from 1 (0: the file as a whole).
#[derive(Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct TableError {
    pub line: usize,
    pub message: String,
}

/// The file's title and points (times strictly increasing).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub title: String,
    pub times: Vec<f64>,
    pub values: Vec<f64>,
}

impl Table {
    /// Reads a table; errors name the line and what is wrong with it.
    pub fn parse(text: &str) -> Result<Table, TableError> {
        let mut table = Table { title: String::new(), times: Vec::new(), values: Vec::new() };
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            let fail = |message: String| TableError { line: i + 1, message };
            if line.is_empty() {
                continue;
            }
            if let Some((key, value)) = line.split_once('=') {
                match key.trim() {
                    "title" => table.title = value.trim().to_owned(),
                    other => return Err(fail(format!("unknown key `{other}` (known: title)"))),
                }
                continue;
            }
            let fields: Vec<&str> = line.split([' ', '\t', ',']).filter(|f| !f.is_empty()).collect();
            let [t, y] = fields[..] else {
                return Err(fail(format!("expected `time value`, got `{line}`")));
            };
            let number = |f: &str| match f.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(fail(format!("`{f}` is not a finite number"))),
            };
            let (t, y) = (number(t)?, number(y)?);
            if let Some(&last) = table.times.last()
                && !(t > last)
            {
                return Err(fail(format!("time {t} does not follow {last}: times must increase")));
            }
            table.times.push(t);
            table.values.push(y);
        }
        if table.times.is_empty() {
            return Err(TableError { line: 0, message: "no points (lines `time value`)".into() });
        }
        Ok(table)
    }

    /// The value at `t`: linear between points, the end values outside them.
    pub fn value_at(&self, t: f64) -> f64 {
        let (ts, ys) = (&self.times, &self.values);
        let after = ts.partition_point(|&ti| ti <= t);
        if after == 0 {
            return ys[0];
        }
        if after == ts.len() {
            return ys[ts.len() - 1];
        }
        let (a, b) = (after - 1, after);
        ys[a] + (t - ts[a]) / (ts[b] - ts[a]) * (ys[b] - ys[a])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_title_and_points_and_interpolates() {
        let t = Table::parse("# ramp\ntitle = ramp, then hold\n0 0\n2, 4 # two\n\n3\t4\n").unwrap();
        assert_eq!(t.title, "ramp, then hold");
        assert_eq!((t.times.as_slice(), t.values.as_slice()), ([0.0, 2.0, 3.0].as_slice(), [0.0, 4.0, 4.0].as_slice()));
        assert_eq!(t.value_at(-1.0), 0.0);
        assert_eq!(t.value_at(0.5), 1.0);
        assert_eq!(t.value_at(2.0), 4.0);
        assert_eq!(t.value_at(2.5), 4.0);
        assert_eq!(t.value_at(10.0), 4.0);
        assert_eq!(Table::parse("5 7").unwrap().value_at(0.0), 7.0);
    }

    #[test]
    fn errors_name_the_line() {
        let e = |text: &str| Table::parse(text).unwrap_err().to_string();
        assert_eq!(e("0 0\n1 x\n"), "line 2: `x` is not a finite number");
        assert_eq!(e("0 0\n0 1\n"), "line 2: time 0 does not follow 0: times must increase");
        assert_eq!(e("0 0 0\n"), "line 1: expected `time value`, got `0 0 0`");
        assert_eq!(e("name = x\n"), "line 1: unknown key `name` (known: title)");
        assert_eq!(e("# nothing\n"), "line 0: no points (lines `time value`)");
        assert_eq!(e("0 inf\n"), "line 1: `inf` is not a finite number");
    }
}
