//! Training and evaluating a detector from an experiment config.

mod checkpoint;
mod clip;
mod evaluate;
mod schedule;
mod trainer;

pub use checkpoint::{TrainState, latest_checkpoint, load_checkpoint, load_model, save_checkpoint};
pub use clip::clip_global_norm;
pub use evaluate::{EvalReport, evaluate, to_kitti};
pub use schedule::lr_multiplier;
pub use trainer::{TrainOptions, TrainSummary, ensure_data, run_dir_for, train};
