//! Training and evaluating a detector from an experiment config.

mod checkpoint;
mod clip;
mod ema;
mod evaluate;
mod schedule;
mod trainer;

pub use checkpoint::{Restored, TrainState, latest_checkpoint, load_checkpoint, load_model, save_checkpoint};
pub use clip::clip_global_norm;
pub use ema::WeightEma;
pub use evaluate::{
    Budget, EvalReport, RANGE_BINS_MAX_M, Scorer, evaluate, frame_seed, mean, quantile, to_kitti, waymo_objects,
};
pub use schedule::lr_multiplier;
pub use trainer::{TrainOptions, TrainSummary, ensure_data, run_dir_for, slices_at, train, validate};
