//! Training and evaluating a detector from an experiment config, as pieces a custom loop can
//! assemble: [`RunFolder`] (config, checkpoints), [`train_loader`] (prepared batches in
//! threads), [`Trainer`] (one optimisation step), [`TrainLog`], [`Schedule`] and
//! [`crate::evaluate::validate`];
//! [`train`] is the loop `starnet train` runs.
//!
//! A custom loop (a few steps on the simulator data; `no_run`: it needs `data/sim`):
//!
//! ```no_run
//! use starnet_train::config::load_config;
//! use starnet_train::distributed::Shard;
//! use starnet_train::evaluate::validate;
//! use starnet_train::train::{Resume, RunFolder, Schedule, Trainer, ensure_data, paste_database, train_loader};
//! use std::path::Path;
//!
//! let cfg = load_config(Path::new("configs/quickstart.toml"), &["train.epochs=1".into()])?;
//! ensure_data(&cfg)?;
//! let run = RunFolder::create(Path::new("runs/custom"), &cfg, Resume::IfSameConfig)?;
//! let train_set = cfg.dataset(&cfg.data.train_split)?;
//! let schedule = Schedule::new(&cfg.train, train_set.ids().len(), Some(20));
//! let device = starnet_model::backend::default_device().autodiff();
//! let mut trainer = Trainer::start(&cfg, None, &device)?;
//! let mut items = train_loader(&cfg, &train_set, paste_database(&cfg)?, schedule, 0, Shard::whole());
//! while trainer.state.step < schedule.end {
//!     let sweeps = (&mut items).take(cfg.train.batch_size).collect::<Result<Vec<_>, _>>()?;
//!     let losses = trainer.step(&sweeps, schedule.lr(cfg.train.learning_rate, trainer.state.step))?;
//!     println!("step {} loss {:.4}", trainer.state.step, losses.loss);
//! }
//! run.save_step(&trainer, 1, schedule.steps_per_epoch)?;
//! let report = validate(&trainer.eval_model(), &cfg, &cfg.dataset(&cfg.data.val_split)?, None)?;
//! println!("{report}");
//! # Ok::<(), starnet_train::TrainError>(())
//! ```

mod clip;
mod curves;
mod data;
mod ema;
mod init_from;
mod log;
mod run_lock;
mod schedule;
mod snapshot;
mod step;
mod trainer;

pub use clip::{clip_global_norm, global_norm, scale_to_norm, squared_grad_norms};
pub use curves::{LogLine, RunLog, plot_run, read_log, run_plots, smooth};
pub use data::{TrainItem, ensure_data, paste_database, prepare_database, slices_at, train_item, train_loader};
pub use ema::WeightEma;
pub use init_from::{FreshTensor, InitReport, InitSource, Reinitialised, init_from};
pub use log::{StepRecord, TrainLog, progress_line};
pub use run_lock::{LOCK_FILE, RunLock};
pub use schedule::{Schedule, lr_multiplier};
pub use snapshot::{Restored, load_checkpoint, save_checkpoint};
pub use step::{Featurizer, StepLosses, Trainer};
pub use trainer::{OnTie, Resume, RunEnd, RunFolder, TrainOptions, TrainSummary, end_epoch, run_dir_for, train};
