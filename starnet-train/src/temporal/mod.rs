//! Temporal context (StarNet §4.4, table 4): on a sequence, up to K of frame t's N
//! farthest-point centers are replaced by seeds from frame t − 1's detections (a few per
//! detection, best first), moved into frame t by the relative ego pose; FPS draws the rest as
//! it would without seeds. The compute stays that of N
//! centers; the centers go where objects were. `starnet eval --sequences` runs
//! [`evaluate_sequences`] over a grid of (N, K) and writes [`write_temporal`]'s table and plot.

mod run;
mod seeds;
mod sequence;

pub use run::{
    TemporalReport, evaluate_sequences, replot_temporal, seeded_centers, temporal_plot, temporal_sweep, temporal_table,
    write_temporal,
};
pub use seeds::{PrevCenters, SEEDS_PER_DETECTION, SeedStats, seed_distances, snap_seeds, temporal_seeds};
pub use sequence::{Sequence, open_sequences};
