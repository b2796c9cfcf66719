//! `starnet render`: draw a bird's-eye-view PNG of a frame.

use crate::parse::parse_centers;
use anyhow::Context;
use clap::Args;
use starnet_data::kitti::KittiDataset;
use starnet_data::sampling::Sampler;
use starnet_train::budget::Budget;
use starnet_train::render::{BevOptions, RenderOptions, render_frame};
use starnet_train::temporal::{PrevCenters, Sequence, seeded_centers};
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;

/// Draw a bird's-eye-view PNG of a frame: points shaded by height, ground-truth boxes
/// (green) and, with --results, predicted boxes (orange), each with a heading mark.
#[derive(Args)]
pub struct Render {
    /// KITTI root (the folder holding `training/`).
    #[arg(long)]
    data: PathBuf,
    /// Frame id, e.g. 000001.
    #[arg(long)]
    frame: String,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// A result folder to draw as predictions: KITTI result files (`{id}.txt`, 16 fields) or
    /// `starnet detect`'s `{id}.json`.
    #[arg(long)]
    results: Option<PathBuf>,
    /// How far the view reaches in metres: forward to `range` (and 0.55 x range to each
    /// side), or with --full to `range` in every direction.
    #[arg(long, default_value_t = 80.0)]
    range: f32,
    /// Show all 360 degrees around the sensor, not only the camera's side (with the
    /// simulator's 360-degree labels, `label_360/`, when the frame has them).
    #[arg(long)]
    full: bool,
    /// Pixels per metre.
    #[arg(long, default_value_t = 10.0)]
    px_per_m: f32,
    /// Apply the training augmentation first (pastes from ROOT/gt_database.bin if present).
    #[arg(long)]
    augment: bool,
    /// Sample and draw centers, as SAMPLER:COUNT, e.g. fps:256 or random:128.
    #[arg(long, value_parser = parse_centers)]
    centers: Option<(Sampler, usize)>,
    /// Seed for --augment and --centers.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// With --prev-centers on a sequence folder (ROOT/sequences/NNNN, with poses.txt): the
    /// model whose previous-frame detections seed this frame's --centers.
    #[arg(long, requires = "prev_centers")]
    checkpoint: Option<PathBuf>,
    /// How many of the --centers come from the previous frame's detections (32 or 50%);
    /// seeded centers are drawn in cyan.
    #[arg(long, requires = "checkpoint")]
    prev_centers: Option<PrevCenters>,
}

impl Render {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.range > 0.0 && self.px_per_m > 0.0,
            "--range and --px-per-m must be positive"
        );
        anyhow::ensure!(
            self.range * self.px_per_m <= 8000.0,
            "--range x --px-per-m must be at most 8000 (image side 16000 px)"
        );
        let ds = KittiDataset::open(&self.data, None)?;
        let view = if self.full {
            BevOptions::around(self.range, self.px_per_m)
        } else {
            BevOptions::front(self.range, self.px_per_m)
        };
        let extra = RenderOptions {
            given_centers: self.seeded_centers()?,
            results: self.results,
            all_around: self.full,
            augment: self.augment,
            centers: self.centers,
            seed: self.seed,
        };
        let canvas = render_frame(&ds, &self.frame, &extra, &view)?;
        canvas
            .save_png(&self.out)
            .with_context(|| format!("writing {}", self.out.display()))?;
        println!(
            "wrote {} ({} x {} px)",
            self.out.display(),
            canvas.width(),
            canvas.height()
        );
        Ok(())
    }

    /// With --checkpoint and --prev-centers: the frame's centers seeded by its predecessor.
    fn seeded_centers(&self) -> anyhow::Result<Option<starnet_data::sampling::Centers>> {
        let (Some(checkpoint), Some(prev)) = (&self.checkpoint, self.prev_centers) else {
            return Ok(None);
        };
        let trained = TrainedModel::load(checkpoint, None, &[])?;
        let seq = Sequence::open(&self.data, &trained.config)?;
        let t = seq
            .dataset
            .ids()
            .iter()
            .position(|i| *i == self.frame)
            .with_context(|| format!("no frame {} in {}", self.frame, self.data.display()))?;
        let detector = trained.detector();
        let detector = match self.centers {
            Some((_, n)) => detector.at_budget(Budget {
                num_centers: n,
                ..detector.budget()
            }),
            None => detector,
        };
        Ok(Some(seeded_centers(&detector, trained.config.seed, &seq, t, prev)?))
    }
}
