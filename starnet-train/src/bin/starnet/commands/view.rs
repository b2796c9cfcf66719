//! `starnet view`: frames in 3D, as a Rerun recording (a build with the `rerun` feature).

use crate::parse::parse_centers;
use clap::Args;
use starnet_data::sampling::Sampler;
use std::path::PathBuf;

/// Write frames in 3D as a Rerun recording (.rrd) for the Rerun viewer (`pip install rerun-sdk`,
/// then `rerun FILE`; it also opens a file written on a headless server): points coloured by
/// height, ground-truth boxes (green), with --results predicted boxes (orange) with scores,
/// heading marks and, with --centers, the sampled centers; one frame per step of the `frame`
/// timeline. Needs a build with the `rerun` cargo feature.
#[derive(Args)]
pub struct View {
    /// Dataset root, in the KITTI layout (the folder holding `training/`) or the custom one.
    #[arg(long)]
    data: PathBuf,
    /// Frame ids, e.g. `--frame 000001 000002` (in this order on the timeline).
    #[arg(long, num_args = 1.., required_unless_present = "split", conflicts_with = "split")]
    frame: Vec<String>,
    /// Every frame of a split (ImageSets/SPLIT.txt), in its order; see --limit.
    #[arg(long)]
    split: Option<String>,
    /// With --split: at most this many frames.
    #[arg(long, requires = "split")]
    limit: Option<usize>,
    /// Output recording, e.g. scene.rrd.
    #[arg(long)]
    out: PathBuf,
    /// A result folder to show as predictions: KITTI result files (`{id}.txt`, 16 fields) or
    /// `starnet detect`'s `{id}.json` (LiDAR frame; the custom layout's).
    #[arg(long)]
    results: Option<PathBuf>,
    /// Sample and show centers, as SAMPLER:COUNT, e.g. fps:256.
    #[arg(long, value_parser = parse_centers)]
    centers: Option<(Sampler, usize)>,
    /// Centers and labels all around the sensor (the simulator's 360-degree labels, `label_360/`,
    /// when the frame has them), not only the camera's side; centers within --range metres.
    #[arg(long)]
    full: bool,
    /// With --full: how far centers are pooled, in metres.
    #[arg(long, default_value_t = 80.0)]
    range: f32,
    /// Apply the training augmentation first (pastes from ROOT/gt_database.bin if present).
    #[arg(long)]
    augment: bool,
    /// Seed for --augment and --centers.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

impl View {
    #[cfg(feature = "rerun")]
    pub fn run(self) -> anyhow::Result<()> {
        use starnet_data::kitti::KittiDataset;
        use starnet_train::render::{RenderOptions, frame_scene, write_rrd};
        let ds = KittiDataset::open(&self.data, self.split.as_deref())?;
        let ids: Vec<String> = match &self.split {
            Some(_) => ds
                .ids()
                .iter()
                .take(self.limit.unwrap_or(usize::MAX))
                .cloned()
                .collect(),
            None => self.frame.clone(),
        };
        let extra = RenderOptions {
            results: self.results.clone(),
            all_around: self.full,
            augment: self.augment,
            centers: self.centers,
            seed: self.seed,
            given_centers: None,
        };
        let scenes = ids
            .iter()
            .map(|id| frame_scene(&ds, id, &extra, self.range))
            .collect::<Result<Vec<_>, _>>()?;
        write_rrd(&scenes, &self.out)?;
        let points: usize = scenes.iter().map(|s| s.points.len()).sum();
        println!(
            "wrote {} ({} frames, {points} points); open it with `rerun {}`",
            self.out.display(),
            scenes.len(),
            self.out.display()
        );
        Ok(())
    }

    #[cfg(not(feature = "rerun"))]
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::bail!(
            "writing {}: this build lacks the 3D view; build it with the `rerun` cargo feature: \
             cargo build --release --bin starnet --features starnet-train/rerun",
            self.out.display()
        )
    }
}
