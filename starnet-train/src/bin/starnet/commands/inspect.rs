//! `starnet inspect`: print what a frame holds.

use clap::Args;
use starnet_data::kitti::KittiDataset;
use starnet_train::inspect::inspect_frame;
use std::path::PathBuf;

/// Print what a frame holds: point count, and per label its class, LiDAR-frame box
/// [x y z dx dy dz heading], difficulty and the number of points inside the box.
#[derive(Args)]
pub struct Inspect {
    /// KITTI root (the folder holding `training/`).
    #[arg(long)]
    data: PathBuf,
    /// Frame id, e.g. 000001.
    #[arg(long)]
    frame: String,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

impl Inspect {
    pub fn run(self) -> anyhow::Result<()> {
        let ds = KittiDataset::open(&self.data, None)?;
        let report = inspect_frame(&ds.load(&self.frame)?);
        if self.json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            print!("{report}");
        }
        Ok(())
    }
}
