//! The metrics, each as its official definition computes it: KITTI AP as the devkit does,
//! Waymo-style AP/APH by difficulty level and range, AP per distance bin and per subtended
//! angle, and the maximum-weight matching the Waymo metric pairs boxes with.

mod angle_ap;
mod hungarian;
mod kitti_ap;
mod range_ap;
mod waymo_ap;

pub use angle_ap::{ANGLE_BINS_DEG, AngleAp, ap_by_angle};
pub use hungarian::max_weight_matching;
pub use kitti_ap::{Ap, ApMetric, ClassAp, KittiFrame, kitti_ap, official_min_overlap};
pub use range_ap::{RANGE_BIN_M, RangeAp, ap_by_range};
pub use waymo_ap::{
    ApAph, RANGE_SHARDS, RecallPrecision, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, waymo_ap, waymo_level,
};
