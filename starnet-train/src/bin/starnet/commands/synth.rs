//! `starnet synth`: generate the built-in dataset.

use clap::Args;
use starnet_train::synth::{SynthJob, run_stats, run_synth};
use std::path::PathBuf;

/// Generate the built-in dataset: a ray-cast 64-beam LiDAR over simulated streets, written in
/// the KITTI layout (velodyne, label_2, calib, ImageSets, plus a 360-degree label sidecar).
/// With --stats, print a generated set's statistics beside KITTI's instead.
#[derive(Args)]
pub struct Synth {
    /// Output root (it gets `training/` and `ImageSets/`, or `sequences/`).
    #[arg(long, required_unless_present = "stats", conflicts_with = "stats")]
    out: Option<PathBuf>,
    /// Independent scenes to generate.
    #[arg(long, default_value_t = 100, conflicts_with = "sequences")]
    frames: usize,
    /// Generate this many sequences instead (with --length frames each, 10 Hz, poses).
    #[arg(long, requires = "length")]
    sequences: Option<usize>,
    /// Frames per sequence.
    #[arg(long)]
    length: Option<usize>,
    /// Random seed: the same seed writes the same bytes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Share of scenes in the validation split.
    #[arg(long, default_value_t = 0.5)]
    val_fraction: f32,
    /// Print the statistics of the generated set at ROOT.
    #[arg(long, value_name = "ROOT")]
    stats: Option<PathBuf>,
}

impl Synth {
    pub fn run(self) -> anyhow::Result<()> {
        let out = match (self.stats, self.out) {
            (Some(root), _) => return Ok(run_stats(&root)?),
            (None, Some(out)) => out,
            (None, None) => anyhow::bail!("--out or --stats is needed"),
        };
        anyhow::ensure!(
            (0.0..=1.0).contains(&self.val_fraction),
            "--val-fraction must be in [0, 1]"
        );
        let job = match (self.sequences, self.length) {
            (Some(sequences), Some(length)) => SynthJob::Sequences { sequences, length },
            _ => SynthJob::Frames(self.frames),
        };
        let cfg = starnet_sim::SynthConfig {
            val_fraction: self.val_fraction,
            ..Default::default()
        };
        run_synth(&out, job, self.seed, &cfg)?;
        Ok(())
    }
}
