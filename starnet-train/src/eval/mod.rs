//! Evaluation: KITTI AP as the official devkit computes it.

mod kitti_ap;

pub use kitti_ap::{Ap, ApMetric, ClassAp, kitti_ap, official_min_overlap};
