//! From a loaded frame to the model's input (DESIGN §4–§5): the center pool, center sampling
//! (random, FPS, seeded FPS), neighbourhood gathering, and the anchor layout around centers.

mod anchors;
mod centers;
mod coverage;
mod fps;
mod gather;
mod pool;
mod prepare;
mod target;

pub use anchors::{AnchorGrid, AnchorPrior};
pub use centers::{CenterZ, Centers, Sampler, sample_centers};
pub use coverage::{CoverageConfig, CoverageTable, coverage};
pub use gather::{GatherConfig, NUM_FEATURES, Neighbourhoods, SpatialGrid, gather, gather_with_grid};
pub use pool::{CenterPoolConfig, center_pool, z_band_from_labels};
pub use prepare::{Augmentation, PipelineConfig, PreparedFrame, prepare_frame};
pub use target::CenterTarget;
