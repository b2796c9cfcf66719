//! The detections of one sweep as `starnet detect` writes them (`{id}.json`, LiDAR frame):
//! a format of its own so any detector's output can be scored ([`crate::score_results`]).

use serde::{Deserialize, Serialize};
use starnet_data::kitti::ObjectClass;

/// One detected box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectedBox {
    /// Class.
    pub class: ObjectClass,
    /// Score in [0, 1].
    pub score: f32,
    /// `[x, y, z, dx, dy, dz, heading]`, LiDAR frame.
    #[serde(rename = "box")]
    pub b: [f32; 7],
}

/// The detections of one sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepDetections {
    /// Sweep id (the file stem).
    pub id: String,
    /// Points in the sweep, as detected.
    pub num_points: usize,
    /// Points of the file beyond `pipeline.wild_points.limit`, dropped before detection
    /// (absent from files written before the limit existed: 0).
    #[serde(default)]
    pub wild_points_dropped: usize,
    /// Whether a calibration was found (and KITTI result lines written).
    pub calibrated: bool,
    /// Boxes, best first.
    pub detections: Vec<DetectedBox>,
}
