//! Evaluation: KITTI AP as the official devkit computes it, Waymo-style AP/APH by difficulty
//! level and range, AP per distance bin, and AP per subtended angle; [`Scorer`] applies them to
//! a split's detections, and [`score_results`] to a folder of result files from any detector.

mod angle_ap;
mod hungarian;
mod kitti_ap;
mod range_ap;
mod results;
mod scorer;
mod waymo_ap;

pub use angle_ap::{ANGLE_BINS_DEG, AngleAp, ap_by_angle};
pub use hungarian::max_weight_matching;
pub use kitti_ap::{Ap, ApMetric, ClassAp, kitti_ap, official_min_overlap};
pub use range_ap::{RANGE_BIN_M, RangeAp, ap_by_range};
pub use results::{ResultFormat, read_detect_json, score_results, write_scores};
pub use scorer::{RANGE_BINS_MAX_M, Scorer, Scores, as_written, to_kitti, waymo_objects};
pub use waymo_ap::{
    ApAph, RANGE_SHARDS, RecallPrecision, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, waymo_ap, waymo_level,
};
