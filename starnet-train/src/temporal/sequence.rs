//! A sequence on disk: a KITTI root whose frames are consecutive sweeps, with the sensor's
//! pose per frame (`poses.txt`, KITTI odometry format), as `starnet synth --sequences` writes
//! them under `ROOT/sequences/NNNN/`.

use crate::config::ExperimentConfig;
use crate::{Result, TrainError};
use starnet_data::geometry::{Pose, read_poses};
use starnet_data::kitti::KittiDataset;
use std::path::Path;

/// One sequence: its frames in order and their poses.
#[derive(Debug, Clone)]
pub struct Sequence {
    /// The folder name (e.g. `0003`).
    pub name: String,
    /// Every frame of `training/`, in id order, labelled as the config says.
    pub dataset: KittiDataset,
    /// The sensor's pose per frame, in the same order.
    pub poses: Vec<Pose>,
}

/// The sequences under `root/sequences/`, in name order. Every one needs as many poses as
/// frames.
pub fn open_sequences(root: &Path, cfg: &ExperimentConfig) -> Result<Vec<Sequence>> {
    let dir = root.join("sequences");
    let entries = std::fs::read_dir(&dir).map_err(|e| starnet_data::DataError::io(&dir, e))?;
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    if names.is_empty() {
        return Err(TrainError::NoInput {
            dir,
            what: "sequence folders (the simulator writes them: `starnet synth --sequences`)".into(),
        });
    }
    names.iter().map(|name| Sequence::open(&dir.join(name), cfg)).collect()
}

impl Sequence {
    /// One sequence folder (a KITTI root with `poses.txt`), labelled as `cfg` says.
    pub fn open(dir: &Path, cfg: &ExperimentConfig) -> Result<Self> {
        let dataset = KittiDataset::open(dir, None)?
            .with_labels(cfg.data.labels)
            .with_wild_points(cfg.pipeline.wild_points);
        let poses_path = dir.join("poses.txt");
        let poses = read_poses(&poses_path)?;
        if poses.len() != dataset.ids().len() {
            return Err(TrainError::InvalidArgument {
                name: poses_path.display().to_string(),
                message: format!("{} poses for {} frames", poses.len(), dataset.ids().len()),
            });
        }
        Ok(Self {
            name: dir
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
            dataset,
            poses,
        })
    }
}
