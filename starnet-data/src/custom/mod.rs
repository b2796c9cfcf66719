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
mod layout;

pub use labels::{CustomObject, parse_custom_labels, read_custom_labels, write_custom_labels};
pub use layout::{LABELS_DIR, POINTS_DIR, is_custom_layout, labels_path, points_path};
