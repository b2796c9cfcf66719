//! The custom dataset layout for a LiDAR without a camera, OpenPCDet's convention:
//!
//! ```text
//! ROOT/points/{id}.npy        N × 4 float (x y z intensity) or N × 3 (no intensity), LiDAR frame
//! ROOT/labels/{id}.txt        x y z dx dy dz heading class, one object per line (labels.rs)
//! ROOT/ImageSets/{split}.txt  the ids of a split, one per line
//! ```
//!
//! No calibration and no image: the labels are all around the sensor, so such a dataset is
//! evaluated with the Waymo-style metrics (AP/APH, LEVEL_1/LEVEL_2, by range), as the
//! simulator's `label_360` labels are, and its configs set `data.labels = "label_360"` and
//! `pipeline.pool.camera_frustum = false`. [`crate::kitti::KittiDataset::open`] reads this layout
//! as well as KITTI's; `starnet convert` ([`crate::convert`]) converts between the two.

mod labels;

pub use labels::{CustomObject, parse_custom_labels, read_custom_labels, write_custom_labels};

use std::path::{Path, PathBuf};

/// The folder of the point clouds.
pub const POINTS_DIR: &str = "points";
/// The folder of the label files.
pub const LABELS_DIR: &str = "labels";

/// Whether `root` is in the custom layout: it has `points/` and no KITTI `training/`.
pub fn is_custom_layout(root: &Path) -> bool {
    root.join(POINTS_DIR).is_dir() && !root.join("training").is_dir()
}

/// `ROOT/points/{id}.npy`.
pub fn points_path(root: &Path, id: &str) -> PathBuf {
    root.join(POINTS_DIR).join(format!("{id}.npy"))
}

/// `ROOT/labels/{id}.txt`.
pub fn labels_path(root: &Path, id: &str) -> PathBuf {
    root.join(LABELS_DIR).join(format!("{id}.txt"))
}
