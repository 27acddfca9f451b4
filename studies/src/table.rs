//! Plain-text tables for the terminal (numeric columns right-aligned, text columns left-aligned)
//! and their Markdown form for reports.

/// A table with a header row.
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Table {
        Table { header: header.into_iter().map(Into::into).collect(), rows: Vec::new() }
    }

    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows.push(cells.into_iter().map(Into::into).collect());
    }

    pub fn render(&self) -> String {
        let cols = self.header.len();
        let mut width = vec![0; cols];
        for r in std::iter::once(&self.header).chain(&self.rows) {
            for (w, c) in width.iter_mut().zip(r) {
                *w = (*w).max(c.chars().count());
            }
        }
        let numeric: Vec<bool> = (0..cols)
            .map(|i| self.rows.iter().all(|r| r.get(i).is_none_or(|c| c.trim().parse::<f64>().is_ok())))
            .collect();
        let line = |r: &Vec<String>| {
            let cells: Vec<String> = (0..cols)
                .map(|i| {
                    let c = r.get(i).map(String::as_str).unwrap_or("");
                    let pad = " ".repeat(width[i] - c.chars().count());
                    if numeric[i] { format!("{pad}{c}") } else { format!("{c}{pad}") }
                })
                .collect();
            cells.join("  ").trim_end().to_string()
        };
        let mut out = line(&self.header);
        out.push('\n');
        out.push_str(&width.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  "));
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
            out.push('\n');
        }
        out
    }

    /// The table in Markdown (a `|` in a cell escaped).
    pub fn render_markdown(&self) -> String {
        let line = |r: &Vec<String>| {
            let cells: Vec<String> =
                (0..self.header.len()).map(|i| r.get(i).map_or(String::new(), |c| c.replace('|', "\\|"))).collect();
            format!("| {} |\n", cells.join(" | "))
        };
        let mut out = line(&self.header);
        out.push_str(&format!("|{}\n", "---|".repeat(self.header.len())));
        for r in &self.rows {
            out.push_str(&line(r));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_align_right_and_text_left() {
        let mut t = Table::new(["a", "value", "note"]);
        t.row(["1", "2.5", "x"]);
        t.row(["10", "-0.25", "long"]);
        assert_eq!(t.render(), " a  value  note\n--  -----  ----\n 1    2.5  x\n10  -0.25  long\n");
    }

    #[test]
    fn markdown_has_a_rule_and_escapes_bars() {
        let mut t = Table::new(["a", "b"]);
        t.row(["x|y", "2"]);
        assert_eq!(t.render_markdown(), "| a | b |\n|---|---|\n| x\\|y | 2 |\n");
    }
}
