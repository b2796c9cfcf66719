//! Experiment configuration: one TOML file per experiment.
//!
//! A file may name another with `base = "other.toml"` (relative to itself); tables merge
//! recursively, the later file winning. `--set key.path=value` overrides come last (the value is
//! read as TOML, else as a string). The result is merged over the defaults of
//! [`ExperimentConfig::default`], which documents every key. A key the defaults do not have, or
//! a value of the wrong type, is an error naming the key and the file. The resolved config is
//! written beside every run.
//!
//! Keys a release renamed are read in their old spelling too ([`RENAMED`]), so the resolved
//! configs of older runs and the configs inside older exports still load.

use crate::{Result, TrainError};
use serde::{Deserialize, Serialize};
use starnet_data::augment::AugmentConfig;
use starnet_data::kitti::{KittiDataset, LabelSource, Layout, MissingIntensity, ObjectClass};
use starnet_data::sampling::{AnchorGrid, PipelineConfig, ReflectanceInput, SliceCenters, SliceConfig};
use starnet_data::settings::{Checked, InvalidSetting, at_least_one, non_negative, positive, width};
use starnet_model::assign::AssignConfig;
use starnet_model::backend::DeviceChoice;
use starnet_model::loss::LossConfig;
use starnet_model::nms::{ClassNms, Emission, NmsConfig, Precedence};
use starnet_model::nn::{FeaturizerConfig, RowLayout, StarNetConfig};
use std::path::{Path, PathBuf};
use toml::{Table, Value};

/// Where the data comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSection {
    /// KITTI root (holding `training/` and `ImageSets/`), relative to the working directory.
    pub root: PathBuf,
    /// If > 0, the built-in simulator generates this many frames at `root` when it is absent.
    pub simulate_frames: usize,
    /// Seed of the simulated set.
    pub simulate_seed: u64,
    /// Classes the detector is trained for (the others are background).
    pub classes: Vec<ObjectClass>,
    /// Training split (`ImageSets/{train_split}.txt`).
    pub train_split: String,
    /// Validation split.
    pub val_split: String,
    /// Labels to train and evaluate on: `label_2` (KITTI, camera view) or `label_360` (the
    /// simulator's every-object sidecar, evaluated Waymo-style).
    pub labels: LabelSource,
}

/// Model widths and anchors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSection {
    /// Width of fc0.
    pub d_fc0: usize,
    /// Per StarNet block, `[hidden, output]`.
    pub blocks: Vec<[usize; 2]>,
    /// Per-offset feature width D.
    pub d_offset: usize,
    /// Anchors around each center.
    pub anchors: AnchorGrid,
    /// Hidden width of the streaming LSTM over the slices of a sweep (the streaming paper:
    /// 128); 0: no LSTM.
    pub lstm_hidden: usize,
    /// A two-bin direction classifier beside the box head (SECOND / OpenPCDet): boxes point
    /// the right way, which AOS and APH need; the paper has none (false).
    pub direction_classifier: bool,
    /// Size residuals predicted once per center from the cell feature and shared by the G²
    /// offsets (`starnet_model::nn::StarNetConfig::shared_size`); the paper predicts them per
    /// offset (false).
    pub shared_size: bool,
    /// Run the featurizer (fc0, the StarNet blocks, the readout) as one fused operation on the
    /// flex backend, and the projector's Linear and the heads as another (the same maths, to
    /// float rounding, several times faster to train); false:
    /// the composed Burn operations, the reference and the path on other backends. Files that
    /// predate it mean true.
    #[serde(default = "fused_by_default")]
    pub fused_blocks: bool,
    /// How the composed layers (every backend but flex's fused kernels: a GPU) lay out a
    /// batch's rows: "auto" (grouped on a GPU, flat on the CPU), "flat" (one long product and
    /// sum over every point), "grouped" (G short ones, then a sum over G;
    /// `starnet_model::nn::row_layout`). The same maths, to float rounding.
    #[serde(default)]
    pub row_layout: RowLayout,
}

fn fused_by_default() -> bool {
    true
}

/// Streaming (the streaming-detection paper): sweeps cut into azimuth slices, detected slice by
/// slice as they arrive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StreamSection {
    /// Slice counts n to train on: each step draws one (every sweep of the step cut alike) and
    /// spreads `pipeline.num_centers` over its slices, so one model serves every n. Empty:
    /// train on whole sweeps, as StarNet does.
    pub train_slices: Vec<usize>,
    /// Slice count of the evaluations during and after training of a streaming config.
    pub eval_slices: usize,
    /// Stateful NMS memory k: a slice's boxes are also suppressed by the boxes kept in the
    /// previous k slices (the paper: 1), a remembered box stays remembered while it suppresses
    /// something, and the last slice also meets the first ([`starnet_model::nms::StatefulNms`]).
    pub nms_memory: usize,
    /// Which of two overlapping boxes from different slices stateful NMS keeps: `score` (the
    /// more confident, unless the earlier one was already emitted; as NMS over both slices'
    /// boxes) or `arrival` (the earlier one always).
    pub nms_precedence: Precedence,
    /// When stateful NMS emits a box: `immediate` (the paper: when its slice is done),
    /// `settled` (a box whose footprint, grown by half its length, reaches a slice not yet
    /// delivered waits one slice and is decided with that slice's candidates) or `deferred`
    /// (global NMS streamed: each box once no later box can overlap it; memory and precedence
    /// unused).
    pub nms_emission: Emission,
    /// Streaming evaluations count objects and detections within this bird's-eye-view range,
    /// metres (the center pool's reach; `inf`: everything labelled).
    pub eval_range: f32,
    /// LiDAR rotation rate, Hz (the worst-case latency model: a slice takes 1 / (n · Hz) to scan).
    pub scan_hz: f64,
    /// Where sweeps start, which way they turn, what a slice may read.
    pub slicing: SliceConfig,
}

/// Post-processing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NmsSection {
    /// Per class (in `data.classes` order): 3D IoU above which a box is suppressed.
    pub iou: Vec<f32>,
    /// Per class: the lowest score kept.
    pub score: Vec<f32>,
    /// Per class: box voting ([`starnet_model::nms::vote`]), each kept box replaced by the
    /// score-weighted mean of the candidates overlapping it by at least this 3D IoU. Empty (the
    /// paper): plain NMS.
    pub vote_iou: Vec<f32>,
    /// At most this many boxes per frame.
    pub max_boxes: usize,
}

/// Optimisation and bookkeeping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSection {
    /// Passes over the training split.
    pub epochs: usize,
    /// Frames per step.
    pub batch_size: usize,
    /// Adam learning rate before decay.
    pub learning_rate: f64,
    /// Epoch at which the exponential decay starts (the rate falls to 1 % at 95 % of training).
    pub decay_start_epoch: f64,
    /// Adam ε (the authors: 1e-6; Burn's default is 1e-5).
    pub adam_epsilon: f32,
    /// Gradients are scaled so their global L2 norm is at most this.
    pub grad_clip_norm: f32,
    /// L2 weight decay added to the gradient.
    pub l2: f32,
    /// Decay of the weight EMA used for evaluation and the `ema.bpk` of checkpoints (lingvo:
    /// 0.99); 0 turns it off.
    pub ema_decay: f64,
    /// Data-loader worker threads.
    pub workers: usize,
    /// Threads a training step computes on, in a pool of its own (0: `RAYON_NUM_THREADS`, else one
    /// per core). A small model beside a busy loader gains nothing from a second thread on 2 cores
    /// (it contends with the loader for its core: the quickstart sets 1); the paper's widths
    /// train 1.3–1.5× faster on two than on one (BENCHMARKS.md, issue #16).
    pub step_threads: usize,
    /// Where the model trains: `flex` (the CPU), `vulkan[:N]` or `wgpu[:N]` (a GPU; a build with
    /// that cargo feature). Evaluation runs on the CPU.
    pub device: DeviceChoice,
    /// Frames prepared ahead.
    pub prefetch: usize,
    /// Print a plain log line every this many steps (when stderr is not a terminal).
    pub log_every: usize,
    /// Evaluate on the validation split every this many epochs (0: only at the end).
    pub eval_every: usize,
    /// Checkpoints kept besides the best.
    pub keep_last: usize,
    /// Epochs at the start during which the point featurizer is held fixed and only the
    /// projection and heads learn (fine-tuning with `train --init`; 0: never).
    pub freeze_featurizer_epochs: usize,
    /// Where runs go: `{run_root}/{config file stem}`.
    pub run_root: PathBuf,
}

/// Evaluation budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalSection {
    /// Centers per frame at evaluation.
    pub num_centers: usize,
    /// Points per center at evaluation.
    pub num_points: usize,
    /// Frames per forward pass.
    pub batch_size: usize,
}

/// One experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentConfig {
    /// The one seed every RNG derives from.
    pub seed: u64,
    /// Data.
    pub data: DataSection,
    /// Centers and neighbourhoods for training.
    pub pipeline: PipelineConfig,
    /// Training augmentation.
    pub augment: AugmentConfig,
    /// Model.
    pub model: ModelSection,
    /// Target assignment.
    pub assign: AssignConfig,
    /// Loss (`starnet_model::loss::LossConfig`, the authors' Waymo defaults).
    pub loss: LossConfig,
    /// Post-processing.
    pub nms: NmsSection,
    /// Optimisation.
    pub train: TrainSection,
    /// Evaluation budget.
    pub eval: EvalSection,
    /// Streaming.
    pub stream: StreamSection,
}

impl Default for ExperimentConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            data: DataSection {
                root: "data/sim".into(),
                simulate_frames: 0,
                simulate_seed: 0,
                classes: vec![ObjectClass::Car],
                train_split: "train".into(),
                val_split: "val".into(),
                labels: LabelSource::Camera,
            },
            pipeline: PipelineConfig::default(),
            augment: AugmentConfig::default(),
            model: ModelSection {
                d_fc0: 64,
                blocks: vec![[256, 64]; 5],
                d_offset: 128,
                anchors: AnchorGrid::kitti_car(),
                lstm_hidden: 0,
                direction_classifier: false,
                shared_size: false,
                fused_blocks: true,
                row_layout: RowLayout::Auto,
            },
            assign: AssignConfig::default(),
            loss: LossConfig::new(),
            nms: NmsSection {
                iou: vec![0.083],
                score: vec![0.321],
                vote_iou: Vec::new(),
                max_boxes: 512,
            },
            train: TrainSection {
                epochs: 20,
                batch_size: 2,
                learning_rate: 1e-3,
                decay_start_epoch: 5.0,
                adam_epsilon: 1e-6,
                grad_clip_norm: 5.0,
                l2: 1e-4,
                ema_decay: 0.99,
                workers: 1,
                step_threads: 0,
                device: DeviceChoice::Flex,
                prefetch: 4,
                log_every: 50,
                eval_every: 0,
                keep_last: 2,
                freeze_featurizer_epochs: 0,
                run_root: "runs".into(),
            },
            eval: EvalSection {
                num_centers: 768,
                num_points: 64,
                batch_size: 2,
            },
            stream: StreamSection {
                train_slices: Vec::new(),
                eval_slices: 8,
                nms_memory: 1,
                nms_precedence: Precedence::Score,
                nms_emission: Emission::Immediate,
                eval_range: f32::INFINITY,
                scan_hz: 10.0,
                slicing: SliceConfig::default(),
            },
        }
    }
}

impl ExperimentConfig {
    /// The model's Burn config.
    pub fn model_config(&self) -> StarNetConfig {
        let f = FeaturizerConfig::new(self.model.d_fc0, self.model.blocks.clone())
            .with_fused(self.model.fused_blocks)
            .with_rows(self.model.row_layout);
        StarNetConfig::new(
            f,
            self.model.d_offset,
            self.model.anchors.clone(),
            self.data.classes.len(),
        )
        .with_lstm_hidden((self.model.lstm_hidden > 0).then_some(self.model.lstm_hidden))
        .with_direction_classifier(self.model.direction_classifier)
        .with_shared_size(self.model.shared_size)
    }

    /// A split of the config's dataset, read with the config's labels.
    /// A root in the custom layout (no camera) needs centers all around the sensor: its frames'
    /// calibration is a stand-in, whose frustum would silently hide most of the scene.
    pub fn dataset(&self, split: &str) -> Result<KittiDataset> {
        let missing = match self.pipeline.gather.reflectance {
            ReflectanceInput::Measured => MissingIntensity::Refuse,
            ReflectanceInput::Ignored => MissingIntensity::Zero,
        };
        let ds = KittiDataset::open(&self.data.root, Some(split))?;
        if ds.layout() == Layout::Custom && self.pipeline.pool.camera_frustum {
            return Err(TrainError::InvalidArgument {
                name: "pipeline.pool.camera_frustum".into(),
                message: format!(
                    "{} is in the custom layout, which has no camera: set it to false (and data.labels = \"label_360\")",
                    self.data.root.display()
                ),
            });
        }
        Ok(ds
            .with_labels(self.data.labels)
            .with_missing_intensity(missing)
            .with_wild_points(self.pipeline.wild_points))
    }

    /// NMS settings per class.
    pub fn nms_config(&self) -> NmsConfig {
        let per_class = self
            .nms
            .iou
            .iter()
            .zip(&self.nms.score)
            .enumerate()
            .map(|(c, (&iou, &score))| ClassNms {
                iou,
                score,
                vote_iou: self.nms.vote_iou.get(c).copied(),
            })
            .collect();
        NmsConfig {
            per_class,
            max_boxes: self.nms.max_boxes,
        }
    }

    /// Checks values no type can express, section by section (each section's `validate`),
    /// then the rules that join sections; the error names the key and `file`.
    pub fn validate(&self, file: &Path) -> Result<()> {
        self.validate_settings().map_err(|e| TrainError::Config {
            file: file.into(),
            key: e.key,
            message: e.message,
        })
    }

    fn validate_settings(&self) -> Checked {
        let k = self.data.classes.len();
        self.data.validate().map_err(|e| e.within("data"))?;
        self.pipeline.validate().map_err(|e| e.within("pipeline"))?;
        self.augment.validate().map_err(|e| e.within("augment"))?;
        self.model.validate().map_err(|e| e.within("model"))?;
        self.assign.validate().map_err(|e| e.within("assign"))?;
        self.loss.validate().map_err(|e| e.within("loss"))?;
        self.nms.validate(k).map_err(|e| e.within("nms"))?;
        self.train.validate().map_err(|e| e.within("train"))?;
        self.eval.validate().map_err(|e| e.within("eval"))?;
        self.stream.validate().map_err(|e| e.within("stream"))?;
        if !(self.loss.class_weights.is_empty() || self.loss.class_weights.len() == k) {
            return Err(InvalidSetting::new(
                "loss.class_weights",
                format!("needs one weight per class ({k}), or none for all 1"),
            ));
        }
        if self.stream.enabled() && self.pipeline.pool.camera_frustum {
            return Err(InvalidSetting::new(
                "pipeline.pool.camera_frustum",
                "slices of a sweep cover 360°: set it to false (and data.labels = \"label_360\")",
            ));
        }
        if self.stream.enabled() && self.pipeline.target != starnet_data::sampling::CenterTarget::All {
            return Err(InvalidSetting::new(
                "pipeline.target",
                "streaming spreads the centers over slices: use \"all\"",
            ));
        }
        Ok(())
    }
}

impl DataSection {
    /// At least one class.
    pub fn validate(&self) -> Checked {
        at_least_one("classes", self.classes.len())
    }
}

impl ModelSection {
    /// Widths in [1, `MAX_WIDTH`] (the LSTM's when it has one), at least one block, and valid
    /// anchors.
    pub fn validate(&self) -> Checked {
        width("d_fc0", self.d_fc0)?;
        at_least_one("blocks", self.blocks.len())?;
        for (i, b) in self.blocks.iter().enumerate() {
            width(&format!("blocks[{i}]"), b[0])?;
            width(&format!("blocks[{i}]"), b[1])?;
        }
        width("d_offset", self.d_offset)?;
        if self.lstm_hidden > 0 {
            width("lstm_hidden", self.lstm_hidden)?;
        }
        self.anchors.validate().map_err(|e| e.within("anchors"))
    }
}

impl NmsSection {
    /// One IoU and one score per class (of `classes`), voting for every class or none, each
    /// value in [0, 1], and at least one box kept.
    pub fn validate(&self, classes: usize) -> Checked {
        if self.iou.len() != classes || self.score.len() != classes {
            return Err(InvalidSetting::new(
                "iou",
                format!("nms.iou and nms.score need one value per class ({classes})"),
            ));
        }
        if !(self.vote_iou.is_empty() || self.vote_iou.len() == classes) {
            return Err(InvalidSetting::new(
                "vote_iou",
                format!("needs one value per class ({classes}), or none to turn voting off"),
            ));
        }
        for (key, values) in [("iou", &self.iou), ("score", &self.score), ("vote_iou", &self.vote_iou)] {
            if let Some(v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                return Err(InvalidSetting::new(
                    key,
                    format!("{v} is not an IoU or score in [0, 1]"),
                ));
            }
        }
        at_least_one("max_boxes", self.max_boxes)
    }
}

impl TrainSection {
    /// Counts ≥ 1, a positive rate and ε, non-negative decay start, clip norm and L2, an EMA
    /// decay in [0, 1).
    pub fn validate(&self) -> Checked {
        at_least_one("epochs", self.epochs)?;
        at_least_one("batch_size", self.batch_size)?;
        positive("learning_rate", self.learning_rate)?;
        non_negative("decay_start_epoch", self.decay_start_epoch)?;
        positive("adam_epsilon", self.adam_epsilon as f64)?;
        positive("grad_clip_norm", self.grad_clip_norm as f64)?;
        non_negative("l2", self.l2 as f64)?;
        if !(0.0..1.0).contains(&self.ema_decay) {
            return Err(InvalidSetting::new(
                "ema_decay",
                format!("{} is not in [0, 1) (0 turns the EMA off)", self.ema_decay),
            ));
        }
        at_least_one("workers", self.workers)?;
        at_least_one("prefetch", self.prefetch)
    }
}

impl EvalSection {
    /// Counts ≥ 1.
    pub fn validate(&self) -> Checked {
        at_least_one("num_centers", self.num_centers)?;
        at_least_one("num_points", self.num_points)?;
        at_least_one("batch_size", self.batch_size)
    }
}

impl StreamSection {
    /// Whether training cuts sweeps into slices.
    pub fn enabled(&self) -> bool {
        !self.train_slices.is_empty()
    }

    /// Slice counts ≥ 1, a positive range and scan rate, a valid slicing.
    pub fn validate(&self) -> Checked {
        if self.train_slices.contains(&0) {
            return Err(InvalidSetting::new("train_slices", "slice counts must be at least 1"));
        }
        at_least_one("eval_slices", self.eval_slices)?;
        positive("scan_hz", self.scan_hz)?;
        if self.eval_range.is_nan() || self.eval_range <= 0.0 {
            return Err(InvalidSetting::new(
                "eval_range",
                format!("{} is not a positive range (inf: everything)", self.eval_range),
            ));
        }
        if !self.train_slices.is_empty() && self.slicing.centers == SliceCenters::Spaced {
            // A training step runs its sweeps as one sequence of equally many slices; a spaced
            // sweep takes as many further steps as its seam needs.
            return Err(InvalidSetting::new(
                "slicing.centers",
                "\"spaced\" varies the steps per sweep and cannot train on slices (train_slices): \
                 train with \"continued\" or \"fresh\", stream-evaluate with \"spaced\"",
            ));
        }
        self.slicing.validate().map_err(|e| e.within("slicing"))
    }
}

/// Keys whose tables are maps with free keys (class names), not structs.
const OPEN_TABLES: [&str; 2] = ["augment.db_paste.max_per_class", "augment.db_paste.min_points"];

fn read_table(path: &Path) -> Result<Table> {
    let text = std::fs::read_to_string(path).map_err(|e| starnet_data::DataError::io(path, e))?;
    text.parse::<Table>().map_err(|e| TrainError::Config {
        file: path.into(),
        key: "(syntax)".into(),
        message: e.to_string().trim().to_string(),
    })
}

/// Reads `path` and its `base` chain, merged (at most 16 levels, so a cycle is an error).
fn read_with_bases(path: &Path, depth: usize) -> Result<Table> {
    if depth > 16 {
        return Err(TrainError::Config {
            file: path.into(),
            key: "base".into(),
            message: "more than 16 nested bases (a cycle?)".into(),
        });
    }
    let mut table = read_table(path)?;
    match table.remove("base") {
        None => Ok(table),
        Some(Value::String(base)) => {
            let base_path = path.parent().unwrap_or(Path::new(".")).join(base);
            let mut merged = read_with_bases(&base_path, depth + 1)?;
            merge(&mut merged, table);
            Ok(merged)
        }
        Some(other) => Err(TrainError::Config {
            file: path.into(),
            key: "base".into(),
            message: format!("expected a file name, found {}", other.type_str()),
        }),
    }
}

/// Recursively merges `top` into `bottom` (tables merge, everything else is replaced).
fn merge(bottom: &mut Table, top: Table) {
    for (k, v) in top {
        match (bottom.get_mut(&k), v) {
            (Some(Value::Table(b)), Value::Table(t)) => merge(b, t),
            (_, v) => {
                bottom.insert(k, v);
            }
        }
    }
}

/// Applies `key.path=value` overrides.
fn apply_sets(table: &mut Table, sets: &[String]) -> Result<()> {
    for s in sets {
        let err = |m: &str| TrainError::Config {
            file: "--set".into(),
            key: s.clone(),
            message: m.into(),
        };
        let (key, raw) = s
            .split_once('=')
            .ok_or_else(|| err("expected KEY=VALUE, e.g. train.epochs=5"))?;
        let value = format!("v = {raw}")
            .parse::<Table>()
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| Value::String(raw.to_string()));
        let parts: Vec<&str> = key.trim().split('.').collect();
        let mut at = &mut *table;
        for p in &parts[..parts.len() - 1] {
            let next = at.entry(p.to_string()).or_insert_with(|| Value::Table(Table::new()));
            at = next
                .as_table_mut()
                .ok_or_else(|| err("a parent of this key is not a table"))?;
        }
        at.insert(parts[parts.len() - 1].to_string(), value);
    }
    Ok(())
}

/// `defaults` with the tables a config may add that are absent by default (an `Option` section
/// is `None` unless the file names it), each holding its defaults, so that their keys are checked
/// and their numbers widened like any other.
fn with_optional_tables(defaults: &Table) -> Table {
    let mut schema = defaults.clone();
    let ground = Table::try_from(starnet_data::geometry::GroundConfig::default()).expect("the defaults serialise");
    if let Some(Value::Table(pipeline)) = schema.get_mut("pipeline") {
        pipeline.insert("ground".into(), Value::Table(ground));
    }
    schema
}

/// Every key of `user` must exist in `defaults` with a compatible type.
fn check_keys(user: &Table, defaults: &Table, prefix: &str, file: &Path) -> Result<()> {
    for (k, v) in user {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        let Some(d) = defaults.get(k) else {
            let known: Vec<&str> = defaults.keys().map(String::as_str).collect();
            return Err(TrainError::Config {
                file: file.into(),
                key,
                message: format!("unknown key (expected one of: {})", known.join(", ")),
            });
        };
        let compatible = matches!((d, v), (Value::Float(_), Value::Integer(_)))
            || std::mem::discriminant(d) == std::mem::discriminant(v);
        if !compatible {
            return Err(TrainError::Config {
                file: file.into(),
                key,
                message: format!("expected {}, found {}", d.type_str(), v.type_str()),
            });
        }
        if let (Value::Table(dt), Value::Table(ut)) = (d, v)
            && !OPEN_TABLES.contains(&key.as_str())
        {
            check_keys(ut, dt, &key, file)?;
        }
    }
    Ok(())
}

/// Integers given where the defaults have floats become floats, so serde accepts `lr = 1`.
fn widen_numbers(user: &mut Table, defaults: &Table) {
    for (k, v) in user.iter_mut() {
        match (defaults.get(k), &mut *v) {
            (Some(Value::Float(_)), Value::Integer(i)) => {
                let f = *i as f64;
                *v = Value::Float(f);
            }
            (Some(Value::Table(d)), Value::Table(u)) => widen_numbers(u, d),
            _ => {}
        }
    }
}

/// Loads an experiment: `path` (with its bases), then `sets`, over the defaults.
pub fn load_config(path: &Path, sets: &[String]) -> Result<ExperimentConfig> {
    resolve(read_with_bases(path, 0)?, sets, path)
}

/// Reads an experiment from TOML text (e.g. the config embedded in an export), then `sets`,
/// over the defaults; errors name `origin`.
pub fn parse_config(text: &str, origin: &Path, sets: &[String]) -> Result<ExperimentConfig> {
    let user = text.parse::<Table>().map_err(|e| TrainError::Config {
        file: origin.into(),
        key: "(syntax)".into(),
        message: e.to_string().trim().to_string(),
    })?;
    resolve(user, sets, origin)
}

/// A key an earlier release spelled otherwise: the table holding it, its old leaf name, and how
/// an old value reads in the new spelling.
pub struct RenamedKey {
    /// The dotted path of the table holding the key, e.g. `stream.slicing`.
    pub table: &'static str,
    /// The key's old name in that table.
    pub old: &'static str,
    /// The key's new name in that table.
    pub new: &'static str,
    /// The new value for an old one; `None` for an old value that was never valid.
    pub translate: fn(&Value) -> Option<Value>,
}

/// Every renamed key. `stream.slicing.gather_previous` (a bool, until issue #51) became
/// `stream.slicing.context`: `true` reads the previous slice (`"previous"`), `false` only the
/// slice's own points (`"own"`).
pub const RENAMED: &[RenamedKey] = &[RenamedKey {
    table: "stream.slicing",
    old: "gather_previous",
    new: "context",
    translate: |v| {
        v.as_bool()
            .map(|b| Value::String(if b { "previous" } else { "own" }.into()))
    },
}];

/// `user` with every old spelling of [`RENAMED`] replaced by the new one. Both spellings at once,
/// or an old value that was never valid, is an error naming the old key.
fn upgrade_renamed(user: &mut Table, file: &Path) -> Result<()> {
    for rename in RENAMED {
        let Some(table) = table_at_mut(user, rename.table) else {
            continue;
        };
        let Some(old) = table.remove(rename.old) else {
            continue;
        };
        let key = format!("{}.{}", rename.table, rename.old);
        let error = |message: String| TrainError::Config {
            file: file.into(),
            key: key.clone(),
            message,
        };
        if table.contains_key(rename.new) {
            return Err(error(format!("renamed to {}; give only the new key", rename.new)));
        }
        let new = (rename.translate)(&old)
            .ok_or_else(|| error(format!("renamed to {}; {old} has no meaning there", rename.new)))?;
        table.insert(rename.new.into(), new);
    }
    Ok(())
}

/// The table at the dotted `path` inside `root`, if every step of it is a table.
fn table_at_mut<'a>(root: &'a mut Table, path: &str) -> Option<&'a mut Table> {
    path.split('.')
        .try_fold(root, |at, part| at.get_mut(part)?.as_table_mut())
}

/// `user` with `sets` applied, key-checked and merged over the defaults, validated.
fn resolve(mut user: Table, sets: &[String], path: &Path) -> Result<ExperimentConfig> {
    apply_sets(&mut user, sets)?;
    upgrade_renamed(&mut user, path)?;
    let mut defaults = Table::try_from(ExperimentConfig::default()).expect("the defaults serialise");
    let schema = with_optional_tables(&defaults);
    check_keys(&user, &schema, "", path)?;
    widen_numbers(&mut user, &schema);
    let pristine = defaults.clone();
    merge(&mut defaults, user.clone());
    let cfg: ExperimentConfig = Value::Table(defaults)
        .try_into()
        .map_err(|e: toml::de::Error| TrainError::Config {
            file: path.into(),
            key: failing_key(&user, &pristine, "").unwrap_or_else(|| "(value)".into()),
            message: e.message().to_string(),
        })?;
    cfg.validate(path)?;
    Ok(cfg)
}

/// The first leaf key of `user` that alone, over `defaults`, fails to deserialise (a value of
/// the right TOML type that the setting does not accept, such as an unknown enum variant): serde's
/// error does not say where it is.
fn failing_key(user: &Table, defaults: &Table, prefix: &str) -> Option<String> {
    user.iter().find_map(|(k, v)| {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(t) if !OPEN_TABLES.contains(&key.as_str()) => failing_key(t, defaults, &key),
            _ => {
                let mut one = Table::new();
                let mut at = &mut one;
                let parts: Vec<&str> = key.split('.').collect();
                for p in &parts[..parts.len() - 1] {
                    at = at
                        .entry(p.to_string())
                        .or_insert_with(|| Value::Table(Table::new()))
                        .as_table_mut()
                        .expect("just inserted a table");
                }
                at.insert(parts[parts.len() - 1].to_string(), v.clone());
                let mut merged = defaults.clone();
                merge(&mut merged, one);
                Value::Table(merged)
                    .try_into::<ExperimentConfig>()
                    .is_err()
                    .then_some(key)
            }
        }
    })
}

/// The resolved config as TOML (written beside each run).
pub fn to_toml(cfg: &ExperimentConfig) -> String {
    toml::to_string(cfg).expect("configs serialise")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn reference_file_lists_the_defaults() {
        // `configs/reference.toml` is `starnet config` output under a comment header.
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/reference.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let body: String = text
            .lines()
            .skip_while(|l| l.starts_with('#') || l.is_empty())
            .map(|l| format!("{l}\n"))
            .collect();
        assert_eq!(
            body,
            to_toml(&ExperimentConfig::default()),
            "regenerate configs/reference.toml with `starnet config`"
        );
    }

    #[test]
    fn shipped_configs_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        names.sort();
        assert!(names.len() >= 5, "{names:?}");
        for path in names {
            let cfg = load_config(&path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(!cfg.model.anchors.priors.is_empty(), "{}", path.display());
        }
        // The presets say what they claim.
        let ped = load_config(&dir.join("sim-360-ped.toml"), &[]).unwrap();
        assert_eq!(ped.data.labels, LabelSource::AllAround);
        assert!(!ped.pipeline.pool.camera_frustum);
        let ped_cyc = load_config(&dir.join("sim-ped-cyc.toml"), &[]).unwrap();
        assert_eq!(ped_cyc.data.classes, [ObjectClass::Pedestrian, ObjectClass::Cyclist]);
        assert_eq!(ped_cyc.model.anchors.len(), 108, "lingvo's ped/cyc anchors per center");
        assert_eq!(ped_cyc.loss.class_weights, [3.5, 3.25]);
        let car = load_config(&dir.join("kitti-car.toml"), &[]).unwrap();
        assert_eq!(car.model_config().featurizer.cell_dim(), 1440);
    }

    #[test]
    fn defaults_round_trip_through_toml() {
        let d = ExperimentConfig::default();
        let back: ExperimentConfig = toml::from_str(&to_toml(&d)).unwrap();
        assert_eq!(back, d);
    }

    #[test]
    fn bases_merge_and_sets_win() {
        let dir = tempfile::tempdir().unwrap();
        write(
            dir.path(),
            "base.toml",
            "seed = 3\n[train]\nepochs = 7\nbatch_size = 4\n",
        );
        let p = write(
            dir.path(),
            "exp.toml",
            "base = \"base.toml\"\n[train]\nepochs = 9\nlearning_rate = 1\n",
        );
        let c = load_config(&p, &["train.batch_size=6".into(), "data.root=\"/x\"".into()]).unwrap();
        assert_eq!((c.seed, c.train.epochs, c.train.batch_size), (3, 9, 6));
        assert_eq!(c.train.learning_rate, 1.0, "integers widen to floats");
        assert_eq!(c.data.root, PathBuf::from("/x"));
        assert_eq!(
            c.model,
            ExperimentConfig::default().model,
            "untouched sections keep their defaults"
        );
    }

    #[test]
    fn a_renamed_key_reads_in_its_old_spelling() {
        use starnet_data::sampling::SliceContext;
        let dir = tempfile::tempdir().unwrap();
        for (old, want) in [(true, SliceContext::Previous), (false, SliceContext::Own)] {
            let p = write(
                dir.path(),
                "old.toml",
                &format!("[stream.slicing]\ngather_previous = {old}\n"),
            );
            assert_eq!(load_config(&p, &[]).unwrap().stream.slicing.context, want);
            let set = format!("stream.slicing.gather_previous={old}");
            let text = parse_config("", Path::new("model.safetensors"), &[set]).unwrap();
            assert_eq!(text.stream.slicing.context, want, "--set and embedded configs alike");
        }
        let both = "[stream.slicing]\ngather_previous = true\ncontext = \"own\"\n";
        let e = load_config(&write(dir.path(), "both.toml", both), &[])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("both.toml") && e.contains("stream.slicing.gather_previous"),
            "{e}"
        );
        assert!(e.contains("renamed to context"), "{e}");
        let odd = "[stream.slicing]\ngather_previous = 3\n";
        let e = load_config(&write(dir.path(), "odd.toml", odd), &[])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("stream.slicing.gather_previous") && e.contains("3 has no meaning"),
            "{e}"
        );
    }

    #[test]
    fn errors_name_the_key_and_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "a.toml", "[train]\nlearning_rat = 0.1\n");
        let e = load_config(&p, &[]).unwrap_err().to_string();
        assert!(
            e.contains("a.toml") && e.contains("train.learning_rat") && e.contains("unknown key"),
            "{e}"
        );
        let p = write(dir.path(), "b.toml", "[train]\nepochs = \"many\"\n");
        let e = load_config(&p, &[]).unwrap_err().to_string();
        assert!(
            e.contains("train.epochs") && e.contains("expected integer, found string"),
            "{e}"
        );
        let p = write(dir.path(), "c.toml", "[data]\nclasses = [\"Bus\"]\n");
        let e = load_config(&p, &[]).unwrap_err().to_string();
        assert!(e.contains("c.toml") && e.contains("Bus"), "{e}");
        let p = write(dir.path(), "d.toml", "[train\n");
        assert!(load_config(&p, &[]).unwrap_err().to_string().contains("d.toml"));
        let p = write(dir.path(), "e.toml", "[nms]\niou = [0.1, 0.2]\n");
        assert!(
            load_config(&p, &[])
                .unwrap_err()
                .to_string()
                .contains("one value per class")
        );
        for (body, want) in [
            ("[nms]\nvote_iou = [0.5, 0.5]\n", "one value per class"),
            ("[nms]\nvote_iou = [1.5]\n", "1.5 is not an IoU"),
        ] {
            let p = write(dir.path(), "v.toml", body);
            let e = load_config(&p, &[]).unwrap_err().to_string();
            assert!(e.contains("nms.vote_iou") && e.contains(want), "{e}");
        }
        let p = write(dir.path(), "v.toml", "[nms]\nvote_iou = [0.5]\n");
        let c = load_config(&p, &[]).unwrap();
        assert_eq!(c.nms_config().per_class[0].vote_iou, Some(0.5));
        assert_eq!(
            ExperimentConfig::default().nms_config().per_class[0].vote_iou,
            None,
            "the paper's plain NMS"
        );
        let p = write(dir.path(), "f.toml", "base = \"f.toml\"\n");
        assert!(load_config(&p, &[]).unwrap_err().to_string().contains("cycle"));
        let ok = write(dir.path(), "g.toml", "");
        let e = load_config(&ok, &["train.nope=1".into()]).unwrap_err().to_string();
        assert!(e.contains("train.nope"), "{e}");
    }

    #[test]
    fn issue_15_settings_are_checked_and_named() {
        let dir = tempfile::tempdir().unwrap();
        let ok = write(dir.path(), "a.toml", "");
        for (set, key) in [
            ("augment.object_margin=-0.1", "augment.object_margin"),
            ("augment.object_margin=0.5", "augment.object_margin"),
            ("pipeline.gather.radius=0.0", "pipeline.gather.radius"),
            ("pipeline.gather.metric=\"sphere\"", "pipeline.gather.metric"),
        ] {
            let e = load_config(&ok, &[set.into()]).unwrap_err().to_string();
            assert!(e.contains(key), "{set}: {e}");
        }
        let c = load_config(
            &ok,
            &[
                "pipeline.gather.metric=\"cylinder\"".into(),
                "model.direction_classifier=true".into(),
            ],
        )
        .unwrap();
        assert_eq!(c.pipeline.gather.metric, starnet_data::sampling::GatherMetric::Cylinder);
        assert!(c.model_config().direction_classifier);
    }

    #[test]
    fn the_ground_table_is_absent_by_default_and_checked_when_named() {
        use starnet_data::geometry::GroundConfig;
        let dir = tempfile::tempdir().unwrap();
        let none = write(dir.path(), "a.toml", "");
        assert_eq!(load_config(&none, &[]).unwrap().pipeline.ground, None);
        let empty = write(
            dir.path(),
            "b.toml",
            "[pipeline]\ncenter_z = \"ground\"\n[pipeline.ground]\n",
        );
        let c = load_config(&empty, &["pipeline.ground.window=3".into()]).unwrap();
        assert_eq!(c.pipeline.center_z, starnet_data::sampling::CenterZ::Ground);
        assert_eq!(
            c.pipeline.ground,
            Some(GroundConfig {
                window: 3,
                ..GroundConfig::default()
            })
        );
        // An integer where a float is due is widened, as everywhere else; a typo is an unknown key.
        let c = load_config(&empty, &["pipeline.ground.cell=1".into()]).unwrap();
        assert_eq!(c.pipeline.ground.map(|g| g.cell), Some(1.0));
        let e = load_config(&empty, &["pipeline.ground.cel=1.0".into()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("pipeline.ground.cel") && e.contains("unknown key"), "{e}");
    }

    #[test]
    fn every_range_rule_rejects_a_bad_value_naming_its_key() {
        let dir = tempfile::tempdir().unwrap();
        let ok = write(dir.path(), "a.toml", "");
        let cases = [
            ("data.classes=[]", "data.classes"),
            ("pipeline.num_centers=0", "pipeline.num_centers"),
            ("pipeline.pool.x_range=[10.0, 0.0]", "pipeline.pool.x_range"),
            ("pipeline.pool.y_range=[1.0, -1.0]", "pipeline.pool.y_range"),
            ("pipeline.pool.z_range=[0.0, -1.0]", "pipeline.pool.z_range"),
            ("pipeline.center_z=\"ground\"", "pipeline.center_z"),
            ("pipeline.ground.cell=0.0", "pipeline.ground.cell"),
            ("pipeline.ground.extent=-5.0", "pipeline.ground.extent"),
            ("pipeline.ground.cell=0.001", "pipeline.ground.extent"),
            ("pipeline.ground.reference_z=nan", "pipeline.ground.reference_z"),
            ("pipeline.gather.num_points=0", "pipeline.gather.num_points"),
            ("pipeline.gather.radius=-1.0", "pipeline.gather.radius"),
            ("augment.object_margin=-0.1", "augment.object_margin"),
            ("augment.box_rotation.max=-0.1", "augment.box_rotation.max"),
            ("augment.flip_probability=1.5", "augment.flip_probability"),
            ("augment.global_rotation.max=-1.0", "augment.global_rotation.max"),
            ("augment.scaling_range=[1.05, 0.95]", "augment.scaling_range"),
            ("augment.scaling_range=[0.0, 1.0]", "augment.scaling_range"),
            ("augment.z_shift_sigma=-1.0", "augment.z_shift_sigma"),
            ("augment.ring_dropout_width=-0.1", "augment.ring_dropout_width"),
            ("model.d_fc0=0", "model.d_fc0"),
            ("model.blocks=[]", "model.blocks"),
            ("model.blocks=[[0, 64]]", "model.blocks[0]"),
            ("model.d_offset=0", "model.d_offset"),
            ("model.d_fc0=5000", "model.d_fc0"),
            ("model.blocks=[[64, 100000]]", "model.blocks[0]"),
            ("model.lstm_hidden=9999", "model.lstm_hidden"),
            ("model.anchors.grid=0", "model.anchors.grid"),
            ("model.anchors.extent=-1.0", "model.anchors.extent"),
            ("model.anchors.rotations=[]", "model.anchors.rotations"),
            ("model.anchors.priors=[]", "model.anchors.priors"),
            (
                "model.anchors.priors=[{size = [3.9, 0.0, 1.5], z = -1.0}]",
                "model.anchors.priors[0].size",
            ),
            ("assign.fg_iou=0.0", "assign.fg_iou"),
            ("assign.fg_iou=1.2", "assign.fg_iou"),
            ("assign.bg_iou=-0.1", "assign.bg_iou"),
            ("loss.alpha=1.5", "loss.alpha"),
            ("loss.gamma=-1.0", "loss.gamma"),
            ("loss.huber_delta=0.0", "loss.huber_delta"),
            ("loss.location_weight=-1.0", "loss.location_weight"),
            ("loss.dimension_weight=-1.0", "loss.dimension_weight"),
            ("loss.rotation_weight=-1.0", "loss.rotation_weight"),
            ("loss.localization_weight=-1.0", "loss.localization_weight"),
            ("loss.classification_weight=-1.0", "loss.classification_weight"),
            ("loss.direction_weight=-1.0", "loss.direction_weight"),
            ("loss.class_weights=[-1.0]", "loss.class_weights[0]"),
            ("loss.class_weights=[1.0, 2.0]", "loss.class_weights"),
            ("nms.iou=[1.5]", "nms.iou"),
            ("nms.score=[-0.1]", "nms.score"),
            ("nms.vote_iou=[1.5]", "nms.vote_iou"),
            ("nms.max_boxes=0", "nms.max_boxes"),
            ("train.epochs=0", "train.epochs"),
            ("train.batch_size=0", "train.batch_size"),
            ("train.learning_rate=0.0", "train.learning_rate"),
            ("train.decay_start_epoch=-1.0", "train.decay_start_epoch"),
            ("train.adam_epsilon=0.0", "train.adam_epsilon"),
            ("train.grad_clip_norm=0.0", "train.grad_clip_norm"),
            ("train.l2=-1.0", "train.l2"),
            ("train.ema_decay=1.0", "train.ema_decay"),
            ("train.workers=0", "train.workers"),
            ("train.prefetch=0", "train.prefetch"),
            ("eval.num_centers=0", "eval.num_centers"),
            ("eval.num_points=0", "eval.num_points"),
            ("eval.batch_size=0", "eval.batch_size"),
            ("stream.train_slices=[4, 0]", "stream.train_slices"),
            ("stream.eval_slices=0", "stream.eval_slices"),
            ("stream.scan_hz=0.0", "stream.scan_hz"),
            ("stream.eval_range=0.0", "stream.eval_range"),
            (
                "stream.slicing.start_azimuth_deg=inf",
                "stream.slicing.start_azimuth_deg",
            ),
            ("stream.slicing.spacing=0.0", "stream.slicing.spacing"),
            ("stream.slicing.peak=0.5", "stream.slicing.peak"),
            ("stream.slicing.context=\"later\"", "stream.slicing.context"),
        ];
        for (set, key) in cases {
            match load_config(&ok, &[set.into()]) {
                Err(TrainError::Config { key: k, .. }) => assert_eq!(k, key, "{set}"),
                other => panic!("{set}: expected an error naming {key}, got {other:?}"),
            }
        }
        // Spaced centers vary the steps per sweep: they stream, they do not train on slices.
        let spaced = [
            "stream.slicing.centers=\"spaced\"".to_string(),
            "stream.train_slices=[1, 8]".into(),
        ];
        match load_config(&ok, &spaced) {
            Err(TrainError::Config { key, message, .. }) => {
                assert_eq!(key, "stream.slicing.centers");
                assert!(message.contains("train_slices"), "{message}");
            }
            other => panic!("expected spaced training to be refused, got {other:?}"),
        }
        assert!(
            load_config(&ok, &spaced[..1]).is_ok(),
            "spaced streaming evaluation is fine"
        );
    }

    #[test]
    fn class_keyed_tables_accept_class_names() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "a.toml",
            "[augment.db_paste.max_per_class]\nCar = 10\nPedestrian = 4\n",
        );
        let c = load_config(&p, &[]).unwrap();
        assert_eq!(c.augment.db_paste.max_per_class.get(&ObjectClass::Pedestrian), Some(&4));
    }
}
