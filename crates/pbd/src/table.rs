//! Terminal output shared by the subcommands: number formatting and plain aligned tables.
//!
//! Tables are for people; `--json` is for programs and carries full precision. So the terminal shows a
//! fixed number of decimals (micrometres and microradians at 6), never `-0.000000`, and `inf` for an
//! absent limit.

use std::io::{self, Write};

/// Decimals shown for lengths and angles in tables: micrometres and microradians.
pub const DECIMALS: usize = 6;

/// `x` with `decimals` fixed decimals; tiny values print as `0`, non-finite as `inf` / `-inf` / `nan`.
pub fn num(x: f64, decimals: usize) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let s = format!("{x:.decimals$}");
    // Avoid "-0.000000": a value that rounds to zero is zero.
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        format!("{:.decimals$}", 0.0)
    } else {
        s
    }
}

/// A plain table: numeric columns right-aligned, text columns left-aligned, two spaces between columns.
#[derive(Debug, Default)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these column headings.
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        Table {
            header: header.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row (missing cells print empty).
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows.push(cells.into_iter().map(Into::into).collect());
    }

    /// Writes the table, each line indented by `indent` spaces.
    pub fn write(&self, out: &mut dyn Write, indent: usize) -> io::Result<()> {
        out.write_all(self.render(indent).as_bytes())
    }

    /// The table as text, each line indented by `indent` spaces.
    pub fn render(&self, indent: usize) -> String {
        let mut out = String::new();
        let ncols = self
            .rows
            .iter()
            .map(Vec::len)
            .chain([self.header.len()])
            .max()
            .unwrap_or(0);
        let mut widths = vec![0usize; ncols];
        for row in std::iter::once(&self.header).chain(&self.rows) {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        // A column is numeric when every non-empty body cell parses as a number ("inf" does).
        let numeric: Vec<bool> = (0..ncols)
            .map(|i| {
                self.rows
                    .iter()
                    .filter_map(|r| r.get(i))
                    .filter(|c| !c.is_empty())
                    .all(|c| c.parse::<f64>().is_ok())
            })
            .collect();
        let pad = " ".repeat(indent);
        let line = |row: &[String], out: &mut String| {
            let mut s = pad.clone();
            for (i, w) in widths.iter().enumerate() {
                let cell = row.get(i).map(String::as_str).unwrap_or("");
                if i > 0 {
                    s.push_str("  ");
                }
                if numeric[i] {
                    s.push_str(&format!("{cell:>w$}"));
                } else {
                    s.push_str(&format!("{cell:<w$}"));
                }
            }
            out.push_str(s.trim_end());
            out.push('\n');
        };
        if !self.header.is_empty() {
            line(&self.header, &mut out);
        }
        for row in &self.rows {
            line(row, &mut out);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_prints_as_zero() {
        assert_eq!(num(-1e-12, 6), "0.000000");
        assert_eq!(num(-0.0, 3), "0.000");
        assert_eq!(num(-0.5, 2), "-0.50");
    }

    #[test]
    fn infinite_limits_print_as_inf() {
        assert_eq!(num(f64::INFINITY, 3), "inf");
        assert_eq!(num(f64::NEG_INFINITY, 3), "-inf");
    }

    #[test]
    fn table_aligns_columns() {
        let mut t = Table::new(["name", "kind", "value"]);
        t.row(["a", "revolute", "1.0"]);
        t.row(["longer", "fixed", "-inf"]);
        let mut buf = Vec::new();
        t.write(&mut buf, 2).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert_eq!(
            text,
            "  name    kind      value\n  a       revolute    1.0\n  longer  fixed      -inf\n"
        );
    }
}
