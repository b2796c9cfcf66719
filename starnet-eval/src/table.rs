//! Markdown tables: the one writer behind every report's tables (evaluation, budget sweep,
//! temporal and streaming).

use std::fmt;

/// A Markdown table: a header row and rows of cells, written as `| a | b |` lines under a
/// `|---|---|` rule.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these column titles.
    pub fn new<S: ToString>(header: impl IntoIterator<Item = S>) -> Self {
        Self {
            header: header.into_iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    pub fn row<S: ToString>(&mut self, cells: impl IntoIterator<Item = S>) -> &mut Self {
        self.rows.push(cells.into_iter().map(|c| c.to_string()).collect());
        self
    }

    /// Rows so far.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether it has no rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }
}

fn write_row(f: &mut fmt::Formatter<'_>, cells: &[String]) -> fmt::Result {
    write!(f, "|")?;
    for c in cells {
        // An empty cell is `| |`, not `|  |`.
        if c.is_empty() {
            write!(f, " |")?;
        } else {
            write!(f, " {c} |")?;
        }
    }
    writeln!(f)
}

impl fmt::Display for Table {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_row(f, &self.header)?;
        writeln!(f, "|{}", "---|".repeat(self.header.len()))?;
        for r in &self.rows {
            write_row(f, r)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_header_rule_and_rows() {
        let mut t = Table::new(["n", "AP"]);
        t.row(["1", "19.4"]).row([String::from("2"), String::new()]);
        assert_eq!(t.len(), 2);
        assert_eq!(t.to_string(), "| n | AP |\n|---|---|\n| 1 | 19.4 |\n| 2 | |\n");
        assert_eq!(Table::new(["a"]).to_string(), "| a |\n|---|\n");
    }
}
