//! The sections of an experiment file, one struct each, as serde reads them.

use serde::{Deserialize, Serialize};
use starnet_data::kitti::{LabelSource, ObjectClass};
use starnet_data::sampling::{AnchorGrid, CenterViews, SliceConfig};
use starnet_model::backend::DeviceChoice;
use starnet_model::nms::{Emission, Precedence};
use starnet_model::nn::RowLayout;
use std::path::PathBuf;

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

/// Evaluation budget, and how its centers look.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalSection {
    /// Centers per frame at evaluation.
    pub num_centers: usize,
    /// Points per center at evaluation.
    pub num_points: usize,
    /// Frames per forward pass.
    pub batch_size: usize,
    /// Which centers see their neighbourhood in the mirror at inference, their boxes mirrored
    /// back (`as_seen`, `alternate` or `mirrored`; [`CenterViews`]): flip test-time
    /// augmentation for the cost of one forward pass. Every command that runs the model (eval,
    /// detect, export's `model.json`) follows it. Missing in configs older than it: `as_seen`.
    #[serde(default)]
    pub views: CenterViews,
}
