//! From a loaded frame to the model's input (ARCHITECTURE.md §4–§5): the center pool, center sampling
//! (random, FPS, seeded FPS), neighbourhood gathering, the anchor layout around centers, the
//! azimuth slices of a streaming sweep, and the mirrored views of centers at inference.

mod anchors;
mod arrival;
mod centers;
mod coverage;
mod fps;
mod gather;
mod pool;
mod prepare;
mod slices;
mod target;
mod views;

pub use anchors::{AnchorGrid, AnchorPrior};
pub use centers::{CenterZ, Centers, Sampler, continue_centers, level_centers, sample_centers};
pub use coverage::{CoverageConfig, CoverageTable, coverage};
// The metric and the grid are geometry's; re-exported here beside the gathering that uses them.
pub use crate::geometry::{GatherMetric, SpatialGrid};
pub use arrival::distance_to_undelivered;
pub use gather::{GatherConfig, NUM_FEATURES, Neighbourhoods, ReflectanceInput, gather, gather_with_grid};
pub use pool::{CenterPoolConfig, center_pool, z_band_from_labels};
pub use prepare::{Augmentation, PipelineConfig, PreparedFrame, prepare_frame};
pub use slices::{
    SliceCenters, SliceConfig, SliceContext, SweepSlicer, centers_per_slice, prepare_sweep, slice_points, slice_rng,
};
pub use target::CenterTarget;
pub use views::{CenterViews, View, view_features};
