//! A scored box: what a detector outputs and what the metrics score.

use super::Box3d;
use crate::class::ObjectClass;
use serde::{Deserialize, Serialize};

/// A scored box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// The box, LiDAR frame.
    pub b: Box3d,
    /// The class.
    pub class: ObjectClass,
    /// Score in [0, 1].
    pub score: f32,
}
