//! `starnet plot --run DIR`: training curves from a run's `log.jsonl`: the loss and its terms
//! (`loss.png`, smoothed), the learning rate (`lr.png`) and the validation headline AP
//! (`ap.png`, when the run evaluated).
//!
//! A resumed run appends to its log and may repeat the steps after its last checkpoint: the
//! last line of each step wins, as those are the steps the checkpoints continued from.

use crate::render::{LinePlot, Series};
use crate::{Result, TrainError};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One line of `log.jsonl`: a training step, or an evaluation.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct LogLine {
    /// Optimizer steps done.
    pub step: u64,
    /// Learning rate of the step.
    pub lr: Option<f64>,
    /// Total loss.
    pub loss: Option<f64>,
    /// Classification term.
    pub classification: Option<f64>,
    /// Location term.
    pub location: Option<f64>,
    /// Dimension term.
    pub dimension: Option<f64>,
    /// Rotation term.
    pub rotation: Option<f64>,
    /// Headline validation AP.
    pub eval_headline: Option<f64>,
}

/// The steps and evaluations of a log, by step (the last line of a step wins).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunLog {
    /// Training steps.
    pub steps: BTreeMap<u64, LogLine>,
    /// Evaluations: step → headline AP.
    pub evals: BTreeMap<u64, f64>,
}

/// Reads a `log.jsonl`; a line that is not a log record is an error naming the file and line.
pub fn read_log(path: &Path) -> Result<RunLog> {
    let text = std::fs::read_to_string(path).map_err(|e| starnet_data::DataError::io(path, e))?;
    let mut log = RunLog::default();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let rec: LogLine = serde_json::from_str(line).map_err(|e| TrainError::Log {
            path: path.to_path_buf(),
            line: i + 1,
            message: e.to_string(),
        })?;
        match rec.eval_headline {
            Some(ap) => {
                log.evals.insert(rec.step, ap);
            }
            None => {
                log.steps.insert(rec.step, rec);
            }
        }
    }
    Ok(log)
}

/// Centered moving average over `window` values (shrinking at the ends).
pub fn smooth(values: &[(f64, f64)], window: usize) -> Vec<(f64, f64)> {
    let half = window / 2;
    (0..values.len())
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(half), (i + half + 1).min(values.len()));
            let mean = values[lo..hi].iter().map(|v| v.1).sum::<f64>() / (hi - lo) as f64;
            (values[i].0, mean)
        })
        .collect()
}

/// The charts of a log: loss terms, learning rate, and AP when there are evaluations.
pub fn run_plots(log: &RunLog, name: &str) -> Vec<(&'static str, LinePlot)> {
    let series = |label: &str, get: fn(&LogLine) -> Option<f64>| {
        let raw: Vec<(f64, f64)> = log
            .steps
            .values()
            .filter_map(|l| get(l).map(|v| (l.step as f64, v)))
            .collect();
        // Smoothed over 1 % of the steps, then thinned to at most ~1,000 vertices.
        let smoothed = smooth(&raw, (raw.len() / 100).max(1));
        let stride = smoothed.len().div_ceil(1000).max(1);
        Series {
            name: label.into(),
            points: smoothed.into_iter().step_by(stride).collect(),
        }
    };
    let chart = |title: String, y: &str, series: Vec<Series>| LinePlot {
        title,
        x_label: "step".into(),
        y_label: y.into(),
        series,
        log_x: false,
        y_range: None,
    };
    let mut plots = vec![
        (
            "loss.png",
            chart(
                format!("{name}: loss (moving average over 1% of the steps)"),
                "loss",
                vec![
                    series("total", |l| l.loss),
                    series("classification", |l| l.classification),
                    series("location", |l| l.location),
                    series("dimension", |l| l.dimension),
                    series("rotation", |l| l.rotation),
                ],
            ),
        ),
        (
            "lr.png",
            chart(
                format!("{name}: learning rate"),
                "learning rate",
                vec![series("LR", |l| l.lr)],
            ),
        ),
    ];
    if !log.evals.is_empty() {
        let points = log.evals.iter().map(|(&s, &ap)| (s as f64, ap)).collect();
        plots.push((
            "ap.png",
            chart(
                format!("{name}: validation headline AP"),
                "3D AP R40 moderate (%)",
                vec![Series {
                    name: "VAL".into(),
                    points,
                }],
            ),
        ));
    }
    plots
}

/// Reads `run/log.jsonl` and writes its charts into `out` (default: the run folder); returns
/// the files written.
pub fn plot_run(run: &Path, out: Option<&Path>) -> Result<Vec<PathBuf>> {
    let log = read_log(&run.join("log.jsonl"))?;
    let out = out.unwrap_or(run);
    std::fs::create_dir_all(out).map_err(|e| starnet_data::DataError::io(out, e))?;
    let name = run
        .file_name()
        .map_or("run".into(), |n| n.to_string_lossy().into_owned());
    let mut written = Vec::new();
    for (file, chart) in run_plots(&log, &name) {
        let path = out.join(file);
        chart.render()?.save_png(&path)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_line_of_a_step_wins_and_evals_are_separate() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.jsonl");
        let lines = [
            r#"{"step":1,"lr":0.1,"loss":3.0}"#,
            r#"{"step":2,"lr":0.1,"loss":2.0}"#,
            r#"{"step":2,"eval_headline":12.5}"#,
            // Resumed from the checkpoint at step 1: step 2 again.
            r#"{"step":2,"lr":0.1,"loss":1.5}"#,
        ];
        std::fs::write(&path, lines.join("\n")).unwrap();
        let log = read_log(&path).unwrap();
        assert_eq!(log.steps.len(), 2);
        assert_eq!(log.steps[&2].loss, Some(1.5));
        assert_eq!(log.evals[&2], 12.5);
        let plots = run_plots(&log, "T");
        let names: Vec<_> = plots.iter().map(|p| p.0).collect();
        assert_eq!(names, ["loss.png", "lr.png", "ap.png"]);
    }

    #[test]
    fn a_bad_line_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.jsonl");
        std::fs::write(&path, "{\"step\":1,\"loss\":1}\n{\"step\":\n").unwrap();
        let err = read_log(&path).unwrap_err().to_string();
        assert!(err.contains("log.jsonl") && err.contains("line 2"), "{err}");
    }

    #[test]
    fn smoothing_averages_a_centered_window() {
        let v = [(0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 10.0)];
        let s = smooth(&v, 3);
        assert_eq!(s, vec![(0.0, 1.5), (1.0, 2.0), (2.0, 5.0), (3.0, 6.5)]);
        assert_eq!(smooth(&v, 1), v.to_vec());
    }
}
