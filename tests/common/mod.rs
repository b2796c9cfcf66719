//! Helpers shared by the workspace's end-to-end tests.

// Each test binary uses some of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

/// Runs the `starnet` binary in `cwd`.
pub fn starnet(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_starnet"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

/// The standard output of a run that must have succeeded (else its standard error, in the panic).
pub fn ok(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A tiny camera-view car experiment (seconds to train) with its data root written `DATA`; it
/// keeps every box (score threshold 0), so comparisons of detections are never vacuous.
pub const TINY_CAR: &str = r#"
seed = 2
[data]
root = "DATA"
simulate_frames = 8
classes = ["Car"]
[pipeline]
num_centers = 32
[pipeline.gather]
num_points = 8
radius = 2.0
[model]
d_fc0 = 8
blocks = [[16, 8]]
d_offset = 8
[nms]
iou = [0.1]
score = [0.0]
[train]
epochs = 1
batch_size = 2
workers = 1
[eval]
num_centers = 32
num_points = 8
"#;

/// Writes [`TINY_CAR`] as `dir/name`, its data root `dir/data`; returns the file's path.
pub fn write_tiny_car(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, TINY_CAR.replace("DATA", &dir.join("data").display().to_string())).unwrap();
    path
}
