//! `starnet stream-eval`: streaming evaluation.

use anyhow::Context;
use clap::Args;
use starnet_data::sampling::CenterTarget;
use starnet_train::budget::Budget;
use starnet_train::evaluate::{StreamGroundTruth, stream_runs, stream_tables, write_stream};
use starnet_train::stream::StreamModel;
use starnet_train::trained::{TrainedModel, run_label};
use std::path::PathBuf;

/// Streaming evaluation: each sweep cut into n azimuth slices and detected slice by slice;
/// Waymo-style AP per class with per-slice ("localized"), stateful and global NMS, vehicle AP
/// by subtended angle, peak compute and measured per-slice latency with the worst-case
/// latency model. Writes stream.md, stream.json and three plots with --out.
#[derive(Args)]
pub struct StreamEval {
    /// Checkpoint folders (repeat or comma-separate: e.g. a localized and an LSTM model).
    #[arg(long, value_delimiter = ',', required = true)]
    checkpoint: Vec<PathBuf>,
    /// KITTI root (default: the first run's data root).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Split to evaluate.
    #[arg(long, default_value = "val")]
    split: String,
    /// Slice counts n (1, the whole-sweep reference, is always run).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    slices: Vec<usize>,
    /// Evaluate only the first N sweeps of the split.
    #[arg(long)]
    frames: Option<usize>,
    /// Centers per sweep (default: each config's eval.num_centers), spread over the slices.
    #[arg(long)]
    centers: Option<usize>,
    /// Points per center (default: each config's eval.num_points).
    #[arg(long)]
    points: Option<usize>,
    /// Override a config key of every run, e.g. --set stream.nms_memory=2 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Where to write stream.md, stream.json, stream_ap.png, stream_flops.png, stream_latency.png.
    #[arg(long)]
    out: Option<PathBuf>,
}

impl StreamEval {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(self.slices.iter().all(|&n| n > 0), "--slices needs positive counts");
        let mut models = Vec::new();
        let mut first = None;
        for c in &self.checkpoint {
            let trained = TrainedModel::load(c, None, &self.sets)?;
            let cfg = &trained.config;
            let budget = Budget {
                num_centers: self.centers.unwrap_or(cfg.eval.num_centers),
                num_points: self.points.unwrap_or(cfg.eval.num_points),
                target: CenterTarget::All,
            };
            models.push(StreamModel::new(run_label(c), trained.model.clone(), cfg, budget));
            first.get_or_insert(trained.config);
        }
        let mut cfg = first.context("--checkpoint names no run")?;
        if let Some(d) = &self.data {
            cfg.data.root = d.clone();
        }
        let ds = cfg.dataset(&self.split)?;
        let gt = StreamGroundTruth::read(cfg.stream.eval_range, &ds, self.frames)?;
        let runs = stream_runs(&models, &ds, &gt, &self.slices, &mut |label, r| {
            println!("{label}: {r}")
        })?;
        print!("\n{}", stream_tables(&runs));
        if let Some(out) = &self.out {
            write_stream(out, &runs)?;
            println!("wrote {}", out.display());
        }
        Ok(())
    }
}
