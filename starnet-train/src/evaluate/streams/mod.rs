//! `starnet stream-eval`: models streamed over a split at several slice counts: Waymo-style
//! AP/APH per class for each NMS mode, AP per subtended angle, peak compute and measured
//! per-slice latency with the worst-case latency model ([`StreamReport`]); its tables and plots
//! ([`write_stream`]).

mod ground_truth;
mod report;
mod runs;
mod split;

pub use ground_truth::StreamGroundTruth;
pub use report::{Latency, latency, replot_stream, stream_plots, stream_tables, write_stream};
pub use runs::{StreamRun, stream_runs};
pub use split::{ModeReport, ModeReports, StreamReport, evaluate_stream};
