//! Streaming detection (Han et al., "Streaming object detection for 3-D point clouds"): a sweep
//! cut into n azimuth slices and detected slice by slice as the laser delivers them, with
//! per-slice ("localized"), stateful and global NMS, the optional LSTM over slices, AP per
//! subtended angle, peak compute and the worst-case latency model. `starnet stream-eval` runs
//! [`evaluate_stream`] over several slice counts and writes [`write_stream`]'s tables and plots.

mod evaluate;
mod ground_truth;
mod model;
mod report;
mod runs;
mod sweep;

pub use evaluate::{ModeReport, ModeReports, StreamReport, evaluate_stream};
pub use ground_truth::StreamGroundTruth;
pub use model::StreamModel;
pub use report::{Latency, latency, replot_stream, stream_plots, stream_tables, write_stream};
pub use runs::{StreamRun, stream_runs};
pub use sweep::{NmsMode, StreamedSweep, stream_sweep};
