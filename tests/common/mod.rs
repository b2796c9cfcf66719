//! Helpers shared by the workspace's end-to-end tests.

use std::path::PathBuf;

/// The real KITTI sample: `STARNET_KITTI_SAMPLE`, else `shared/kitti-sample` beside the clone.
pub fn sample_root() -> PathBuf {
    let root = std::env::var_os("STARNET_KITTI_SAMPLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/kitti-sample"));
    assert!(
        root.join("training/velodyne/000000.bin").is_file(),
        "KITTI sample not found at {}",
        root.display()
    );
    root
}
