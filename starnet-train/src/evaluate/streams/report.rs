//! The streaming evaluation's outputs: tables of AP per slice count and NMS mode, of vehicle AP
//! per subtended angle (the paper's table 1), of peak compute and latency with the paper's
//! worst-case latency model (§4.4: scanning a slice at the LiDAR rate, then inferring on it,
//! against a full rotation then a full-sweep inference), and their plots.

use super::runs::StreamRun;
use super::split::StreamReport;
use crate::Result;
use crate::json::read_json;
use crate::render::{LinePlot, Series};
use crate::report::ReportFiles;
use crate::stream::NmsMode;
use serde::{Deserialize, Serialize};
use starnet_eval::Table;
use starnet_eval::metrics::ANGLE_BINS_DEG;
use std::fmt::Write as _;
use std::path::Path;

impl StreamRun {
    /// The whole-sweep report (n = 1).
    fn full(&self) -> &StreamReport {
        &self.reports[0]
    }

    /// The first two cells of a mode's row: the model and the paper's variant name.
    fn row(&self, mode: NmsMode) -> Vec<String> {
        let lstm = if self.reports.first().is_some_and(|r| r.lstm) {
            " + LSTM"
        } else {
            ""
        };
        let mode = match mode {
            NmsMode::Localized => "localized".to_string(),
            NmsMode::Stateful => "+ stateful NMS".to_string(),
            NmsMode::Global => "global NMS".to_string(),
        };
        vec![self.label.clone(), format!("{mode}{lstm}")]
    }
}

/// The worst-case latency of one slice count: from the first return of an object to its box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Latency {
    /// Time to scan one slice, ms.
    pub scan_ms: f64,
    /// Measured inference per slice (median), ms.
    pub inference_ms: f64,
    /// `scan_ms + inference_ms`.
    pub worst_case_ms: f64,
    /// The non-streaming baseline: a full rotation, then the whole sweep's inference.
    pub baseline_ms: f64,
}

/// The paper's worst-case latency model for `r`, with `full_ms` the whole-sweep inference.
pub fn latency(r: &StreamReport, full_ms: f64, scan_hz: f64) -> Latency {
    let rotation = 1e3 / scan_hz;
    let scan_ms = rotation / r.slices as f64;
    Latency {
        scan_ms,
        inference_ms: r.slice_ms_median,
        worst_case_ms: scan_ms + r.slice_ms_median,
        baseline_ms: rotation + full_ms,
    }
}

/// The markdown tables of a streaming evaluation: per class AP and recall / precision by
/// slice count, the first class's AP by subtended angle, and peak compute with latency.
pub fn stream_tables(runs: &[StreamRun]) -> String {
    let mut s = String::new();
    let Some(first) = runs.first() else {
        return s;
    };
    for (k, class) in first.classes.iter().enumerate() {
        let _ = writeln!(
            s,
            "{class}: Waymo-style LEVEL_1 3D AP by slices per sweep ({} sweeps, {} centers per sweep)\n",
            first.full().frames,
            first.full().num_centers
        );
        s += &slice_table(runs, &|r, mode| format!("{:.1}", r.ap(mode, k))).to_string();
        let _ = writeln!(
            s,
            "\n{class}: LEVEL_1 recall / precision of every box the variant emits, % (duplicates cost precision; suppressing the better of two boxes costs recall)\n"
        );
        let boxes = slice_table(runs, &|r, mode| {
            let b = r.mode(mode).waymo.get(k).map(|w| w.all_boxes[0]).unwrap_or_default();
            format!("{:.0} / {:.0}", b.recall, b.precision)
        });
        let _ = writeln!(s, "{boxes}");
    }
    if let Some(last) = first.reports.last() {
        let _ = writeln!(
            s,
            "{}: LEVEL_1 AP by subtended angle at n = {} (change from the whole-sweep baseline)\n",
            first.classes[0], last.slices
        );
        let _ = writeln!(s, "{}", angle_table(runs));
    }
    let _ = writeln!(
        s,
        "Peak compute and latency (per-slice latency: the median over every slice of every sweep, batch 1; worst case: scan of a slice at {} Hz + its inference, baseline: a full rotation + the whole sweep's inference)\n",
        first.scan_hz
    );
    s + &latency_table(runs).to_string()
}

/// One row per model and NMS mode, one `cell` per slice count.
fn slice_table(runs: &[StreamRun], cell: &dyn Fn(&StreamReport, NmsMode) -> String) -> Table {
    let ns = runs[0].reports.iter().map(|r| format!("n = {}", r.slices));
    let mut t = Table::new(["model".to_string(), "variant".into()].into_iter().chain(ns));
    for run in runs {
        for mode in NmsMode::ALL {
            t.row(
                run.row(mode)
                    .into_iter()
                    .chain(run.reports.iter().map(|r| cell(r, mode))),
            );
        }
    }
    t
}

/// The first class's AP by subtended angle at the largest n, against the first model's
/// whole-sweep baseline.
fn angle_table(runs: &[StreamRun]) -> Table {
    let first = &runs[0];
    let base = &first.full().mode(NmsMode::Global).by_angle;
    let bins = base.iter().zip(ANGLE_BINS_DEG).map(|(b, (lo, hi))| {
        let hi = if hi >= 360.0 { "+".to_string() } else { format!("-{hi}") };
        format!("{lo}{hi}° ({})", b.num_objects)
    });
    let mut t = Table::new(["model".to_string(), "variant".into()].into_iter().chain(bins));
    let baseline = [first.label.clone(), "baseline (n = 1)".into()];
    t.row(baseline.into_iter().chain(base.iter().map(|b| format!("{:.1}", b.ap))));
    for run in runs {
        let Some(r) = run.reports.last() else { continue };
        for mode in NmsMode::ALL {
            let cells = r.mode(mode).by_angle.iter().zip(base).map(|(b, b0)| {
                let change = if b0.ap > 0.0 {
                    format!(" ({:+.0} %)", 100.0 * (b.ap - b0.ap) / b0.ap)
                } else {
                    String::new()
                };
                format!("{:.1}{change}", b.ap)
            });
            t.row(run.row(mode).into_iter().chain(cells));
        }
    }
    t
}

/// Per model and slice count: peak compute, measured latency and the worst-case model.
fn latency_table(runs: &[StreamRun]) -> Table {
    let mut t = Table::new([
        "model",
        "n",
        "centers / slice",
        "GFLOP / slice",
        "peak fraction",
        "slice ms",
        "n × slice / sweep",
        "scan ms",
        "worst case ms",
        "baseline ms",
        "speed-up",
    ]);
    for run in runs {
        let full_ms = run.full().slice_ms_median;
        for r in &run.reports {
            let l = latency(r, full_ms, run.scan_hz);
            t.row([
                run.label.clone(),
                r.slices.to_string(),
                r.centers_per_slice.to_string(),
                format!("{:.3}", r.gflop_per_slice),
                format!("{:.3}", r.peak_fraction),
                format!("{:.2}", r.slice_ms_median),
                format!("{:.2}", r.slices as f64 * r.slice_ms_median / full_ms),
                format!("{:.1}", l.scan_ms),
                format!("{:.1}", l.worst_case_ms),
                format!("{:.1}", l.baseline_ms),
                format!("{:.1}×", l.baseline_ms / l.worst_case_ms),
            ]);
        }
    }
    t
}

/// AP of the first class against n and against peak compute, and worst-case latency against n.
pub fn stream_plots(runs: &[StreamRun]) -> [LinePlot; 3] {
    let class = runs.first().map_or(String::new(), |r| r.classes[0].to_string());
    let series = |x: &dyn Fn(&StreamReport) -> f64| {
        runs.iter()
            .flat_map(|run| {
                NmsMode::ALL.into_iter().map(move |mode| Series {
                    name: run.row(mode).join(": "),
                    points: run.reports.iter().map(|r| (x(r), r.ap(mode, 0))).collect(),
                })
            })
            .collect::<Vec<_>>()
    };
    let y_label = format!("{class} LEVEL_1 AP (%)");
    let by_n = LinePlot {
        title: "Streaming: AP vs slices per sweep".into(),
        x_label: "slices n".into(),
        y_label: y_label.clone(),
        series: series(&|r| r.slices as f64),
        log_x: true,
        y_range: None,
    };
    let by_flops = LinePlot {
        title: "Streaming: AP vs peak compute (fraction of a whole sweep)".into(),
        x_label: "peak GFLOP / whole-sweep GFLOP".into(),
        y_label,
        series: series(&|r| r.peak_fraction),
        log_x: true,
        y_range: None,
    };
    let mut lat = Vec::new();
    for run in runs {
        let full = run.full().slice_ms_median;
        let pts = |f: &dyn Fn(&Latency) -> f64| {
            run.reports
                .iter()
                .map(|r| (r.slices as f64, f(&latency(r, full, run.scan_hz))))
                .collect()
        };
        lat.push(Series {
            name: format!("{}: streaming", run.label),
            points: pts(&|l| l.worst_case_ms),
        });
        lat.push(Series {
            name: format!("{}: whole sweep", run.label),
            points: pts(&|l| l.baseline_ms),
        });
    }
    let latency = LinePlot {
        title: "Worst-case latency: scan of a slice + its inference".into(),
        x_label: "slices n".into(),
        y_label: "worst-case latency (ms)".into(),
        series: lat,
        log_x: true,
        y_range: None,
    };
    [by_n, by_flops, latency]
}

/// Writes `stream.md`, `stream.json` and `stream_ap.png`, `stream_flops.png`,
/// `stream_latency.png` into `out`.
pub fn write_stream(out: &Path, runs: &[StreamRun]) -> Result<()> {
    let [ap, flops, latency] = stream_plots(runs);
    ReportFiles {
        stem: "stream",
        table: stream_tables(runs),
        data: runs,
        plots: vec![("stream_ap", ap), ("stream_flops", flops), ("stream_latency", latency)],
    }
    .write(out)
}

/// Redraws `stream.md` and the plots from a folder's `stream.json`.
pub fn replot_stream(dir: &Path) -> Result<()> {
    write_stream(dir, &read_json::<Vec<StreamRun>>(&dir.join("stream.json"))?)
}
