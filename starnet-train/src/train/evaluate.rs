//! Evaluating a model on a split at a center/point budget: detections for every frame, written
//! as KITTI result files and scored by [`Scorer`] (KITTI AP, Waymo-style AP/APH, AP per 10 m);
//! the per-frame latency.

use crate::Result;
use crate::config::ExperimentConfig;
use crate::detector::Detector;
use crate::eval::{Scorer, Scores};
use crate::synth::progress_bar;
use serde::{Deserialize, Serialize};
use starnet_data::kitti::KittiDataset;
use starnet_data::sampling::CenterTarget;
use starnet_data::sim::sub_seed;
use starnet_data::summary::{mean, quantile};
use std::path::Path;
use std::time::Instant;

/// What an evaluation found: the budget and its cost, and the scores.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvalReport {
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Which sampled centers the model saw.
    pub target: CenterTarget,
    /// Forward GFLOP per frame at this budget.
    pub gflop_per_frame: f64,
    /// Mean wall time per frame (preparation, forward, decoding), ms.
    pub latency_ms_mean: f64,
    /// 95th percentile of the per-frame time, ms.
    pub latency_ms_p95: f64,
    /// The scores (`eval.json` holds their fields beside the budget's).
    #[serde(flatten)]
    pub scores: Scores,
}

impl EvalReport {
    /// The report of `detector` (at its budget) scoring `scores`, its frames having taken
    /// `latencies_ms` each.
    pub fn new(detector: &Detector, scores: Scores, latencies_ms: &[f64]) -> Self {
        let budget = detector.budget();
        Self {
            num_centers: budget.num_centers,
            num_points: budget.num_points,
            target: budget.target,
            gflop_per_frame: detector.gflop_per_frame(),
            latency_ms_mean: mean(latencies_ms),
            latency_ms_p95: quantile(latencies_ms, 0.95).unwrap_or(0.0),
            scores,
        }
    }

    /// The headline AP ([`Scores::headline`]).
    pub fn headline(&self) -> f64 {
        self.scores.headline()
    }
}

impl std::fmt::Display for EvalReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let target = match self.target {
            CenterTarget::All => String::new(),
            t => format!(" (target {t})"),
        };
        writeln!(
            f,
            "{} frames, {} centers{target} x {} points ({:.2} GFLOP/frame), latency {:.1} ms mean, {:.1} ms p95",
            self.scores.frames,
            self.num_centers,
            self.num_points,
            self.gflop_per_frame,
            self.latency_ms_mean,
            self.latency_ms_p95
        )?;
        write!(f, "{}", self.scores)
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
    let bar = progress_bar(
        dataset.ids().len() as u64,
        &format!("eval {} x {}", budget.num_centers, budget.num_points),
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
        bar.inc(ids.len() as u64);
    }
    bar.finish_and_clear();
    Ok(EvalReport::new(detector, scorer.finish(), &latencies))
}

/// The seed of the `i`-th evaluated frame's sampling RNG, for experiment seed `seed`.
pub fn frame_seed(seed: u64, i: usize) -> u64 {
    sub_seed(seed, 21, i as u64)
}
