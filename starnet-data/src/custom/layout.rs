//! The custom layout's folders and file names.

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
