//! `starnet train`: train a detector from an experiment config (TOML).

use crate::distributed::{Distributed, abort_job, join_world};
use anyhow::Context;
use clap::Args;
use starnet_train::train::{InitSource, Resume, TrainOptions, run_dir_for, train};
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Train a detector from an experiment config (TOML). Generates the built-in simulator data
/// if the config asks for it, then trains, checkpoints every epoch, and evaluates on the
/// validation split at the end. Ctrl-C saves a checkpoint and stops; --resume continues.
#[derive(Args)]
pub struct Train {
    /// Experiment file, e.g. configs/quickstart.toml.
    #[arg(long)]
    config: PathBuf,
    /// Continue from the newest checkpoint of the run.
    #[arg(long)]
    resume: bool,
    /// Override a config key: --set train.epochs=3 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Run folder (default: {train.run_root}/{config file stem}).
    #[arg(long)]
    run: Option<PathBuf>,
    /// Stop after this many steps in total.
    #[arg(long)]
    max_steps: Option<u64>,
    /// Train data-parallel as one process of an MPI job: `mpirun -np N starnet train
    /// --distributed mpi ...` (a build with the `mpi` feature). `train.batch_size` is the global
    /// batch, split across the N processes.
    #[arg(long, value_enum)]
    distributed: Option<Distributed>,
    /// Where the model trains: flex (the CPU, default), vulkan, vulkan:N, wgpu or wgpu:N (a GPU; a build
    /// with that cargo feature). The same as --set train.device=...
    #[arg(long)]
    device: Option<String>,
    /// Fine-tune: start from another model's weights, a checkpoint folder (runs/NAME/checkpoints/best),
    /// a model.bpk or an export folder (models/quickstart). Tensors whose shape differs (other
    /// classes or anchors) are re-initialised and named; the optimizer starts fresh. Hold the
    /// featurizer fixed at first with --set train.freeze_featurizer_epochs=N.
    #[arg(long, value_name = "CHECKPOINT_OR_EXPORT")]
    init: Option<PathBuf>,
}

impl Train {
    pub fn run(self) -> anyhow::Result<()> {
        let mut sets = self.sets;
        sets.extend(self.device.map(|d| format!("train.device={d:?}")));
        let cfg = starnet_train::config::load_config(&self.config, &sets)?;
        let run_dir = self.run.unwrap_or_else(|| run_dir_for(&cfg, &self.config));
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)).context("installing the Ctrl-C handler")?;
        let world = self.distributed.map(|_| join_world()).transpose()?;
        let init = self
            .init
            .map(|path| -> anyhow::Result<InitSource> {
                let source = TrainedModel::load(&path, None, &[])
                    .with_context(|| format!("loading the model to fine-tune from, {}", path.display()))?;
                Ok(InitSource {
                    path,
                    model: source.model,
                })
            })
            .transpose()?;
        let opts = TrainOptions {
            resume: if self.resume {
                Resume::Always
            } else {
                Resume::IfSameConfig
            },
            max_steps: self.max_steps,
            stop: Some(stop),
            replicas: world
                .clone()
                .map(|w| w as Arc<dyn starnet_train::distributed::Replicas>),
            init,
        };
        let result = train(&cfg, &run_dir, &opts).map_err(|e| match e {
            starnet_train::TrainError::RunExists { .. } => anyhow::anyhow!("{e}; pass --resume to continue it"),
            e => e.into(),
        });
        let summary = match (result, &world) {
            (Ok(summary), _) => summary,
            (Err(e), Some(world)) => abort_job(world, &e),
            (Err(e), None) => return Err(e),
        };
        if opts.replicas.as_ref().is_some_and(|r| r.rank() != 0) {
            return Ok(());
        }
        println!("{} steps; run folder {}", summary.steps, summary.run_dir.display());
        if let Some(report) = summary.eval {
            print!("{report}");
        }
        Ok(())
    }
}
