//! `starnet train`: the training loop. Batches are prepared in loader threads (augmentation,
//! sampling, gathering, target assignment) while the model computes; Adam with the authors'
//! schedule, global-norm clipping and L2; a weight EMA for evaluation; a JSON-lines log of every
//! scalar; checkpoints at every epoch (and on Ctrl-C) that `--resume` continues bit for bit;
//! evaluation on the validation split (with the EMA weights), keeping the best checkpoint.
//!
//! A streaming config (`stream.train_slices`) cuts every sweep of a step into the same drawn
//! number of slices and runs them as one sequence (through the LSTM, when the model has one).
//!
//! Determinism: the data order is a function of (seed, epoch) and item `k`'s randomness of
//! (seed, k), so a resumed run sees exactly the items the uninterrupted one would have.

use super::checkpoint::{Restored, TrainState, latest_checkpoint, load_checkpoint, prune, save_checkpoint};
use super::clip::clip_global_norm;
use super::ema::WeightEma;
use super::evaluate::{Budget, EvalReport, evaluate};
use super::schedule::lr_multiplier;
use crate::config::{ExperimentConfig, to_toml};
use crate::prepare::database_path;
use crate::stream::{NmsMode, StreamGroundTruth, evaluate_stream};
use crate::synth::progress_bar;
use crate::{Result, TrainError};
use burn::module::Module;
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, GradientsParams};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use starnet_data::augment::GtDatabase;
use starnet_data::kitti::KittiDataset;
use starnet_data::loader::Loader;
use starnet_data::sampling::{Augmentation, prepare_frame, prepare_sweep};
use starnet_data::sim::{SynthConfig, sub_seed, synth_frames};
use starnet_model::batch::{frame_targets, make_batch};
use starnet_model::loss::starnet_loss;
use starnet_model::nn::StarNet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// How to run.
#[derive(Debug, Clone, Default)]
pub struct TrainOptions {
    /// Continue from the newest checkpoint of the run folder.
    pub resume: bool,
    /// Stop after this many steps in total (for tests and smoke runs).
    pub max_steps: Option<u64>,
    /// Set by a Ctrl-C handler: save and stop at the next step.
    pub stop: Option<Arc<AtomicBool>>,
}

/// How a run ended.
#[derive(Debug, Clone)]
pub struct TrainSummary {
    /// The run folder.
    pub run_dir: PathBuf,
    /// Steps done.
    pub steps: u64,
    /// Whether it stopped early on request.
    pub interrupted: bool,
    /// The final evaluation on the validation split.
    pub eval: Option<EvalReport>,
}

/// Generates the built-in data if the config asks for it and it is absent, and the ground-truth
/// database if the paste augmentation needs it.
pub fn ensure_data(cfg: &ExperimentConfig) -> Result<()> {
    let root = &cfg.data.root;
    if !root.join("training/velodyne").is_dir() && cfg.data.simulate_frames > 0 {
        println!(
            "generating {} simulated frames at {}",
            cfg.data.simulate_frames,
            root.display()
        );
        let bar = progress_bar(cfg.data.simulate_frames as u64, "synth");
        synth_frames(
            root,
            cfg.data.simulate_frames,
            cfg.data.simulate_seed,
            &SynthConfig::default(),
            &|| bar.inc(1),
        )?;
        bar.finish_and_clear();
    }
    if cfg.augment.db_paste.enabled && !GtDatabase::is_current(&database_path(root)) {
        crate::prepare::run_prepare(root, &cfg.data.train_split)?;
    }
    Ok(())
}

/// The slice count of step `step` of a streaming config (drawn from `stream.train_slices`, the
/// same for every sweep of the step), `None` when training on whole sweeps.
pub fn slices_at(cfg: &ExperimentConfig, step: u64) -> Option<usize> {
    let choices = &cfg.stream.train_slices;
    (!choices.is_empty()).then(|| choices[(sub_seed(cfg.seed, 33, step) % choices.len() as u64) as usize])
}

/// The validation of a run: [`evaluate`] at the config's budget, or for a streaming config
/// (sliced training or an LSTM) the streamed evaluation at `stream.eval_slices` with stateful
/// NMS (which writes no result files).
pub fn validate(
    model: &StarNet,
    cfg: &ExperimentConfig,
    val: &KittiDataset,
    results: Option<&Path>,
) -> Result<EvalReport> {
    if !cfg.stream.enabled() && cfg.model.lstm_hidden == 0 {
        return evaluate(model, cfg, val, Budget::of(cfg), results);
    }
    let gt = StreamGroundTruth::read(cfg, val, None)?;
    let report = evaluate_stream(model, cfg, val, &gt, Budget::of(cfg), cfg.stream.eval_slices)?;
    println!("{report}");
    Ok(report.eval_report(NmsMode::Stateful))
}

/// The run folder of a config: `{run_root}/{file stem}`.
pub fn run_dir_for(cfg: &ExperimentConfig, config_path: &Path) -> PathBuf {
    cfg.train.run_root.join(config_path.file_stem().unwrap_or_default())
}

/// Trains as `cfg` says, in `run_dir`.
pub fn train(cfg: &ExperimentConfig, run_dir: &Path, opts: &TrainOptions) -> Result<TrainSummary> {
    ensure_data(cfg)?;
    let ckpt_dir = run_dir.join("checkpoints");
    let existing = latest_checkpoint(&ckpt_dir);
    if existing.is_some() && !opts.resume {
        return Err(TrainError::InvalidArgument {
            name: "--resume".into(),
            message: format!(
                "{} already holds checkpoints: pass --resume to continue it, or choose another run",
                run_dir.display()
            ),
        });
    }
    std::fs::create_dir_all(&ckpt_dir).map_err(|e| starnet_data::DataError::io(&ckpt_dir, e))?;
    starnet_data::io::atomic_write(&run_dir.join("config.toml"), to_toml(cfg).as_bytes())?;

    let train_set = cfg.dataset(&cfg.data.train_split)?;
    let val_set = cfg.dataset(&cfg.data.val_split)?;
    let batch = cfg.train.batch_size;
    let steps_per_epoch = (train_set.ids().len() / batch).max(1) as u64;
    let total = cfg.train.epochs as u64 * steps_per_epoch;
    let decay_start = (cfg.train.decay_start_epoch * steps_per_epoch as f64) as u64;

    let device = starnet_model::backend::default_device().autodiff();
    device.seed(cfg.seed);
    let model_cfg = cfg.model_config();
    let adam = AdamConfig::new()
        .with_epsilon(cfg.train.adam_epsilon)
        .with_weight_decay(Some(WeightDecayConfig::new(cfg.train.l2)));
    let Restored {
        mut model,
        mut optim,
        mut ema,
        mut state,
    } = match &existing {
        Some(dir) => {
            println!("resuming from {}", dir.display());
            load_checkpoint(dir, || model_cfg.init(&device), &adam, cfg.train.ema_decay)?
        }
        None => {
            let model = model_cfg.init(&device);
            Restored {
                ema: (cfg.train.ema_decay > 0.0).then(|| WeightEma::new(cfg.train.ema_decay, &model)),
                model,
                optim: adam.init(),
                state: TrainState {
                    step: 0,
                    best_metric: None,
                },
            }
        }
    };
    // The model evaluated and kept as `best`: the averaged weights when there is an EMA.
    let eval_model = |model: &StarNet, ema: &Option<WeightEma>| match ema {
        Some(e) => e.apply(model),
        None => model.valid(),
    };

    let db = if cfg.augment.db_paste.enabled {
        Some(Arc::new(GtDatabase::read(&database_path(&cfg.data.root))?))
    } else {
        None
    };
    let start = state.step;
    let end = opts.max_steps.map_or(total, |m| m.min(total));
    let loader = {
        let (ds, cfg, db) = (train_set.clone(), cfg.clone(), db.clone());
        let n = ds.ids().len();
        let per_epoch = steps_per_epoch as usize * batch;
        Loader::new(
            ((end - start.min(end)) as usize) * batch,
            cfg.train.workers,
            cfg.train.prefetch,
            cfg.seed,
            move |i, _| {
                let k = start as usize * batch + i;
                let (epoch, pos) = (k / per_epoch, k % per_epoch);
                let mut order: Vec<usize> = (0..n).collect();
                order.shuffle(&mut ChaCha8Rng::seed_from_u64(sub_seed(cfg.seed, 31, epoch as u64)));
                let frame = ds.load(&ds.ids()[order[pos % n]])?;
                let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(cfg.seed, 32, k as u64));
                let aug = Augmentation {
                    config: &cfg.augment,
                    database: db.as_deref(),
                };
                // A sweep is a sequence of slices (one, unless streaming), each a frame of its own.
                let slices = match slices_at(&cfg, (k / batch) as u64) {
                    None => vec![prepare_frame(&frame, &cfg.pipeline, Some(aug), &[], &mut rng)],
                    Some(n) => prepare_sweep(&frame, &cfg.pipeline, &cfg.stream.slicing, n, Some(aug), &mut rng),
                };
                Ok(slices
                    .into_iter()
                    .map(|p| {
                        let t = frame_targets(&p, &cfg.model.anchors, &cfg.data.classes, &cfg.assign);
                        (p, t)
                    })
                    .collect::<Vec<_>>())
            },
        )
    };
    let mut items = loader;
    let log_path = run_dir.join("log.jsonl");
    let mut log = std::io::BufWriter::new(
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log_path)
            .map_err(|e| starnet_data::DataError::io(&log_path, e))?,
    );
    let loss_cfg = cfg.loss_config();
    let bar = progress_bar(total, "train");
    bar.set_position(start);
    let terminal = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let mut interrupted = false;
    let mut clock = Instant::now();
    let save = |model: &_, optim: &_, ema: &Option<WeightEma>, state: &TrainState| -> Result<()> {
        save_checkpoint(
            &ckpt_dir,
            &format!("step-{:08}", state.step),
            model,
            optim,
            ema.as_ref(),
            state,
        )?;
        prune(&ckpt_dir, cfg.train.keep_last.max(1));
        Ok(())
    };
    while state.step < end {
        if opts.stop.as_ref().is_some_and(|s| s.load(Ordering::Relaxed)) {
            interrupted = true;
            break;
        }
        let step_items: Vec<Vec<_>> = (&mut items).take(batch).collect::<std::result::Result<_, _>>()?;
        let slices = step_items[0].len();
        // Sweep-major: the slices of each sweep in order, as `forward_slices` expects.
        let frames: Vec<_> = step_items.iter().flatten().map(|(p, _)| p).collect();
        let targets: Vec<_> = step_items.iter().flatten().map(|(_, t)| t).collect();
        let b = make_batch(&frames, &targets, cfg.data.classes.len(), &device);
        let (out, _) = model.forward_slices(b.input, slices, None);
        let terms = starnet_loss(&out, &b.targets, &loss_cfg);
        let values: Vec<f32> = [
            &terms.total,
            &terms.classification,
            &terms.location,
            &terms.dimension,
            &terms.rotation,
            &terms.direction,
        ]
        .iter()
        .map(|t| (*t).clone().into_scalar::<f32>())
        .collect();
        if !values[0].is_finite() {
            return Err(TrainError::NonFiniteLoss {
                step: state.step,
                value: values[0],
            });
        }
        let mut grads = GradientsParams::from_grads(terms.total.backward(), &model);
        let grad_norm = clip_global_norm(&model, &mut grads, cfg.train.grad_clip_norm);
        let lr = cfg.train.learning_rate * lr_multiplier(state.step, decay_start, total);
        model = optim.step(lr, model, grads);
        state.step += 1;
        if let Some(e) = ema.as_mut() {
            e.update(&model, state.step);
        }
        let fps = batch as f64 / clock.elapsed().as_secs_f64();
        clock = Instant::now();
        let epoch = state.step as f64 / steps_per_epoch as f64;
        let line = serde_json::json!({"step": state.step, "epoch": epoch, "lr": lr, "loss": values[0], "classification": values[1], "location": values[2], "dimension": values[3], "rotation": values[4], "direction": values[5], "grad_norm": grad_norm, "frames_per_s": fps});
        writeln!(log, "{line}").map_err(|e| starnet_data::DataError::io(&log_path, e))?;
        bar.set_position(state.step);
        bar.set_message(format!(
            "epoch {epoch:.2} loss {:.4} (cls {:.4} loc {:.4}) lr {lr:.2e} {fps:.1} frames/s",
            values[0], values[1], values[2]
        ));
        if !terminal && state.step % cfg.train.log_every.max(1) as u64 == 0 {
            eprintln!(
                "step {}/{total} epoch {epoch:.2} loss {:.4} cls {:.4} loc {:.4} dim {:.4} rot {:.4} lr {lr:.2e} {fps:.1} frames/s",
                state.step, values[0], values[1], values[2], values[3], values[4]
            );
        }
        if state.step % steps_per_epoch == 0 || state.step == end {
            log.flush().map_err(|e| starnet_data::DataError::io(&log_path, e))?;
            let epoch_done = state.step / steps_per_epoch;
            let due =
                cfg.train.eval_every > 0 && epoch_done.is_multiple_of(cfg.train.eval_every as u64) && state.step < end;
            if due {
                let report = validate(&eval_model(&model, &ema), cfg, &val_set, None)?;
                writeln!(
                    log,
                    "{}",
                    serde_json::json!({"step": state.step, "eval_headline": report.headline()})
                )
                .map_err(|e| starnet_data::DataError::io(&log_path, e))?;
                if state.best_metric.is_none_or(|b| report.headline() > b) {
                    state.best_metric = Some(report.headline());
                    save_checkpoint(&ckpt_dir, "best", &model, &optim, ema.as_ref(), &state)?;
                }
            }
            save(&model, &optim, &ema, &state)?;
        }
    }
    bar.finish_and_clear();
    log.flush().map_err(|e| starnet_data::DataError::io(&log_path, e))?;
    if interrupted {
        save(&model, &optim, &ema, &state)?;
        println!(
            "stopped at step {}: checkpoint saved, continue with --resume",
            state.step
        );
        return Ok(TrainSummary {
            run_dir: run_dir.to_path_buf(),
            steps: state.step,
            interrupted,
            eval: None,
        });
    }
    let results = run_dir.join("results");
    let report = validate(&eval_model(&model, &ema), cfg, &val_set, Some(&results))?;
    if state.best_metric.is_none_or(|b| report.headline() >= b) {
        state.best_metric = Some(report.headline());
        save_checkpoint(&ckpt_dir, "best", &model, &optim, ema.as_ref(), &state)?;
    }
    starnet_data::io::atomic_write(
        &run_dir.join("eval.json"),
        serde_json::to_string_pretty(&report).expect("serialises").as_bytes(),
    )?;
    Ok(TrainSummary {
        run_dir: run_dir.to_path_buf(),
        steps: state.step,
        interrupted,
        eval: Some(report),
    })
}
