//! `starnet compare-data A B`: two KITTI-layout folders' realism statistics side by side
//! ([`starnet_sim::realism`]), as a table, JSON and plots.

use crate::Result;
use crate::render::{LinePlot, Series};
use crate::report::ReportFiles;
use starnet_sim::realism::{RealismComparison, RealismReport, ReflectanceBin, realism_report};
use std::path::Path;

/// One folder to measure.
#[derive(Debug, Clone, Copy)]
pub struct DataSource<'a> {
    /// KITTI-layout root.
    pub root: &'a Path,
    /// Split to read (`ImageSets/{split}.txt`); every frame when `None`.
    pub split: Option<&'a str>,
}

/// Measures `a` and `b` (at most `max_frames` of each, when given).
pub fn compare_data(a: DataSource<'_>, b: DataSource<'_>, max_frames: Option<usize>) -> Result<RealismComparison> {
    Ok(RealismComparison {
        a: realism_report(a.root, a.split, max_frames)?,
        b: realism_report(b.root, b.split, max_frames)?,
    })
}

/// Writes `realism.md`, `realism.json` and the plots `reflectance_by_range.png` and
/// `zero_by_range.png` into `out`.
pub fn write_comparison(out: &Path, cmp: &RealismComparison) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| starnet_data::DataError::io(out, e))?;
    let [mean, zeros] = comparison_plots(cmp);
    ReportFiles {
        stem: "realism",
        table: cmp.to_string(),
        data: cmp,
        plots: vec![("reflectance_by_range", mean), ("zero_by_range", zeros)],
    }
    .write(out)
}

/// Mean reflectance and zero share against range, for every return and for car returns of
/// both folders.
pub fn comparison_plots(cmp: &RealismComparison) -> [LinePlot; 2] {
    let name = |r: &RealismReport| {
        r.root
            .file_name()
            .map_or_else(|| r.root.display().to_string(), |n| n.to_string_lossy().into_owned())
    };
    let series = |value: fn(&ReflectanceBin) -> f64| {
        let mut out = Vec::new();
        for r in [&cmp.a, &cmp.b] {
            for (kind, bins) in [("all", &r.reflectance.all), ("cars", &r.reflectance.cars)] {
                out.push(Series {
                    name: format!("{} {kind}", name(r)),
                    points: bins
                        .iter()
                        .filter(|b| b.points > 0)
                        .map(|b| (0.5 * (b.lo + b.hi) as f64, value(b)))
                        .collect(),
                });
            }
        }
        out
    };
    let plot = |title: &str, y_label: &str, value: fn(&ReflectanceBin) -> f64, y_range| LinePlot {
        title: title.into(),
        x_label: "range (m), bin centre".into(),
        y_label: y_label.into(),
        series: series(value),
        log_x: false,
        y_range,
    };
    [
        plot(
            "Mean reflectance by range (camera view)",
            "mean reflectance",
            |b| b.mean,
            Some((0.0, 0.5)),
        ),
        plot(
            "Returns reading exactly 0 by range (camera view)",
            "% of returns",
            |b| b.zero_percent,
            Some((0.0, 100.0)),
        ),
    ]
}
