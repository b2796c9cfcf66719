//! A report's files: a Markdown table, the JSON it is drawn from and its plots, written
//! atomically into one folder. Every command that reports a table (`eval`'s budget sweep,
//! `eval --run`, `eval --sequences`, `stream-eval`, `compare-data`) writes and replots through
//! [`ReportFiles`], so they name and write their files alike.

use crate::Result;
use crate::json::write_json;
use crate::render::LinePlot;
use serde::Serialize;
use starnet_data::io::atomic_write;
use std::path::Path;

/// `{stem}.md`, `{stem}.json` and a `{name}.png` per plot.
#[derive(Debug)]
pub struct ReportFiles<'a, T: ?Sized> {
    /// The table's and the JSON's file name without extension (`budget`, `temporal`, …).
    pub stem: &'a str,
    /// The Markdown table.
    pub table: String,
    /// What the table and plots are drawn from, written as pretty JSON (and read back by the
    /// `replot_*` functions).
    pub data: &'a T,
    /// The plots, each by its file name without extension.
    pub plots: Vec<(&'a str, LinePlot)>,
}

impl<T: Serialize + ?Sized> ReportFiles<'_, T> {
    /// Writes every file into `out` (which must exist), each to a temporary file first.
    pub fn write(&self, out: &Path) -> Result<()> {
        atomic_write(&out.join(format!("{}.md", self.stem)), self.table.as_bytes())?;
        write_json(&out.join(format!("{}.json", self.stem)), self.data)?;
        for (name, plot) in &self.plots {
            plot.render()?.save_png(&out.join(format!("{name}.png")))?;
        }
        Ok(())
    }
}
