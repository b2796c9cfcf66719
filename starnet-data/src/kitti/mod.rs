//! The KITTI 3D object formats: velodyne scans, `label_2` ground truth and result files,
//! calibration, `ImageSets` splits, conversions between the LiDAR and camera frames, and a
//! dataset type that lists and loads frames. Writers reproduce KITTI's exact bytes.
//! Format facts: `shared/reference/kitti-format.md`.

mod calib;
mod camera;
mod dataset;
mod label;
mod sidecar;
mod split;

pub use calib::{Calib, KITTI_000000_CALIB, format_c_exp};
pub use camera::{ImageSize, observation_angle};
pub use dataset::{Annotations, Frame, KittiDataset, LabelSource, Layout, MissingIntensity};
pub use label::{
    CameraBox, Difficulty, KittiObject, NO_ALPHA, format_labels, parse_labels, read_labels, write_labels, write_results,
};
pub use sidecar::{SimObject, parse_sidecar, read_sidecar, write_sidecar};
pub use split::{parse_split, read_split, write_split};
// The velodyne `.bin` codec lives with the other point-cloud formats.
pub use crate::class::ObjectClass;
pub use crate::cloud::{decode_points, encode_points, read_points, write_points};
