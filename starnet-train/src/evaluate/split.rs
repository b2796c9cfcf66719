//! `starnet eval --checkpoint`: a model on a split at a center/point budget: detections for
//! every frame, written as KITTI result files and scored by [`Scorer`] (KITTI AP, Waymo-style
//! AP/APH, AP per 10 m); the per-frame latency.

use crate::Result;
use crate::config::ExperimentConfig;
use crate::detector::{Detector, frame_seed};
use starnet_data::events::Task;
use starnet_data::kitti::KittiDataset;
use starnet_data::summary::{mean, quantile};
use starnet_eval::{EvalReport, Scorer, Scores};
use std::path::Path;
use std::time::Instant;

/// The report of `detector` (at its budget) scoring `scores`, its frames having taken
/// `latencies_ms` each.
pub fn eval_report(detector: &Detector, scores: Scores, latencies_ms: &[f64]) -> EvalReport {
    let budget = detector.budget();
    EvalReport {
        num_centers: budget.num_centers,
        num_points: budget.num_points,
        target: budget.target,
        views: detector.views,
        gflop_per_frame: detector.gflop_per_frame(),
        latency_ms_mean: mean(latencies_ms),
        latency_ms_p95: quantile(latencies_ms, 0.95).unwrap_or(0.0),
        scores,
    }
}

/// How [`evaluate`] batches and seeds the frames of a split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EvalOptions {
    /// Frames per forward.
    pub batch_size: usize,
    /// The experiment seed: frame `i` samples its centers from [`frame_seed`]`(seed, i)`.
    pub seed: u64,
}

impl EvalOptions {
    /// The config's evaluation batch size and seed.
    pub fn of(cfg: &ExperimentConfig) -> Self {
        Self {
            batch_size: cfg.eval.batch_size,
            seed: cfg.seed,
        }
    }
}

/// Evaluates `detector` on `dataset` at its budget; writes `{id}.txt` result files to
/// `results` when given.
pub fn evaluate(
    detector: &Detector,
    dataset: &KittiDataset,
    opts: EvalOptions,
    results: Option<&Path>,
) -> Result<EvalReport> {
    let mut scorer = Scorer::new(&detector.classes, dataset.labels(), results);
    let batch = opts.batch_size.max(1);
    let budget = detector.budget();
    let mut latencies = Vec::with_capacity(dataset.ids().len());
    let task = Task::begin(
        &format!("eval {} x {}", budget.num_centers, budget.num_points),
        dataset.ids().len() as u64,
    );
    for (chunk_i, ids) in dataset.ids().chunks(batch).enumerate() {
        let loaded: Vec<_> = ids
            .iter()
            .map(|id| dataset.load(id))
            .collect::<std::result::Result<_, _>>()?;
        let seeds: Vec<u64> = (0..ids.len())
            .map(|k| frame_seed(opts.seed, chunk_i * batch + k))
            .collect();
        // Latency: from the loaded scan to the final boxes (reading files and scoring excluded).
        let start = Instant::now();
        let decoded = detector.detect_batch(&loaded.iter().collect::<Vec<_>>(), &seeds);
        let per_frame = start.elapsed().as_secs_f64() * 1e3 / ids.len() as f64;
        for (frame, decoded) in loaded.into_iter().zip(decoded) {
            scorer.add(frame, &decoded)?;
            latencies.push(per_frame);
        }
        task.inc(ids.len() as u64);
    }
    drop(task);
    Ok(eval_report(detector, scorer.finish(), &latencies))
}
