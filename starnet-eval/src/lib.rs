//! StarNet evaluation, without a deep-learning dependency: a KITTI or Waymo-metrics user can
//! depend on this crate alone.
//!
//! * [`metrics`]: KITTI AP as the official devkit computes it (R40 and R11, 3D, BEV, 2D, AOS),
//!   Waymo-style AP/APH by difficulty level and range, AP per distance bin and per subtended
//!   angle.
//! * [`Scorer`] applies them to a split's detections, frame by frame; [`score_results`] to a
//!   folder of result files from any detector (KITTI `{id}.txt` or `starnet detect`'s
//!   `{id}.json`, [`SweepDetections`]); [`kitti_results`] and [`kitti_frames`] compute the
//!   KITTI AP alone, from labels and calibrations without the scans.
//! * [`EvalReport`] is a checkpoint's evaluation at one budget (its cost and scores), and
//!   [`Table`] the Markdown writer of every report's tables.
//!
//! Frames and box layout are those of [`starnet_data`]'s crate docs.

#![warn(missing_docs)]

mod detections;
pub mod error;
mod kitti_scores;
pub mod metrics;
mod report;
mod results;
mod scorer;
mod table;

pub use detections::{DetectedBox, SweepDetections};
pub use error::{EvalError, Result};
pub use kitti_scores::{kitti_frames, kitti_results};
pub use report::EvalReport;
pub use results::{FrameResults, ResultFormat, read_detect_json, score_frames, score_results, write_scores};
pub use scorer::{RANGE_BINS_MAX_M, Scorer, Scores, as_written, to_kitti, waymo_objects};
pub use table::Table;
