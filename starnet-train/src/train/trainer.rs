//! `starnet train`: the training loop, as named steps a custom loop can call. Batches are
//! prepared in loader threads ([`super::train_loader`]: augmentation, sampling, gathering,
//! target assignment) while the model computes ([`super::Trainer::step`]: Adam with the
//! authors' schedule, global-norm clipping and L2; a weight EMA for evaluation); every scalar
//! goes to a JSON-lines log; checkpoints at every epoch (and on Ctrl-C) let `--resume` continue
//! bit for bit; evaluation on the validation split (with the EMA weights) keeps the best
//! checkpoint.
//!
//! A streaming config (`stream.train_slices`) cuts every sweep of a step into the same drawn
//! number of slices and runs them as one sequence (through the LSTM, when the model has one).

use super::data::{TrainItem, ensure_data, paste_database, train_loader};
use super::init_from::{InitReport, InitSource};
use super::log::{StepRecord, TrainLog, progress_line};
use super::run_lock::RunLock;
use super::schedule::Schedule;
use super::step::{Featurizer, Trainer};
use crate::checkpoint::{latest_checkpoint, prune, recover_checkpoints};
use crate::config::{ExperimentConfig, to_toml};
use crate::distributed::{Replicas, Role};
use crate::evaluate::validate;
use crate::json::write_json;
use crate::{Result, TrainError};
use starnet_data::events::{Task, note};
use starnet_data::kitti::KittiDataset;
use starnet_eval::EvalReport;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// How to run.
#[derive(Debug, Clone, Default)]
pub struct TrainOptions {
    /// What to do with a run folder that already holds checkpoints.
    pub resume: Resume,
    /// Stop after this many steps in total (for tests and smoke runs).
    pub max_steps: Option<u64>,
    /// Set by a Ctrl-C handler: save and stop at the next step (every replica, when any is
    /// asked).
    pub stop: Option<Arc<AtomicBool>>,
    /// Train as one replica of this group (data-parallel; [`crate::distributed`]).
    pub replicas: Option<Arc<dyn Replicas>>,
    /// Fine-tune: a new run starts from this model's weights ([`Trainer::fine_tune`]); a
    /// resumed run ignores it (its checkpoint holds the weights).
    pub init: Option<InitSource>,
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct TrainSummary {
    /// The run folder.
    pub run_dir: PathBuf,
    /// Steps done.
    pub steps: u64,
    /// Whether the schedule ran to its end.
    pub end: RunEnd,
    /// The final evaluation on the validation split.
    pub eval: Option<EvalReport>,
}

/// What [`RunFolder::create`] does with a folder that already holds checkpoints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Resume {
    /// Continue from its newest checkpoint, whatever config wrote it (`--resume`).
    Always,
    /// Continue only when its `config.toml` is this config (the same command run again after a
    /// kill continues, as OpenPCDet's does); refuse another config.
    #[default]
    IfSameConfig,
}

/// How a training run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunEnd {
    /// The schedule ran to its last step.
    Finished,
    /// Stopped before it (Ctrl-C or `--max-steps`): a checkpoint was saved; `--resume` continues.
    Stopped,
}

/// The run folder of a config: `{run_root}/{file stem}`.
pub fn run_dir_for(cfg: &ExperimentConfig, config_path: &Path) -> PathBuf {
    cfg.train.run_root.join(config_path.file_stem().unwrap_or_default())
}

/// Which checkpoint [`RunFolder::keep_best`] keeps when a new metric equals the best.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnTie {
    /// The earlier `best` (evaluations during training).
    KeepOld,
    /// The new weights (the final evaluation: the run's last word).
    TakeNew,
}

/// A run folder, ready: `checkpoints/` exists and `config.toml` holds the resolved config.
#[derive(Debug, Clone)]
pub struct RunFolder {
    /// The run folder.
    pub dir: PathBuf,
    /// Its `checkpoints/`.
    pub checkpoints: PathBuf,
    /// The newest `step-*` checkpoint, when resuming.
    pub resume_from: Option<PathBuf>,
    /// The writer's lock, held while any clone of this folder lives ([`RunLock`]).
    _lock: Option<Arc<RunLock>>,
}

impl RunFolder {
    /// Takes the writer's lock of `dir` ([`RunLock`]: a folder another trainer is writing is
    /// refused) and prepares it for `cfg`. A folder holding checkpoints is continued or refused
    /// as `resume` says.
    pub fn create(dir: &Path, cfg: &ExperimentConfig, resume: Resume) -> Result<Self> {
        Self::create_locked(dir, cfg, resume, RunLock::acquire(dir)?)
    }

    /// [`RunFolder::create`] with the lock of `dir` already held.
    pub fn create_locked(dir: &Path, cfg: &ExperimentConfig, resume: Resume, lock: RunLock) -> Result<Self> {
        let checkpoints = dir.join("checkpoints");
        recover_checkpoints(&checkpoints)?;
        let resume_from = latest_checkpoint(&checkpoints);
        let config = to_toml(cfg);
        if resume_from.is_some() && resume == Resume::IfSameConfig {
            let saved = std::fs::read_to_string(dir.join("config.toml")).unwrap_or_default();
            if saved != config {
                return Err(TrainError::RunExists { dir: dir.to_path_buf() });
            }
            note(format!(
                "{} holds checkpoints of this same config: continuing it (choose another run folder to start over)",
                dir.display()
            ));
        }
        std::fs::create_dir_all(&checkpoints).map_err(|e| starnet_data::DataError::io(&checkpoints, e))?;
        starnet_data::io::atomic_write(&dir.join("config.toml"), config.as_bytes())?;
        Ok(Self {
            dir: dir.to_path_buf(),
            checkpoints,
            resume_from,
            _lock: Some(Arc::new(lock)),
        })
    }

    /// An existing run folder as another member of data-parallel training sees it, after
    /// replica 0 has prepared it: nothing is written.
    pub fn open(dir: &Path) -> Self {
        let checkpoints = dir.join("checkpoints");
        Self {
            resume_from: latest_checkpoint(&checkpoints),
            dir: dir.to_path_buf(),
            checkpoints,
            _lock: None,
        }
    }

    /// Saves `trainer` as its `step-*` checkpoint and prunes to the newest `keep` taken at
    /// epoch ends (epochs of `steps_per_epoch`), see [`prune`].
    pub fn save_step(&self, trainer: &Trainer, keep: usize, steps_per_epoch: u64) -> Result<()> {
        trainer.save(&self.checkpoints, &format!("step-{:08}", trainer.state.step))?;
        prune(&self.checkpoints, keep.max(1), steps_per_epoch);
        Ok(())
    }

    /// Keeps `trainer` as `best` when `metric` beats the best so far (or equals it, with
    /// [`OnTie::TakeNew`]).
    pub fn keep_best(&self, trainer: &mut Trainer, metric: f64, on_tie: OnTie) -> Result<()> {
        let better = trainer
            .state
            .best_metric
            .is_none_or(|b| metric > b || (on_tie == OnTie::TakeNew && metric == b));
        if better {
            trainer.state.best_metric = Some(metric);
            trainer.save(&self.checkpoints, "best")?;
        }
        Ok(())
    }
}

/// Trains as `cfg` says, in `run_dir`: restore, then per step load → step → log, per epoch
/// evaluate → checkpoint, and at the end the final evaluation. With
/// [`TrainOptions::replicas`], as one replica of data-parallel training ([`crate::distributed`]):
/// it loads its shard of every batch, and only replica 0 writes the run's files and evaluates.
pub fn train(cfg: &ExperimentConfig, run_dir: &Path, opts: &TrainOptions) -> Result<TrainSummary> {
    let role = Role::of(opts.replicas.clone());
    let local_batch = role.shard.local_batch(cfg.train.batch_size)?;
    let run = prepare_run(cfg, run_dir, opts.resume, &role)?;
    let train_set = cfg.dataset(&cfg.data.train_split)?;
    let val_set = cfg.dataset(&cfg.data.val_split)?;
    let schedule = Schedule::new(&cfg.train, train_set.ids().len(), opts.max_steps);
    let mut trainer = start_trainer(cfg, &run, &role, opts.init.as_ref())?;
    let mut items = train_loader(
        cfg,
        &train_set,
        paste_database(cfg)?,
        schedule,
        trainer.state.step,
        role.shard,
    );
    let mut log = role
        .writes()
        .then(|| TrainLog::open(&run.dir.join("log.jsonl")))
        .transpose()?;
    // Only the writing member reports: the others' progress is the same.
    let task = role.writes().then(|| Task::begin("train", schedule.total));
    if let Some(task) = &task {
        task.set_position(trainer.state.step);
    }
    let stop_requested = || opts.stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed));
    let mut clock = Instant::now();
    while trainer.state.step < schedule.end && !role.any(stop_requested()) {
        let sweeps: Vec<Vec<TrainItem>> = (&mut items).take(local_batch).collect::<std::result::Result<_, _>>()?;
        let lr = schedule.lr(cfg.train.learning_rate, trainer.state.step);
        trainer.set_featurizer(featurizer_at(cfg, &schedule, trainer.state.step));
        let losses = trainer.step(&sweeps, lr)?;
        let record = StepRecord {
            step: trainer.state.step,
            epoch: schedule.epoch(trainer.state.step),
            lr,
            losses,
            frames_per_s: (sweeps.len() * role.shard.ranks) as f64 / clock.elapsed().as_secs_f64(),
        };
        clock = Instant::now();
        let (Some(log), Some(task)) = (log.as_mut(), &task) else {
            continue;
        };
        report_step(&record, task, log, cfg.train.log_every, schedule.total)?;
        if schedule.epoch_ends(record.step) {
            end_epoch(cfg, &run, &mut trainer, log, &schedule, &val_set)?;
        }
    }
    drop(task);
    let Some(mut log) = log else {
        let end = if trainer.state.step < schedule.end {
            RunEnd::Stopped
        } else {
            RunEnd::Finished
        };
        return Ok(summary(&run, &trainer, end, None));
    };
    log.flush()?;
    finish(cfg, &run, trainer, &schedule, &val_set)
}

/// The run folder, ready on every member: replica 0 takes the folder's lock first (a second
/// trainer is refused before it touches anything), generates the data when absent and
/// prepares the folder; the others wait for it, then find the checkpoint to resume from.
fn prepare_run(cfg: &ExperimentConfig, run_dir: &Path, resume: Resume, role: &Role) -> Result<RunFolder> {
    let run = if role.writes() {
        let lock = RunLock::acquire(run_dir)?;
        ensure_data(cfg)?;
        Some(RunFolder::create_locked(run_dir, cfg, resume, lock)?)
    } else {
        None
    };
    role.barrier();
    match run {
        Some(run) => Ok(run),
        None => Ok(RunFolder::open(run_dir)),
    }
}

/// Whether the step after `step` updates the featurizer: not in the first
/// `train.freeze_featurizer_epochs` epochs.
fn featurizer_at(cfg: &ExperimentConfig, schedule: &Schedule, step: u64) -> Featurizer {
    match schedule.epoch(step) < cfg.train.freeze_featurizer_epochs as f64 {
        true => Featurizer::Frozen,
        false => Featurizer::Trained,
    }
}

/// The trainer of a run on the autodiff CPU device: from the newest checkpoint, else from
/// `init`'s weights (fine-tuning; the report goes to `init.json` and the log), else fresh; a
/// replica of the role's group, when it has one.
fn start_trainer(cfg: &ExperimentConfig, run: &RunFolder, role: &Role, init: Option<&InitSource>) -> Result<Trainer> {
    let device = cfg.train.device.device().map_err(|e| TrainError::InvalidArgument {
        name: "train.device".into(),
        message: e.to_string(),
    })?;
    let device = device.autodiff();
    if let (Some(dir), true) = (&run.resume_from, role.writes()) {
        note(format!("resuming from {}", dir.display()));
    }
    let trainer = match (&run.resume_from, init) {
        (None, Some(source)) => {
            let (trainer, report) = Trainer::fine_tune(cfg, source, &device)?;
            if role.writes() {
                report_init(&run.dir, &report)?;
            }
            trainer
        }
        _ => Trainer::start(cfg, run.resume_from.as_deref(), &device)?,
    };
    match &role.group {
        Some(group) => trainer.with_replicas(Arc::clone(group)),
        None => Ok(trainer),
    }
}

/// Writes a fine-tuning start's report as `init.json` in the run folder and names the tensors
/// that kept their fresh initialisation.
fn report_init(run_dir: &Path, report: &InitReport) -> Result<()> {
    let json = serde_json::to_string_pretty(report).expect("the report serialises");
    starnet_data::io::atomic_write(&run_dir.join("init.json"), json.as_bytes())?;
    note(format!(
        "initialised from {}: {} tensors loaded, {} re-initialised{}",
        report.source.display(),
        report.loaded.len(),
        report.reinitialised.len(),
        match report.reinitialised.is_empty() {
            true => String::new(),
            false => {
                let names: Vec<&str> = report.reinitialised.iter().map(|f| f.name.as_str()).collect();
                format!(" ({})", names.join(", "))
            }
        }
    ));
    Ok(())
}

/// A step's record to the log, and to the task's progress: its position and status every
/// step, a log line every `log_every` steps.
fn report_step(record: &StepRecord, task: &Task, log: &mut TrainLog, log_every: usize, total: u64) -> Result<()> {
    log.step(record)?;
    task.set_position(record.step);
    let l = &record.losses;
    task.status(&format!(
        "epoch {:.2} loss {:.4} (cls {:.4} loc {:.4}) lr {:.2e} {:.1} frames/s",
        record.epoch, l.loss, l.classification, l.location, record.lr, record.frames_per_s
    ));
    if record.step.is_multiple_of(log_every.max(1) as u64) {
        task.log(&progress_line(record, total));
    }
    Ok(())
}

/// The end of a run on the writing member: the checkpoint to resume from when it stopped
/// early, else the final evaluation (kept as `best` and `eval.json`).
fn finish(
    cfg: &ExperimentConfig,
    run: &RunFolder,
    mut trainer: Trainer,
    schedule: &Schedule,
    val_set: &KittiDataset,
) -> Result<TrainSummary> {
    if trainer.state.step < schedule.end {
        run.save_step(&trainer, cfg.train.keep_last, schedule.steps_per_epoch)?;
        note(format!(
            "stopped at step {}: checkpoint saved, continue with --resume",
            trainer.state.step
        ));
        return Ok(summary(run, &trainer, RunEnd::Stopped, None));
    }
    let report = validate(&trainer.eval_model(), cfg, val_set, Some(&run.dir.join("results")))?;
    run.keep_best(&mut trainer, report.headline(), OnTie::TakeNew)?;
    write_json(&run.dir.join("eval.json"), &report)?;
    Ok(summary(run, &trainer, RunEnd::Finished, Some(report)))
}

/// The close of an epoch: the validation when due (keeping `best`), then the step checkpoint.
pub fn end_epoch(
    cfg: &ExperimentConfig,
    run: &RunFolder,
    trainer: &mut Trainer,
    log: &mut TrainLog,
    schedule: &Schedule,
    val_set: &KittiDataset,
) -> Result<()> {
    log.flush()?;
    let step = trainer.state.step;
    let every = cfg.train.eval_every as u64;
    let due = every > 0 && (step / schedule.steps_per_epoch).is_multiple_of(every) && step < schedule.end;
    if due {
        let report = validate(&trainer.eval_model(), cfg, val_set, None)?;
        log.evaluation(step, report.headline())?;
        run.keep_best(trainer, report.headline(), OnTie::KeepOld)?;
    }
    run.save_step(trainer, cfg.train.keep_last, schedule.steps_per_epoch)
}

fn summary(run: &RunFolder, trainer: &Trainer, end: RunEnd, eval: Option<EvalReport>) -> TrainSummary {
    TrainSummary {
        run_dir: run.dir.clone(),
        steps: trainer.state.step,
        end,
        eval,
    }
}
