//! Commands on models: `train`, `eval`, `stream-eval`, `export`, `detect`.

use crate::distributed::{Distributed, abort_job, join_world};
use anyhow::Context;
use clap::Args;
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_data::sampling::CenterTarget;
use starnet_eval::{ResultFormat, score_results, write_scores};
use starnet_train::budget::Budget;
use starnet_train::commands::eval::{budget_grid, budget_table, sweep};
use starnet_train::evaluate::EvalOptions;
use starnet_train::stream::{StreamGroundTruth, StreamModel, stream_runs, stream_tables, write_stream};
use starnet_train::temporal::{PrevCenters, open_sequences, temporal_sweep, temporal_table, write_temporal};
use starnet_train::train::{TrainOptions, run_dir_for, train};
use starnet_train::trained::{TrainedModel, run_label};
use std::path::{Path, PathBuf};
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
        let opts = TrainOptions {
            resume: self.resume,
            max_steps: self.max_steps,
            stop: Some(stop),
            replicas: world
                .clone()
                .map(|w| w as Arc<dyn starnet_train::distributed::Replicas>),
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

/// Evaluate a checkpoint: KITTI AP (3D, BEV, 2D, AOS; R40 and R11) and Waymo-style AP/APH on
/// a split, KITTI result files, a JSON summary and per-frame latency, at one or more
/// center/point budgets. Or score any detector's result folder (--results) the same way.
#[derive(Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["checkpoint", "results"])))]
pub struct Eval {
    /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// Score this folder of result files instead of a checkpoint (with --data): `{id}.txt` in
    /// KITTI's result format (camera frame) or `{id}.json` from `starnet detect` (LiDAR
    /// frame), one per frame of the split.
    #[arg(long, conflicts_with_all = ["checkpoint", "config", "centers", "points", "sets", "sequences"])]
    results: Option<PathBuf>,
    /// With --results: `kitti` or `detect` (default: whichever the split's first frame has).
    #[arg(long, requires = "results")]
    format: Option<ResultFormat>,
    /// With --results: the classes to score (default: Car, Pedestrian and Cyclist, those with
    /// a detection).
    #[arg(long, requires = "results", value_delimiter = ',', value_parser = parse_class)]
    classes: Vec<ObjectClass>,
    /// With --results: the labels to score against, `label_2` (camera view) or `label_360`
    /// (the simulator's all-around labels).
    #[arg(long, requires = "results", default_value = "label_2", value_parser = parse_labels)]
    labels: LabelSource,
    /// The run's config (default: the config.toml of the run holding the checkpoint).
    #[arg(long)]
    config: Option<PathBuf>,
    /// KITTI root (default: the config's data root; needed with --results).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Split to evaluate.
    #[arg(long, default_value = "val")]
    split: String,
    /// Centers per frame (a list sweeps budgets).
    #[arg(long, value_delimiter = ',')]
    centers: Vec<usize>,
    /// Points per center (a list sweeps budgets).
    #[arg(long, value_delimiter = ',')]
    points: Vec<usize>,
    /// Which sampled centers the model sees: `all`, or `nearest:N` (the N closest to the
    /// sensor; compare the AP per 10 m).
    #[arg(long, default_value = "all")]
    target: CenterTarget,
    /// Override a config key, e.g. --set nms.score=[0.1] (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Where to write, per budget, the result files and eval.json (in c{C}_p{P}/), and for a
    /// sweep budget.md, budget.json and the plots budget_gflop.png and budget_latency.png;
    /// with --sequences, temporal.md, temporal.json and temporal_ap.png; with --results,
    /// eval.json.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Evaluate the sequences under ROOT/sequences/ (from `starnet synth --sequences`) frame
    /// by frame, seeding each frame's centers with the previous frame's detections.
    #[arg(long)]
    sequences: bool,
    /// With --sequences: how many of the centers come from the previous frame's best
    /// detections, as counts (32) or shares (50%); a list evaluates each with each --centers.
    #[arg(long, value_delimiter = ',', default_value = "0")]
    prev_centers: Vec<PrevCenters>,
}

pub(crate) fn parse_class(s: &str) -> Result<ObjectClass, String> {
    ObjectClass::from_name(s)
        .ok_or_else(|| format!("unknown class `{s}` (KITTI's names: Car, Pedestrian, Cyclist, ...)"))
}

pub(crate) fn parse_labels(s: &str) -> Result<LabelSource, String> {
    serde_json::from_value(serde_json::Value::String(s.into()))
        .map_err(|_| format!("unknown labels `{s}` (expected `label_2` or `label_360`)"))
}

impl Eval {
    pub fn run(self) -> anyhow::Result<()> {
        match (&self.checkpoint, &self.results) {
            (Some(checkpoint), _) => self.checkpoint(checkpoint),
            (None, Some(results)) => self.results(results),
            (None, None) => unreachable!("clap requires --checkpoint or --results"),
        }
    }

    fn results(&self, results: &Path) -> anyhow::Result<()> {
        let root = self
            .data
            .as_deref()
            .context("--results needs --data ROOT (the KITTI root it scores against)")?;
        let ds = KittiDataset::open(root, Some(&self.split))?.with_labels(self.labels);
        let classes = (!self.classes.is_empty()).then_some(self.classes.as_slice());
        let scores = score_results(&ds, results, self.format, classes)?;
        println!("{} frames, results from {}", scores.frames, results.display());
        print!("{scores}");
        if let Some(out) = &self.out {
            write_scores(out, &scores)?;
            println!("wrote {}", out.join("eval.json").display());
        }
        Ok(())
    }

    fn checkpoint(&self, checkpoint: &Path) -> anyhow::Result<()> {
        let mut trained = TrainedModel::load(checkpoint, self.config.as_deref(), &self.sets)?;
        if let Some(d) = &self.data {
            trained.config.data.root = d.clone();
        }
        let cfg = &trained.config;
        let or = |v: &[usize], d: usize| if v.is_empty() { vec![d] } else { v.to_vec() };
        let centers = or(&self.centers, cfg.eval.num_centers);
        let points = or(&self.points, cfg.eval.num_points);
        anyhow::ensure!(
            centers.iter().chain(&points).all(|&n| n > 0),
            "--centers and --points need positive counts"
        );
        let detector = trained.detector();
        if self.sequences {
            let detector = detector.at_budget(Budget {
                num_centers: centers[0],
                num_points: points[0],
                target: self.target,
            });
            let seqs = open_sequences(&cfg.data.root, cfg)?;
            let reports = temporal_sweep(&detector, cfg.seed, &seqs, &centers, &self.prev_centers, &mut |r| {
                let (n, k, ap) = (r.num_centers, r.prev_centers, r.report.headline());
                println!("{n} centers, {k} from t - 1: headline AP {ap:.2}");
            })?;
            print!("{}", temporal_table(&reports));
            if let Some(out) = &self.out {
                write_temporal(out, &reports)?;
                println!("wrote {}", out.display());
            }
            return Ok(());
        }
        let ds = cfg.dataset(&self.split)?;
        let budgets = budget_grid(&centers, &points, self.target);
        let opts = EvalOptions::of(cfg);
        let reports = sweep(&detector, &ds, opts, &budgets, self.out.as_deref(), &mut |r| {
            println!("{r}")
        })?;
        if reports.len() > 1 {
            print!("{}", budget_table(&reports));
        }
        Ok(())
    }
}

/// Streaming evaluation: each sweep cut into n azimuth slices and detected slice by slice;
/// Waymo-style AP per class with per-slice ("localized"), stateful and global NMS, vehicle AP
/// by subtended angle, peak compute and measured per-slice latency with the worst-case
/// latency model. Writes stream.md, stream.json and three plots with --out.
#[derive(Args)]
pub struct StreamEval {
    /// Checkpoint folders (repeat or comma-separate: e.g. a localized and an LSTM model).
    #[arg(long, value_delimiter = ',', required = true)]
    checkpoint: Vec<PathBuf>,
    /// KITTI root (default: the first run's data root).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Split to evaluate.
    #[arg(long, default_value = "val")]
    split: String,
    /// Slice counts n (1, the whole-sweep reference, is always run).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    slices: Vec<usize>,
    /// Evaluate only the first N sweeps of the split.
    #[arg(long)]
    frames: Option<usize>,
    /// Centers per sweep (default: each config's eval.num_centers), spread over the slices.
    #[arg(long)]
    centers: Option<usize>,
    /// Points per center (default: each config's eval.num_points).
    #[arg(long)]
    points: Option<usize>,
    /// Override a config key of every run, e.g. --set stream.nms_memory=2 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Where to write stream.md, stream.json, stream_ap.png, stream_flops.png, stream_latency.png.
    #[arg(long)]
    out: Option<PathBuf>,
}

impl StreamEval {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(self.slices.iter().all(|&n| n > 0), "--slices needs positive counts");
        let mut models = Vec::new();
        let mut first = None;
        for c in &self.checkpoint {
            let trained = TrainedModel::load(c, None, &self.sets)?;
            let cfg = &trained.config;
            let budget = Budget {
                num_centers: self.centers.unwrap_or(cfg.eval.num_centers),
                num_points: self.points.unwrap_or(cfg.eval.num_points),
                target: CenterTarget::All,
            };
            models.push(StreamModel::new(run_label(c), trained.model.clone(), cfg, budget));
            first.get_or_insert(trained.config);
        }
        let mut cfg = first.context("--checkpoint names no run")?;
        if let Some(d) = &self.data {
            cfg.data.root = d.clone();
        }
        let ds = cfg.dataset(&self.split)?;
        let gt = StreamGroundTruth::read(cfg.stream.eval_range, &ds, self.frames)?;
        let runs = stream_runs(&models, &ds, &gt, &self.slices, &mut |label, r| {
            println!("{label}: {r}")
        })?;
        print!("\n{}", stream_tables(&runs));
        if let Some(out) = &self.out {
            write_stream(out, &runs)?;
            println!("wrote {}", out.display());
        }
        Ok(())
    }
}

/// Export a checkpoint for other runtimes: model.safetensors (PyTorch names and layouts, the
/// config in its metadata), model.json (the contract for host code: features, widths, anchors
/// and their order, box coder, classes, NMS, sampling) and golden.safetensors (an input and
/// the outputs it must give).
#[derive(Args)]
pub struct Export {
    /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
    #[arg(long)]
    checkpoint: PathBuf,
    /// The run's config (default: the config.toml of the run holding the checkpoint).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

impl Export {
    pub fn run(self) -> anyhow::Result<()> {
        let trained = TrainedModel::load(&self.checkpoint, self.config.as_deref(), &[])?;
        for path in starnet_train::export::export(&trained.model, &trained.config, &self.out)? {
            println!("wrote {}", path.display());
        }
        Ok(())
    }
}

/// Detect objects on raw sweeps (velodyne .bin files): sampling, gathering, the network,
/// decoding and NMS at the config's evaluation budget. Writes {id}.json (LiDAR boxes) and,
/// with a calibration (--calib, or ROOT/.../calib/{id}.txt beside velodyne/), {id}.txt in
/// KITTI's result format.
#[derive(Args)]
pub struct Detect {
    /// An export folder (holding model.safetensors) or a checkpoint (folder or model.bpk).
    #[arg(long)]
    model: PathBuf,
    /// A .bin file or a folder of them.
    #[arg(long)]
    input: PathBuf,
    /// A KITTI calib file for every sweep.
    #[arg(long)]
    calib: Option<PathBuf>,
    /// With a checkpoint: its config (default: the run's config.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

impl Detect {
    pub fn run(self) -> anyhow::Result<()> {
        let trained = TrainedModel::load(&self.model, self.config.as_deref(), &[])?;
        let files = starnet_train::commands::detect::sweep_files(&self.input)?;
        let sweeps = starnet_train::commands::detect::detect(
            &trained.detector(),
            trained.config.seed,
            &files,
            self.calib.as_deref(),
            &self.out,
        )?;
        for s in &sweeps {
            let note = if s.calibrated {
                ""
            } else {
                " (no calibration: JSON only)"
            };
            println!(
                "{}: {} points, {} detections{note}",
                s.id,
                s.num_points,
                s.detections.len()
            );
        }
        println!("wrote {} sweeps to {}", sweeps.len(), self.out.display());
        Ok(())
    }
}
