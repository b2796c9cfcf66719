//! Commands on data: `inspect`, `render`, `coverage`, `prepare`, `synth`.

use anyhow::Context;
use clap::Args;
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_data::sampling::Sampler;
use starnet_train::budget::Budget;
use starnet_train::commands::compare_data::{DataSource, compare_data, write_comparison};
use starnet_train::commands::coverage::{paper_coverage, run_coverage};
use starnet_train::commands::inspect::inspect_frame;
use starnet_train::commands::synth::{SynthJob, run_stats, run_synth};
use starnet_train::render::{BevOptions, RenderOptions, render_frame};
use starnet_train::temporal::{PrevCenters, Sequence, seeded_centers};
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;

/// Print what a frame holds: point count, and per label its class, LiDAR-frame box
/// [x y z dx dy dz heading], difficulty and the number of points inside the box.
#[derive(Args)]
pub struct Inspect {
    /// KITTI root (the folder holding `training/`).
    #[arg(long)]
    data: PathBuf,
    /// Frame id, e.g. 000001.
    #[arg(long)]
    frame: String,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

impl Inspect {
    pub fn run(self) -> anyhow::Result<()> {
        let ds = KittiDataset::open(&self.data, None)?;
        let report = inspect_frame(&ds.load(&self.frame)?);
        if self.json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            print!("{report}");
        }
        Ok(())
    }
}

/// Draw a bird's-eye-view PNG of a frame: points shaded by height, ground-truth boxes
/// (green) and, with --results, predicted boxes (orange), each with a heading mark.
#[derive(Args)]
pub struct Render {
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
}

impl Render {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.range > 0.0 && self.px_per_m > 0.0,
            "--range and --px-per-m must be positive"
        );
        anyhow::ensure!(
            self.range * self.px_per_m <= 8000.0,
            "--range x --px-per-m must be at most 8000 (image side 16000 px)"
        );
        let ds = KittiDataset::open(&self.data, None)?;
        let view = if self.full {
            BevOptions::around(self.range, self.px_per_m)
        } else {
            BevOptions::front(self.range, self.px_per_m)
        };
        let extra = RenderOptions {
            given_centers: self.seeded_centers()?,
            results: self.results,
            all_around: self.full,
            augment: self.augment,
            centers: self.centers,
            seed: self.seed,
        };
        let canvas = render_frame(&ds, &self.frame, &extra, &view)?;
        canvas
            .save_png(&self.out)
            .with_context(|| format!("writing {}", self.out.display()))?;
        println!(
            "wrote {} ({} x {} px)",
            self.out.display(),
            canvas.width(),
            canvas.height()
        );
        Ok(())
    }

    /// With --checkpoint and --prev-centers: the frame's centers seeded by its predecessor.
    fn seeded_centers(&self) -> anyhow::Result<Option<starnet_data::sampling::Centers>> {
        let (Some(checkpoint), Some(prev)) = (&self.checkpoint, self.prev_centers) else {
            return Ok(None);
        };
        let trained = TrainedModel::load(checkpoint, None, &[])?;
        let seq = Sequence::open(&self.data, &trained.config)?;
        let t = seq
            .dataset
            .ids()
            .iter()
            .position(|i| *i == self.frame)
            .with_context(|| format!("no frame {} in {}", self.frame, self.data.display()))?;
        let detector = trained.detector();
        let detector = match self.centers {
            Some((_, n)) => detector.at_budget(Budget {
                num_centers: n,
                ..detector.budget()
            }),
            None => detector,
        };
        Ok(Some(seeded_centers(&detector, trained.config.seed, &seq, t, prev)?))
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

/// Measure how many objects (with at least 5 points) the sampled centers reach: the share
/// with an anchor at BEV IoU > 0.5 around some center, per sampler and center count
/// (the StarNet paper's figure 5). Prints a table and writes a PNG plot.
#[derive(Args)]
pub struct Coverage {
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
    /// Classes counted, each with its KITTI anchors (cars', pedestrians' or cyclists').
    #[arg(long, value_delimiter = ',', default_value = "Car,Pedestrian,Cyclist", value_parser = crate::models::parse_class)]
    classes: Vec<ObjectClass>,
    /// Output PNG.
    #[arg(long, default_value = "coverage.png")]
    plot: PathBuf,
    /// Seed for the samplers.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

impl Coverage {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.samples.is_empty() && self.samples.iter().all(|n| *n > 0),
            "--samples needs positive counts"
        );
        let cfg = paper_coverage(&self.samples, &self.sampler, &self.classes, self.full);
        run_coverage(&self.data, self.split.as_deref(), &cfg, &self.plot, self.seed)?;
        Ok(())
    }
}

/// Build the ground-truth database for paste augmentation from the train split:
/// every labelled object with the points inside its box, written to ROOT/gt_database.bin
/// (ROOT/gt_database_360.bin from the simulator's all-around labels).
#[derive(Args)]
pub struct Prepare {
    /// KITTI root.
    #[arg(long)]
    data: PathBuf,
    /// Split to draw objects from.
    #[arg(long, default_value = "train")]
    split: String,
    /// The labels to draw objects from: `label_2` (camera view) or `label_360` (the
    /// simulator's all-around labels, for configs with `data.labels = "label_360"`).
    #[arg(long, default_value = "label_2", value_parser = crate::models::parse_labels)]
    labels: LabelSource,
}

impl Prepare {
    pub fn run(self) -> anyhow::Result<()> {
        starnet_train::train::prepare_database(&self.data, &self.split, self.labels)?;
        Ok(())
    }
}

/// Generate the built-in dataset: a ray-cast 64-beam LiDAR over simulated streets, written in
/// the KITTI layout (velodyne, label_2, calib, ImageSets, plus a 360-degree label sidecar).
/// With --stats, print a generated set's statistics beside KITTI's instead.
#[derive(Args)]
pub struct Synth {
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
}

impl Synth {
    pub fn run(self) -> anyhow::Result<()> {
        let out = match (self.stats, self.out) {
            (Some(root), _) => return Ok(run_stats(&root)?),
            (None, Some(out)) => out,
            (None, None) => anyhow::bail!("--out or --stats is needed"),
        };
        anyhow::ensure!(
            (0.0..=1.0).contains(&self.val_fraction),
            "--val-fraction must be in [0, 1]"
        );
        let job = match (self.sequences, self.length) {
            (Some(sequences), Some(length)) => SynthJob::Sequences { sequences, length },
            _ => SynthJob::Frames(self.frames),
        };
        let cfg = starnet_data::sim::SynthConfig {
            val_fraction: self.val_fraction,
            ..Default::default()
        };
        run_synth(&out, job, self.seed, &cfg)?;
        Ok(())
    }
}

/// Compare two KITTI-layout folders (the simulator's and real scans, or your own sensor's):
/// reflectance and exact-zero share by range and by what was hit, labelled cars' returns,
/// height and viewpoint by distance, how volumetric the background is. Prints the table;
/// with --out also writes realism.md, realism.json and two plots.
#[derive(Args)]
pub struct CompareData {
    /// First root (A).
    a: PathBuf,
    /// Second root (B).
    b: PathBuf,
    /// Split of A to read (ImageSets/{split}.txt); every frame when absent.
    #[arg(long)]
    split_a: Option<String>,
    /// Split of B to read.
    #[arg(long)]
    split_b: Option<String>,
    /// Read at most this many frames of each (the first by id).
    #[arg(long)]
    frames: Option<usize>,
    /// Folder for realism.md, realism.json, reflectance_by_range.png, zero_by_range.png.
    #[arg(long)]
    out: Option<PathBuf>,
}

impl CompareData {
    pub fn run(self) -> anyhow::Result<()> {
        let a = DataSource {
            root: &self.a,
            split: self.split_a.as_deref(),
        };
        let b = DataSource {
            root: &self.b,
            split: self.split_b.as_deref(),
        };
        let cmp = compare_data(a, b, self.frames)?;
        print!("{cmp}");
        if let Some(out) = &self.out {
            write_comparison(out, &cmp)?;
            println!("\nwrote {}", out.display());
        }
        Ok(())
    }
}
