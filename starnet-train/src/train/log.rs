//! The training log: `log.jsonl`, one JSON object per step (every scalar) and one per
//! evaluation (`eval_headline`), appended so a resumed run continues the same file; and the
//! progress shown while training.

use super::step::StepLosses;
use crate::Result;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// One step's line of `log.jsonl`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StepRecord {
    /// Steps done.
    pub step: u64,
    /// Epochs done.
    pub epoch: f64,
    /// The learning rate of the step.
    pub lr: f64,
    /// Its losses and gradient norm.
    #[serde(flatten)]
    pub losses: StepLosses,
    /// Training frames per second over the step, data loading included.
    pub frames_per_s: f64,
}

/// `log.jsonl`, open for appending.
pub struct TrainLog {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
}

impl TrainLog {
    /// Opens (or creates) `path` for appending.
    pub fn open(path: &Path) -> Result<Self> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| starnet_data::DataError::io(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            file: std::io::BufWriter::new(file),
        })
    }

    /// Appends a step.
    pub fn step(&mut self, record: &StepRecord) -> Result<()> {
        self.line(&serde_json::to_value(record).expect("records serialise"))
    }

    /// Appends an evaluation's headline metric after `step` steps.
    pub fn evaluation(&mut self, step: u64, headline: f64) -> Result<()> {
        self.line(&serde_json::json!({"step": step, "eval_headline": headline}))
    }

    /// Writes what is buffered to the file.
    pub fn flush(&mut self) -> Result<()> {
        self.file
            .flush()
            .map_err(|e| starnet_data::DataError::io(&self.path, e).into())
    }

    fn line(&mut self, value: &serde_json::Value) -> Result<()> {
        writeln!(self.file, "{value}").map_err(|e| starnet_data::DataError::io(&self.path, e).into())
    }
}

/// The progress line of a step.
pub fn progress_line(record: &StepRecord, total: u64) -> String {
    let l = &record.losses;
    format!(
        "step {}/{total} epoch {:.2} loss {:.4} cls {:.4} loc {:.4} dim {:.4} rot {:.4} lr {:.2e} {:.1} frames/s",
        record.step,
        record.epoch,
        l.loss,
        l.classification,
        l.location,
        l.dimension,
        l.rotation,
        record.lr,
        record.frames_per_s
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_line_holds_every_scalar_under_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.jsonl");
        let losses = StepLosses {
            loss: 1.5,
            classification: 0.5,
            location: 0.25,
            dimension: 0.125,
            rotation: 0.0625,
            direction: 0.75,
            grad_norm: 3.0,
        };
        let mut log = TrainLog::open(&path).unwrap();
        log.step(&StepRecord {
            step: 7,
            epoch: 0.5,
            lr: 0.002,
            losses,
            frames_per_s: 40.0,
        })
        .unwrap();
        log.evaluation(7, 61.25).unwrap();
        log.flush().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let expected = serde_json::json!({"step": 7, "epoch": 0.5, "lr": 0.002, "loss": 1.5,
            "classification": 0.5, "location": 0.25, "dimension": 0.125, "rotation": 0.0625,
            "direction": 0.75, "grad_norm": 3.0, "frames_per_s": 40.0});
        assert_eq!(
            lines,
            vec![expected, serde_json::json!({"step": 7, "eval_headline": 61.25})]
        );
    }
}
