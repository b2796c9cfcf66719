//! `starnet detect`: detect objects on raw sweeps (KITTI .bin, PCD, PLY or NumPy .npy).

use clap::Args;
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;

/// Detect objects on raw sweeps (KITTI velodyne .bin; PCD ascii, binary or binary_compressed; PLY
/// ascii or binary; NumPy .npy of N x 3 or N x 4; LiDAR frame, x forward, y left, z up, metres;
/// a cloud without intensity needs a geometry-only model): sampling, gathering, the network,
/// decoding and NMS at the config's evaluation budget. Writes {id}.json (LiDAR boxes) and,
/// with a calibration (--calib, or ROOT/.../calib/{id}.txt beside velodyne/), {id}.txt in
/// KITTI's result format.
#[derive(Args)]
pub struct Detect {
    /// An export folder (holding model.safetensors) or a checkpoint (folder or model.bpk).
    #[arg(long)]
    model: PathBuf,
    /// A point cloud (.bin, .pcd, .ply, .npy) or a folder of them.
    #[arg(long)]
    input: PathBuf,
    /// A KITTI calib file for every sweep.
    #[arg(long)]
    calib: Option<PathBuf>,
    /// With a checkpoint: its config (default: the run's config.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

impl Detect {
    pub fn run(self) -> anyhow::Result<()> {
        let trained = TrainedModel::load(&self.model, self.config.as_deref(), &[])?;
        let files = starnet_train::detect::sweep_files(&self.input)?;
        let sweeps = starnet_train::detect::detect(
            &trained.detector(),
            trained.config.seed,
            &files,
            self.calib.as_deref(),
            &self.out,
        )?;
        for s in &sweeps {
            let note = if s.calibrated {
                ""
            } else {
                " (no calibration: JSON only)"
            };
            let wild = match s.wild_points_dropped {
                0 => String::new(),
                n => format!(" ({n} beyond pipeline.wild_points.limit dropped)"),
            };
            println!(
                "{}: {} points{wild}, {} detections{note}",
                s.id,
                s.num_points,
                s.detections.len()
            );
        }
        println!("wrote {} sweeps to {}", sweeps.len(), self.out.display());
        Ok(())
    }
}
