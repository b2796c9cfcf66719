//! Every way of evaluating a model, in one place; those that report a table write it, its JSON and
//! its plots through [`crate::report::ReportFiles`]:
//!
//! | way | function | `starnet` | writes |
//! |---|---|---|---|
//! | a split at one budget | [`evaluate`] | `eval --checkpoint` | result files, `eval.json` |
//! | a grid of budgets (figure 7) | [`sweep`] | `eval --centers A,B --points C,D` | per budget as above; `budget.*` |
//! | every kept checkpoint of a run | [`evaluate_run`] | `eval --run` | per step as above; `run_eval.*` |
//! | sequences with temporal seeding (table 4) | [`temporal_sweep`] | `eval --sequences` | `temporal.*` |
//! | streamed over azimuth slices | [`evaluate_stream`] | `stream-eval` | `stream.*` |
//! | a training run's validation (the first way, or the streamed one for a streaming config) | [`validate`] | `train` | `RUN/results/`, `RUN/eval.json` |
//! | where the centers can reach objects (figure 5) | [`run_coverage`] | `coverage` | a plot |
//!
//! Every way draws frame `i`'s centers from an RNG seeded by (the config's seed, `i`): frame by frame from
//! [`crate::detector::frame_seed`] (a split, budgets, checkpoints, sequences at K = 0, validation), so those agree
//! with each other; slice by slice from their own sub-seed (streams). The same config and seed give the same figures.

mod budgets;
mod checkpoints;
mod coverage;
mod sequences;
mod split;
mod streams;
mod validate;

pub use budgets::{budget_dir_name, budget_grid, budget_plots, budget_table, replot_sweep, sweep, write_sweep};
pub use checkpoints::{CheckpointEval, RunEval, evaluate_run, run_checkpoints, run_plot, run_table, write_run_eval};
pub use coverage::{paper_coverage, run_coverage};
pub use sequences::{
    TemporalReport, evaluate_sequences, replot_temporal, temporal_plot, temporal_sweep, temporal_table, write_temporal,
};
pub use split::{EvalOptions, eval_report, evaluate};
pub use streams::{
    Latency, ModeReport, ModeReports, StreamGroundTruth, StreamReport, StreamRun, evaluate_stream, latency,
    replot_stream, stream_plots, stream_runs, stream_tables, write_stream,
};
pub use validate::validate;
