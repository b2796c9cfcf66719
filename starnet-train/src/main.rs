//! `starnet`: train, evaluate, export and inspect StarNet detectors. Parses arguments and
//! calls the `starnet_train` library; nothing else happens here.

use anyhow::Context;
use clap::{Parser, Subcommand};
use starnet_data::kitti::KittiDataset;
use starnet_data::sampling::{CenterTarget, Sampler};
use starnet_train::budget::{budget_grid, budget_table, replot_sweep, sweep};
use starnet_train::coverage::run_coverage;
use starnet_train::curves::plot_run;
use starnet_train::inspect::inspect_frame;
use starnet_train::prepare::run_prepare;
use starnet_train::render::{BevOptions, RenderOptions, render_frame};
use starnet_train::stream::{StreamGroundTruth, StreamModel, replot_stream, stream_runs, stream_tables, write_stream};
use starnet_train::synth::{SynthJob, run_stats, run_synth};
use starnet_train::temporal::{
    PrevCenters, Sequence, TemporalReport, evaluate_sequences, open_sequences, replot_temporal, seeded_centers,
    temporal_table, write_temporal,
};
use starnet_train::train::{Budget, TrainOptions, load_model, run_dir_for, train};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

// Training allocates and frees the same large buffers every step; glibc hands each back to the
// kernel and faults it in again, mimalloc keeps them (BENCHMARKS.md, issue #16).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[derive(Parser)]
#[command(
    name = "starnet",
    version,
    about = "StarNet point-cloud 3D object detection: data, training, evaluation, export"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print what a frame holds: point count, and per label its class, LiDAR-frame box
    /// [x y z dx dy dz heading], difficulty and the number of points inside the box.
    Inspect {
        /// KITTI root (the folder holding `training/`).
        #[arg(long)]
        data: PathBuf,
        /// Frame id, e.g. 000001.
        #[arg(long)]
        frame: String,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Draw a bird's-eye-view PNG of a frame: points shaded by height, ground-truth boxes
    /// (green) and, with --results, predicted boxes (orange), each with a heading mark.
    Render {
        /// KITTI root (the folder holding `training/`).
        #[arg(long)]
        data: PathBuf,
        /// Frame id, e.g. 000001.
        #[arg(long)]
        frame: String,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// A folder of KITTI result files (`{id}.txt`, 16 fields) to draw as predictions.
        #[arg(long)]
        results: Option<PathBuf>,
        /// How far the view reaches in metres: forward to `range` (and 0.55 x range to each
        /// side), or with --full to `range` in every direction.
        #[arg(long, default_value_t = 80.0)]
        range: f32,
        /// Show all 360 degrees around the sensor, not only the camera's side (with the
        /// simulator's 360-degree labels, `label_360/`, when the frame has them).
        #[arg(long)]
        full: bool,
        /// Pixels per metre.
        #[arg(long, default_value_t = 10.0)]
        px_per_m: f32,
        /// Apply the training augmentation first (pastes from ROOT/gt_database.bin if present).
        #[arg(long)]
        augment: bool,
        /// Sample and draw centers, as SAMPLER:COUNT, e.g. fps:256 or random:128.
        #[arg(long, value_parser = parse_centers)]
        centers: Option<(Sampler, usize)>,
        /// Seed for --augment and --centers.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// With --prev-centers on a sequence folder (ROOT/sequences/NNNN, with poses.txt): the
        /// model whose previous-frame detections seed this frame's --centers.
        #[arg(long, requires = "prev_centers")]
        checkpoint: Option<PathBuf>,
        /// How many of the --centers come from the previous frame's detections (32 or 50%);
        /// seeded centers are drawn in cyan.
        #[arg(long, requires = "checkpoint")]
        prev_centers: Option<PrevCenters>,
    },
    /// Measure how many objects (with at least 5 points) the sampled centers reach: the share
    /// with an anchor at BEV IoU > 0.5 around some center, per sampler and center count
    /// (the StarNet paper's figure 5). Prints a table and writes a PNG plot.
    Coverage {
        /// KITTI root.
        #[arg(long)]
        data: PathBuf,
        /// Split to measure (ImageSets/SPLIT.txt); every frame if absent.
        #[arg(long)]
        split: Option<String>,
        /// Center counts.
        #[arg(long, value_delimiter = ',', default_value = "16,32,64,128,256,512,1024")]
        samples: Vec<usize>,
        /// Samplers to compare: fps, random.
        #[arg(long, value_delimiter = ',', default_value = "fps,random")]
        sampler: Vec<Sampler>,
        /// Sample centers all around the sensor, not only in the camera's view.
        #[arg(long)]
        full: bool,
        /// Output PNG.
        #[arg(long, default_value = "coverage.png")]
        plot: PathBuf,
        /// Seed for the samplers.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Build the ground-truth database for paste augmentation from the train split:
    /// every labelled object with the points inside its box, written to ROOT/gt_database.bin.
    Prepare {
        /// KITTI root.
        #[arg(long)]
        data: PathBuf,
        /// Split to draw objects from.
        #[arg(long, default_value = "train")]
        split: String,
    },
    /// Train a detector from an experiment config (TOML). Generates the built-in simulator data
    /// if the config asks for it, then trains, checkpoints every epoch, and evaluates on the
    /// validation split at the end. Ctrl-C saves a checkpoint and stops; --resume continues.
    Train {
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
    },
    /// Evaluate a checkpoint: KITTI AP (3D, BEV, 2D, AOS; R40 and R11) on a split, KITTI result
    /// files, a JSON summary and per-frame latency, at one or more center/point budgets.
    Eval {
        /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
        #[arg(long)]
        checkpoint: PathBuf,
        /// The run's config (default: the config.toml of the run holding the checkpoint).
        #[arg(long)]
        config: Option<PathBuf>,
        /// KITTI root (default: the config's data root).
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
        /// with --sequences, temporal.md, temporal.json and temporal_ap.png.
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
    },
    /// Streaming evaluation: each sweep cut into n azimuth slices and detected slice by slice;
    /// Waymo-style AP per class with per-slice ("localized"), stateful and global NMS, vehicle AP
    /// by subtended angle, peak compute and measured per-slice latency with the worst-case
    /// latency model. Writes stream.md, stream.json and three plots with --out.
    StreamEval {
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
    },
    /// Export a checkpoint for other runtimes: model.safetensors (PyTorch names and layouts, the
    /// config in its metadata), model.json (the contract for host code: features, widths, anchors
    /// and their order, box coder, classes, NMS, sampling) and golden.safetensors (an input and
    /// the outputs it must give).
    Export {
        /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
        #[arg(long)]
        checkpoint: PathBuf,
        /// The run's config (default: the config.toml of the run holding the checkpoint).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Detect objects on raw sweeps (velodyne .bin files): sampling, gathering, the network,
    /// decoding and NMS at the config's evaluation budget. Writes {id}.json (LiDAR boxes) and,
    /// with a calibration (--calib, or ROOT/.../calib/{id}.txt beside velodyne/), {id}.txt in
    /// KITTI's result format.
    Detect {
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
    },
    /// Plot a run's training curves from its log.jsonl: loss.png (total and terms), lr.png and,
    /// when it evaluated during training, ap.png. With --budget, redraw an `eval` sweep's table
    /// and plots from its budget.json instead.
    Plot {
        /// The run folder (holding log.jsonl).
        #[arg(long, required_unless_present = "budget", conflicts_with = "budget")]
        run: Option<PathBuf>,
        /// An `eval --out` or `stream-eval --out` folder: redraws its tables and plots from the
        /// budget.json, temporal.json or stream.json it holds.
        #[arg(long)]
        budget: Option<PathBuf>,
        /// Output folder for the training curves (default: the run folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Print an experiment's resolved config (its bases, overrides and every default) as TOML;
    /// without --config, the defaults, which document every key.
    Config {
        /// Experiment file.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Override a config key (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
    /// Generate the built-in dataset: a ray-cast 64-beam LiDAR over simulated streets, written in
    /// the KITTI layout (velodyne, label_2, calib, ImageSets, plus a 360-degree label sidecar).
    /// With --stats, print a generated set's statistics beside KITTI's instead.
    Synth {
        /// Output root (it gets `training/` and `ImageSets/`, or `sequences/`).
        #[arg(long, required_unless_present = "stats", conflicts_with = "stats")]
        out: Option<PathBuf>,
        /// Independent scenes to generate.
        #[arg(long, default_value_t = 100, conflicts_with = "sequences")]
        frames: usize,
        /// Generate this many sequences instead (with --length frames each, 10 Hz, poses).
        #[arg(long, requires = "length")]
        sequences: Option<usize>,
        /// Frames per sequence.
        #[arg(long)]
        length: Option<usize>,
        /// Random seed: the same seed writes the same bytes.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Share of scenes in the validation split.
        #[arg(long, default_value_t = 0.5)]
        val_fraction: f32,
        /// Print the statistics of the generated set at ROOT.
        #[arg(long, value_name = "ROOT")]
        stats: Option<PathBuf>,
    },
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Inspect { data, frame, json } => {
            let ds = KittiDataset::open(&data, None)?;
            let report = inspect_frame(&ds.load(&frame)?);
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{report}");
            }
        }
        Command::Render {
            data,
            frame,
            out,
            results,
            range,
            full,
            px_per_m,
            augment,
            centers,
            seed,
            checkpoint,
            prev_centers,
        } => {
            anyhow::ensure!(range > 0.0 && px_per_m > 0.0, "--range and --px-per-m must be positive");
            anyhow::ensure!(
                range * px_per_m <= 8000.0,
                "--range x --px-per-m must be at most 8000 (image side 16000 px)"
            );
            let ds = KittiDataset::open(&data, None)?;
            let view = if full {
                BevOptions::around(range, px_per_m)
            } else {
                BevOptions::front(range, px_per_m)
            };
            let given_centers = match (checkpoint, prev_centers) {
                (Some(c), Some(prev)) => {
                    let cfg = starnet_train::config::load_config(&run_config(&c, None)?, &[])?;
                    let model = load_model(&c, cfg.model_config().init(&starnet_model::backend::default_device()))?;
                    let seq = Sequence::open(&data, &cfg)?;
                    let t = seq
                        .dataset
                        .ids()
                        .iter()
                        .position(|i| *i == frame)
                        .with_context(|| format!("no frame {frame} in {}", data.display()))?;
                    let budget = Budget {
                        num_centers: centers.map_or(cfg.eval.num_centers, |c| c.1),
                        num_points: cfg.eval.num_points,
                        target: CenterTarget::All,
                    };
                    Some(seeded_centers(&model, &cfg, &seq, t, budget, prev)?)
                }
                _ => None,
            };
            let extra = RenderOptions {
                results,
                all_around: full,
                augment,
                centers,
                seed,
                given_centers,
            };
            let canvas = render_frame(&ds, &frame, &extra, &view)?;
            canvas
                .save_png(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            println!("wrote {} ({} x {} px)", out.display(), canvas.width(), canvas.height());
        }
        Command::Train {
            config,
            resume,
            sets,
            run,
            max_steps,
        } => {
            let cfg = starnet_train::config::load_config(&config, &sets)?;
            let run_dir = run.unwrap_or_else(|| run_dir_for(&cfg, &config));
            let stop = Arc::new(AtomicBool::new(false));
            let flag = Arc::clone(&stop);
            ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)).context("installing the Ctrl-C handler")?;
            let summary = train(
                &cfg,
                &run_dir,
                &TrainOptions {
                    resume,
                    max_steps,
                    stop: Some(stop),
                },
            )?;
            println!("{} steps; run folder {}", summary.steps, summary.run_dir.display());
            if let Some(report) = summary.eval {
                print!("{report}");
            }
        }
        Command::Eval {
            checkpoint,
            config,
            data,
            split,
            centers,
            points,
            target,
            sets,
            out,
            sequences,
            prev_centers,
        } => {
            let mut cfg = starnet_train::config::load_config(&run_config(&checkpoint, config)?, &sets)?;
            if let Some(d) = data {
                cfg.data.root = d;
            }
            let device = starnet_model::backend::default_device();
            let model = load_model(&checkpoint, cfg.model_config().init(&device))?;
            if sequences {
                let seqs = open_sequences(&cfg.data.root, &cfg)?;
                let budgets = budget_grid(
                    &if centers.is_empty() {
                        vec![cfg.eval.num_centers]
                    } else {
                        centers
                    },
                    &[points.first().copied().unwrap_or(cfg.eval.num_points)],
                    target,
                );
                let mut reports = Vec::new();
                for b in &budgets {
                    let first = reports.len();
                    for &prev in &prev_centers {
                        // `32` and `50%` of 64 are the same run: evaluate it once.
                        let same = reports[first..]
                            .iter()
                            .find(|r: &&TemporalReport| r.prev_centers == prev.of(b.num_centers))
                            .cloned();
                        let r = match same {
                            Some(r) => TemporalReport { prev, ..r },
                            None => {
                                let r = evaluate_sequences(&model, &cfg, &seqs, *b, prev)?;
                                println!(
                                    "{} centers, {} from t - 1: headline AP {:.2}",
                                    r.num_centers,
                                    r.prev_centers,
                                    r.report.headline()
                                );
                                r
                            }
                        };
                        reports.push(r);
                    }
                }
                print!("{}", temporal_table(&reports));
                if let Some(out) = out {
                    write_temporal(&out, &reports)?;
                    println!("wrote {}", out.display());
                }
                return Ok(());
            }
            let ds = cfg.dataset(&split)?;
            let or = |v: Vec<usize>, d: usize| if v.is_empty() { vec![d] } else { v };
            let budgets = budget_grid(
                &or(centers, cfg.eval.num_centers),
                &or(points, cfg.eval.num_points),
                target,
            );
            anyhow::ensure!(
                budgets.iter().all(|b| b.num_centers > 0 && b.num_points > 0),
                "--centers and --points need positive counts"
            );
            let reports = sweep(&model, &cfg, &ds, &budgets, out.as_deref(), &mut |r| println!("{r}"))?;
            if reports.len() > 1 {
                print!("{}", budget_table(&reports));
            }
        }
        Command::StreamEval {
            checkpoint,
            data,
            split,
            slices,
            frames,
            centers,
            points,
            sets,
            out,
        } => {
            anyhow::ensure!(slices.iter().all(|&n| n > 0), "--slices needs positive counts");
            let device = starnet_model::backend::default_device();
            let mut loaded = Vec::new();
            for c in &checkpoint {
                let mut cfg = starnet_train::config::load_config(&run_config(c, None)?, &sets)?;
                if let Some(d) = &data {
                    cfg.data.root = d.clone();
                }
                let model = load_model(c, cfg.model_config().init(&device))?;
                loaded.push((run_label(c), model, cfg));
            }
            let models: Vec<StreamModel> = loaded
                .iter()
                .map(|(label, model, cfg)| StreamModel {
                    label: label.clone(),
                    model,
                    config: cfg,
                    budget: Budget {
                        num_centers: centers.unwrap_or(cfg.eval.num_centers),
                        num_points: points.unwrap_or(cfg.eval.num_points),
                        target: CenterTarget::All,
                    },
                })
                .collect();
            let cfg = &loaded[0].2;
            let ds = cfg.dataset(&split)?;
            let gt = StreamGroundTruth::read(cfg, &ds, frames)?;
            let runs = stream_runs(&models, &ds, &gt, &slices, &mut |label, r| println!("{label}: {r}"))?;
            print!("\n{}", stream_tables(&runs));
            if let Some(out) = out {
                write_stream(&out, &runs)?;
                println!("wrote {}", out.display());
            }
        }
        Command::Export {
            checkpoint,
            config,
            out,
        } => {
            let cfg = starnet_train::config::load_config(&run_config(&checkpoint, config)?, &[])?;
            let device = starnet_model::backend::default_device();
            let model = load_model(&checkpoint, cfg.model_config().init(&device))?;
            for path in starnet_train::export::export(&model, &cfg, &out)? {
                println!("wrote {}", path.display());
            }
        }
        Command::Detect {
            model,
            input,
            calib,
            config,
            out,
        } => {
            let (net, cfg) = if model.join("model.safetensors").is_file() {
                starnet_train::export::load_exported(&model)?
            } else {
                let cfg = starnet_train::config::load_config(&run_config(&model, config)?, &[])?;
                let device = starnet_model::backend::default_device();
                (load_model(&model, cfg.model_config().init(&device))?, cfg)
            };
            let files = starnet_train::detect::sweep_files(&input)?;
            let sweeps = starnet_train::detect::detect(&net, &cfg, &files, calib.as_deref(), &out)?;
            for s in &sweeps {
                println!(
                    "{}: {} points, {} detections{}",
                    s.id,
                    s.num_points,
                    s.detections.len(),
                    if s.calibrated {
                        ""
                    } else {
                        " (no calibration: JSON only)"
                    }
                );
            }
            println!("wrote {} sweeps to {}", sweeps.len(), out.display());
        }
        Command::Plot { run, budget, out } => {
            if let Some(dir) = budget {
                let mut found = false;
                for (file, replot) in [
                    (
                        "budget.json",
                        replot_sweep as fn(&std::path::Path) -> starnet_train::Result<()>,
                    ),
                    ("temporal.json", replot_temporal),
                    ("stream.json", replot_stream),
                ] {
                    if dir.join(file).is_file() {
                        replot(&dir)?;
                        println!("redrew {} from {file}", dir.display());
                        found = true;
                    }
                }
                anyhow::ensure!(
                    found,
                    "{} holds no budget.json, temporal.json or stream.json",
                    dir.display()
                );
            }
            if let Some(run) = run {
                for path in plot_run(&run, out.as_deref())? {
                    println!("wrote {}", path.display());
                }
            }
        }
        Command::Config { config, sets } => {
            let cfg = match config {
                Some(c) => starnet_train::config::load_config(&c, &sets)?,
                None => starnet_train::config::ExperimentConfig::default(),
            };
            print!("{}", starnet_train::config::to_toml(&cfg));
        }
        Command::Coverage {
            data,
            split,
            samples,
            sampler,
            full,
            plot,
            seed,
        } => {
            anyhow::ensure!(
                !samples.is_empty() && samples.iter().all(|n| *n > 0),
                "--samples needs positive counts"
            );
            run_coverage(&data, split.as_deref(), &samples, &sampler, full, &plot, seed)?;
        }
        Command::Prepare { data, split } => {
            run_prepare(&data, &split)?;
        }
        Command::Synth {
            out,
            frames,
            sequences,
            length,
            seed,
            val_fraction,
            stats,
        } => {
            if let Some(root) = stats {
                return Ok(run_stats(&root)?);
            }
            anyhow::ensure!((0.0..=1.0).contains(&val_fraction), "--val-fraction must be in [0, 1]");
            let job = match (sequences, length) {
                (Some(sequences), Some(length)) => SynthJob::Sequences { sequences, length },
                _ => SynthJob::Frames(frames),
            };
            let cfg = starnet_data::sim::SynthConfig {
                val_fraction,
                ..Default::default()
            };
            run_synth(&out.expect("clap requires --out without --stats"), job, seed, &cfg)?;
        }
    }
    Ok(())
}

/// The config given, or the `config.toml` of the run folder above `checkpoint`.
/// A checkpoint's run name: the folder above `checkpoints/`, else the checkpoint's own.
fn run_label(checkpoint: &std::path::Path) -> String {
    let name = |p: &std::path::Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    checkpoint
        .ancestors()
        .find(|a| a.file_name().is_some_and(|n| n == "checkpoints"))
        .and_then(|a| a.parent().and_then(name))
        .or_else(|| name(checkpoint))
        .unwrap_or_else(|| "model".into())
}

fn run_config(checkpoint: &std::path::Path, given: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    match given {
        Some(c) => Ok(c),
        None => checkpoint
            .ancestors()
            .map(|a| a.join("config.toml"))
            .find(|p| p.is_file())
            .context("no config.toml above the checkpoint; pass --config"),
    }
}

/// Parses `SAMPLER:COUNT`.
fn parse_centers(s: &str) -> Result<(Sampler, usize), String> {
    let (sampler, n) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}`: expected SAMPLER:COUNT, e.g. fps:256"))?;
    let n: usize = n.parse().map_err(|_| format!("`{n}` is not a count"))?;
    Ok((sampler.parse()?, n))
}
