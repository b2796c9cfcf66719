//! Temporal context (StarNet §4.4, table 4): on a sequence, up to K of frame t's N
//! farthest-point centers are replaced by seeds from frame t − 1's detections (a few per
//! detection, best first), moved into frame t by the relative ego pose; FPS draws the rest as
//! it would without seeds. The compute stays that of N
//! centers; the centers go where objects were. `starnet eval --sequences` runs
//! [`crate::evaluate::evaluate_sequences`] over a grid of (N, K).

mod seeds;
mod sequence;
mod step;

pub use seeds::{PrevCenters, SEEDS_PER_DETECTION, SeedStats, seed_distances, snap_seeds, temporal_seeds};
pub use sequence::{Sequence, open_sequences};
pub(crate) use step::SeededStep;
pub use step::seeded_centers;
