//! `starnet convert`: a dataset from the KITTI layout to the custom one, or back.

use clap::{Args, ValueEnum};
use starnet_data::convert::{custom_to_kitti, kitti_to_custom};
use std::path::PathBuf;

/// The layout to write.
#[derive(Clone, Copy, ValueEnum)]
enum Target {
    /// OpenPCDet's custom layout: points/{id}.npy, labels/{id}.txt (LiDAR frame), ImageSets/.
    Custom,
    /// KITTI's: training/velodyne/*.bin, training/label_360/*.txt, training/calib/*.txt, ImageSets/.
    Kitti,
}

/// Convert a dataset between the KITTI layout and the custom layout of a LiDAR without a camera
/// (points/{id}.npy, labels/{id}.txt with `x y z dx dy dz heading class`, ImageSets/). The points
/// pass bit for bit; custom -> KITTI -> custom gives the same bytes.
#[derive(Args)]
pub struct Convert {
    /// The dataset root to read (either layout).
    #[arg(long)]
    from: PathBuf,
    /// The root to write; it must not exist yet, or be empty.
    #[arg(long)]
    to: PathBuf,
    /// The layout to write.
    #[arg(long, value_enum)]
    layout: Target,
}

impl Convert {
    pub fn run(self) -> anyhow::Result<()> {
        let done = match self.layout {
            Target::Custom => kitti_to_custom(&self.from, &self.to)?,
            Target::Kitti => custom_to_kitti(&self.from, &self.to)?,
        };
        println!(
            "{} frames written to {} (splits: {})",
            done.frames,
            self.to.display(),
            done.splits.join(", ")
        );
        Ok(())
    }
}
