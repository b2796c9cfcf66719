//! Streaming detection (Han et al., "Streaming object detection for 3-D point clouds"): a sweep
//! cut into n azimuth slices and detected slice by slice as the laser delivers them, with
//! per-slice ("localized"), stateful and global NMS and the optional LSTM over slices.
//! `starnet stream-eval` runs [`crate::evaluate::evaluate_stream`] over several slice counts
//! (AP per subtended angle, peak compute and the worst-case latency model).

mod model;
mod sweep;

pub use model::StreamModel;
pub use sweep::{NmsMode, StreamedSweep, stream_sweep};
