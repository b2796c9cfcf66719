//! `starnet export`: a checkpoint for other runtimes. Writes into the output folder
//!
//! - `model.safetensors`: every parameter and BatchNorm running statistic (PyTorch names and
//!   layouts, see [`starnet_model::export`]), with `__metadata__` holding `format`,
//!   `format_version` and the resolved experiment config (`config`, TOML);
//! - `model.json`: the contract for host code ([`ModelSpec`]): the input features and their
//!   order, the network's widths, the anchors and their order, the box coder, the classes, NMS
//!   and the sampling defaults;
//! - `model.onnx`: the dense network, `points [C, P, F]` and `mask [C, P]` in, `cls_logits
//!   [C, A, K]`, `box_residuals [C, A, 7]` and, with the direction classifier, `dir_logits
//!   [C, A, 2]` out, C and P dynamic, opset 13 ([`starnet_model::onnx`]);
//! - `golden.safetensors`: a seeded input (`points [C, P, F]`, `mask [C, P]`) and the outputs the
//!   model gives for it (`cls_logits [C, A, K]`, `box_residuals [C, A, 7]`, `dir_logits
//!   [C, A, 2]`), for checking a port;
//! - for the streaming LSTM variant, `model.onnx` is one slice step (state in, state out; see
//!   [`starnet_model::onnx`]), `model.json` says how to loop it ([`StreamingSpec`]), and
//!   `golden_stream.safetensors` holds a whole sweep of seeded slices: per slice `s`,
//!   `slice{s}.points`, `.mask`, `.center_valid` and the outputs with the state carried from the
//!   sweep's start, `slice{s}.cls_logits`, `.box_residuals`, `.dir_logits`, `.state_h`, `.state_c`
//!   (after the slice).

use crate::config::{ExperimentConfig, to_toml};
use crate::{Result, TrainError};
use burn::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use starnet_data::geometry::GroundConfig;
use starnet_data::io::atomic_write;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::{
    AnchorGrid, CenterPoolConfig, CenterViews, CenterZ, GatherMetric, NUM_FEATURES, Sampler, SliceConfig,
};
use starnet_model::export::{NamedTensor, named_tensors, write_safetensors};
use starnet_model::nms::{Emission, Precedence};
use starnet_model::nn::{ModelInput, SliceState, StarNet};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Version of the exported files' layout; bumped on any incompatible change.
pub const FORMAT_VERSION: u32 = 1;

/// The network's shape, as a port rebuilds it.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkSpec {
    /// Per-point input features F.
    pub d_input: usize,
    /// Width of fc0 (Linear + bias + ReLU, no BatchNorm).
    pub d_fc0: usize,
    /// Per StarNet block `[hidden, output]`; each block: concat(f, max over P of f) → BN →
    /// Linear (no bias) → ReLU → BN → Linear (no bias) → ReLU, padded rows kept at 0.
    pub blocks: Vec<[usize; 2]>,
    /// Cell feature width: concat of the masked means over P of fc0's and every block's output.
    pub cell_dim: usize,
    /// Per-offset feature width D: projector BN → Linear(cell → G²·D) → ReLU, reshaped per offset.
    pub d_offset: usize,
    /// Whether the size residuals (3..6) come from `size_head` (Linear(cell → A/G²·3), no bias, on
    /// the projector's BatchNorm output), the same at every offset, instead of from `box_head`.
    pub shared_size: bool,
    /// BatchNorm ε (biased running variance).
    pub batch_norm_epsilon: f64,
}

/// Everything host code needs around the dense network.
#[derive(Debug, Clone, Serialize)]
pub struct ModelSpec {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// Frames and box layout.
    pub conventions: &'static str,
    /// Per-point features, in order.
    pub input_features: [&'static str; NUM_FEATURES],
    /// The network.
    pub network: NetworkSpec,
    /// Anchors around each center.
    pub anchors: AnchorGrid,
    /// How anchors are ordered along A.
    pub anchor_order: &'static str,
    /// Anchors per center A.
    pub anchors_per_center: usize,
    /// How box residuals decode.
    pub box_coder: &'static str,
    /// How the direction logits turn a decoded heading (`None`: the model has none, and a
    /// heading may point either way).
    pub direction: Option<DirectionSpec>,
    /// Classes K, in the order of the logits.
    pub classes: Vec<ObjectClass>,
    /// Per class: 3D IoU above which a lower-scoring box is suppressed (greedy, per class).
    pub nms_iou: Vec<f32>,
    /// Per class: the lowest sigmoid score kept.
    pub nms_score: Vec<f32>,
    /// Per class: box voting after NMS, each kept box replaced by the score-weighted mean of the
    /// candidates (score above `nms_score`) overlapping it by at least this 3D IoU; centers and
    /// sizes averaged, the heading averaged modulo π about the kept one and turned by π when
    /// the weighted majority points the other way (`starnet_model::nms::vote`). Empty: none.
    pub nms_vote_iou: Vec<f32>,
    /// At most this many boxes per frame.
    pub max_boxes: usize,
    /// Center sampler.
    pub sampler: Sampler,
    /// Points that may become centers.
    pub center_pool: CenterPoolConfig,
    /// The z given to centers.
    pub center_z: CenterZ,
    /// The local ground, when the pool's z band and the centers' z are measured from it
    /// (`starnet_data::geometry::GroundModel`: each 2 m cell's third-lowest return, eroded over
    /// a 5 × 5 window; `null`: the sensor's z, flat ground).
    pub ground: Option<GroundConfig>,
    /// Centers per frame C (evaluation default).
    pub num_centers: usize,
    /// Points per center P (evaluation default).
    pub num_points: usize,
    /// Neighbourhood radius, metres.
    pub radius: f32,
    /// What the radius bounds: `ball` (3D distance) or `cylinder` (distance in x, y).
    pub gather_metric: GatherMetric,
    /// Which centers see their neighbourhood in the mirror (`as_seen`, `alternate`: ranks 1, 3,
    /// 5, … in sampling order, or `mirrored`: all); see [`ModelSpec::mirror_rule`].
    pub center_views: CenterViews,
    /// How a mirrored center runs.
    pub mirror_rule: &'static str,
    /// The streaming LSTM variant: how to run `model.onnx` slice by slice (`None`: every call is
    /// a whole sweep).
    pub streaming: Option<StreamingSpec>,
}

/// How the streaming LSTM variant runs over a sweep (the streaming-detection paper, §3.4).
#[derive(Debug, Clone, Serialize)]
pub struct StreamingSpec {
    /// LSTM hidden width H.
    pub lstm_hidden: usize,
    /// The state between slices.
    pub state: &'static str,
    /// When the state starts afresh.
    pub reset: &'static str,
    /// The order of the slices and what each holds.
    pub slice_order: &'static str,
    /// Where a sweep starts, which way it turns, what a slice's neighbourhoods may read.
    pub slicing: SliceConfig,
    /// Slices per sweep n of the run's evaluations (the model serves any n).
    pub eval_slices: usize,
    /// Centers per slice: `ceil(num_centers / n)`, at least 1 (times `slicing.peak`, rounded up,
    /// for spaced centers at n > 1).
    pub centers_per_slice: &'static str,
    /// Stateful NMS: a slice's boxes are also suppressed by those kept in the previous k slices
    /// (and by the boxes those suppressed something with, and the last slice by the first's),
    /// and vote with their candidates ([`starnet_model::nms::StatefulNms`]).
    pub nms_memory: usize,
    /// Which of two overlapping boxes from different slices stateful NMS keeps.
    pub nms_precedence: Precedence,
    /// When stateful NMS emits a box (immediately, or once the next slice cannot overlap it).
    pub nms_emission: Emission,
    /// The LSTM's tensors in `model.safetensors`.
    pub lstm_weights: &'static str,
}

impl StreamingSpec {
    fn of(cfg: &ExperimentConfig) -> Option<Self> {
        (cfg.model.lstm_hidden > 0).then_some(Self {
            lstm_hidden: cfg.model.lstm_hidden,
            state: "state_h and state_c, [1, H] f32 each (the LSTM's hidden and cell state): inputs of \
                    model.onnx, and state_h_out / state_c_out its outputs after the slice",
            reset: "zeros at the first slice of every sweep; each later slice of the sweep takes the \
                    previous slice's state_h_out / state_c_out",
            slice_order: "a sweep is cut into n equal azimuth sectors, starting at slicing.start_azimuth_deg \
                          and turning as slicing.clockwise says; each point (atan2(y, x)) falls in one, and \
                          slices run in that order. Where a slice's centers go and what its neighbourhoods read \
                          is slicing.context (own, previous, arrived) and how many it takes slicing.centers \
                          (scripts/onnx_detect.py follows each); center_valid is 0 for repeats that pad a \
                          slice with fewer candidates than its centers",
            slicing: cfg.stream.slicing,
            eval_slices: cfg.stream.eval_slices,
            centers_per_slice: "ceil(num_centers / n), at least 1; with slicing.centers = spaced and n > 1, \
                                that times slicing.peak, rounded up",
            nms_memory: cfg.stream.nms_memory,
            nms_precedence: cfg.stream.nms_precedence,
            nms_emission: cfg.stream.nms_emission,
            lstm_weights: "lstm.lstm.{input,forget,output,cell}_gate.{input,hidden}_transform.{weight [H, D | H], \
                           bias [H]} (gate = sigmoid, sigmoid, sigmoid, tanh of x·Wxᵀ + bx + h·Whᵀ + bh; c' = \
                           f·c + i·g, h' = o·tanh(c')); torch.nn.LSTM's weight_ih_l0 stacks the input \
                           transforms in the order input, forget, cell, output (likewise weight_hh_l0 and \
                           the biases, bias_ih + bias_hh = both biases). lstm.out.{weight [D, H], bias [D]} \
                           projects h' back to the cell width; the slice's cells get it added. The LSTM \
                           input is the mean of the valid centers' cells",
        })
    }
}

/// The direction classifier's decoding.
#[derive(Debug, Clone, Serialize)]
pub struct DirectionSpec {
    /// Where the two bins meet (radians; and π later).
    pub offset: f32,
    /// The rule.
    pub rule: &'static str,
}

impl ModelSpec {
    /// The spec of a config.
    pub fn of(cfg: &ExperimentConfig) -> Self {
        let model = cfg.model_config();
        Self {
            format_version: FORMAT_VERSION,
            conventions: "LiDAR frame: x forward, y left, z up, metres. Box [x, y, z, dx, dy, dz, heading]: \
                          center, extent along the heading (length), across it (width), height, and the \
                          counter-clockwise yaw from +x in [-pi, pi).",
            input_features: ["x - center_x", "y - center_y", "z - center_z", "reflectance"],
            network: NetworkSpec {
                d_input: NUM_FEATURES,
                d_fc0: cfg.model.d_fc0,
                blocks: cfg.model.blocks.clone(),
                cell_dim: model.featurizer.cell_dim(),
                d_offset: cfg.model.d_offset,
                shared_size: cfg.model.shared_size,
                batch_norm_epsilon: 1e-3,
            },
            anchors: cfg.model.anchors.clone(),
            anchor_order: "offset-major, then rotation, then prior. Offsets (ox, oy) = (-extent + i*step, \
                           -extent + j*step), step = 2*extent/(grid-1), i outer (x), j inner (y). Anchor \
                           = [cx + ox, cy + oy, cz + prior.z, prior.size..., rotation]",
            anchors_per_center: cfg.model.anchors.len(),
            box_coder: "d = sqrt(dx_a^2 + dy_a^2); x = x_a + r0*d; y = y_a + r1*d; z = z_a + r2*dz_a; \
                        dx = dx_a*exp(r3); dy = dy_a*exp(r4); dz = dz_a*exp(r5); heading = wrap(heading_a + r6) \
                        into [-pi, pi)",
            direction: cfg.model.direction_classifier.then_some(DirectionSpec {
                offset: starnet_model::coder::DIRECTION_OFFSET,
                rule: "bin = argmax(dir_logits[c, a]); heading = wrap(offset + ((heading - offset) mod pi) + pi*bin) \
                       into [-pi, pi), after the box coder and before NMS",
            }),
            classes: cfg.data.classes.clone(),
            nms_iou: cfg.nms.iou.clone(),
            nms_score: cfg.nms.score.clone(),
            nms_vote_iou: cfg.nms.vote_iou.clone(),
            max_boxes: cfg.nms.max_boxes,
            sampler: cfg.pipeline.sampler,
            center_pool: cfg.pipeline.pool.clone(),
            center_z: cfg.pipeline.center_z,
            ground: cfg.pipeline.ground,
            num_centers: cfg.eval.num_centers,
            num_points: cfg.eval.num_points,
            radius: cfg.pipeline.gather.radius,
            gather_metric: cfg.pipeline.gather.metric,
            center_views: cfg.eval.views,
            mirror_rule: "a mirrored center's input has its y offsets negated (points[c, :, 1] *= -1); its \
                          anchors lie around (cx, -cy, cz); each decoded box (after the direction rule) is \
                          mirrored back, y = -y and heading = wrap(-heading), before NMS",
            streaming: StreamingSpec::of(cfg),
        }
    }
}

/// A seeded neighbourhood input of `c` centers × `p` points, `[C, P, F]` and `[C, P]`: features
/// uniform in [−1, 1), the last quarter of each neighbourhood padded with zeros, as the gatherer
/// writes them. From its own RNG, so it does not depend on the device's.
fn seeded_input(rng: &mut ChaCha8Rng, c: usize, p: usize) -> (Vec<f32>, Vec<f32>) {
    let real = p - p / 4;
    let m: Vec<f32> = (0..c * p).map(|i| if i % p < real { 1.0 } else { 0.0 }).collect();
    let values: Vec<f32> = m
        .iter()
        .flat_map(|&on| [0; NUM_FEATURES].map(|_| if on > 0.0 { rng.random_range(-1.0f32..1.0) } else { 0.0 }))
        .collect();
    (values, m)
}

fn named(name: String, data: Vec<f32>, shape: Vec<usize>) -> NamedTensor {
    NamedTensor { name, shape, data }
}

/// One slice (or whole sweep) through the model from `state`: the outputs, named with
/// `prefix`, and the state after it.
fn golden_step(
    model: &StarNet,
    (values, m, valid): (&[f32], &[f32], &[f32]),
    state: Option<SliceState>,
    prefix: &str,
) -> (Vec<NamedTensor>, Option<SliceState>) {
    let device = starnet_model::backend::default_device();
    let (c, p) = (valid.len(), m.len() / valid.len());
    let (out, next) = model.forward_slices(
        ModelInput {
            points: Tensor::<1>::from_floats(values, &device).reshape([1, c, p, NUM_FEATURES]),
            mask: Tensor::<1>::from_floats(m, &device).reshape([1, c, p]),
            center_valid: Tensor::<1>::from_floats(valid, &device).reshape([1, c]),
        },
        1,
        state,
    );
    let data = |t: Tensor<4>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
    let [_, _, a, k] = out.cls_logits.dims();
    let mut tensors = vec![
        named(format!("{prefix}cls_logits"), data(out.cls_logits), vec![c, a, k]),
        named(format!("{prefix}box_residuals"), data(out.box_residuals), vec![c, a, 7]),
    ];
    if let Some(d) = out.dir_logits {
        tensors.push(named(format!("{prefix}dir_logits"), data(d), vec![c, a, 2]));
    }
    (tensors, next)
}

/// A seeded input of `c` centers × `p` points (features uniform in [−1, 1), the last quarter of
/// each neighbourhood padded with zeros, from its own RNG) and the model's outputs for it: a
/// whole sweep, every center valid (the streaming variant: one slice from a fresh state).
pub fn golden(model: &StarNet, c: usize, p: usize, seed: u64) -> Vec<NamedTensor> {
    let (values, m) = seeded_input(&mut ChaCha8Rng::seed_from_u64(seed), c, p);
    let valid = vec![1.0; c];
    let (outputs, _) = golden_step(model, (&values, &m, &valid), None, "");
    let mut tensors = vec![
        named("points".into(), values, vec![c, p, NUM_FEATURES]),
        named("mask".into(), m, vec![c, p]),
    ];
    tensors.extend(outputs);
    tensors
}

/// A whole sweep of `slices` seeded slices (inputs as [`golden`]'s) through the streaming
/// variant, the state carried from a fresh start: per slice its input (on odd slices the last
/// quarter of the centers marked as repeats), outputs and the state after it, named
/// `slice{s}.…`.
pub fn golden_stream(model: &StarNet, c: usize, p: usize, slices: usize, seed: u64) -> Vec<NamedTensor> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut state, mut tensors) = (None, Vec::new());
    for s in 0..slices {
        let (values, m) = seeded_input(&mut rng, c, p);
        let valid: Vec<f32> = (0..c)
            .map(|i| if s % 2 == 1 && i >= c - c / 4 { 0.0 } else { 1.0 })
            .collect();
        let prefix = format!("slice{s}.");
        let (outputs, next) = golden_step(model, (&values, &m, &valid), state, &prefix);
        let next = next.expect("the streaming variant carries a state");
        let flat = |t: Tensor<2>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
        let h = next.hidden.dims()[1];
        tensors.extend([
            named(format!("{prefix}points"), values, vec![c, p, NUM_FEATURES]),
            named(format!("{prefix}mask"), m, vec![c, p]),
            named(format!("{prefix}center_valid"), valid, vec![c]),
        ]);
        tensors.extend(outputs);
        tensors.push(named(format!("{prefix}state_h"), flat(next.hidden.clone()), vec![1, h]));
        tensors.push(named(format!("{prefix}state_c"), flat(next.cell.clone()), vec![1, h]));
        state = Some(next);
    }
    tensors
}

/// Slices in `golden_stream.safetensors`.
pub const GOLDEN_SLICES: usize = 6;

/// Writes `model.safetensors`, `model.json`, `model.onnx`, `golden.safetensors` and for the
/// streaming variant `golden_stream.safetensors` for `model` (in validation mode) into `out`;
/// returns the files written.
pub fn export(model: &StarNet, cfg: &ExperimentConfig, out: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).map_err(|e| starnet_data::DataError::io(out, e))?;
    let metadata = BTreeMap::from([
        ("format".to_string(), "starnet".to_string()),
        ("format_version".to_string(), FORMAT_VERSION.to_string()),
        ("config".to_string(), to_toml(cfg)),
    ]);
    let mut files = vec![
        (
            out.join("model.safetensors"),
            write_safetensors(&named_tensors(model), &metadata),
        ),
        (
            out.join("model.json"),
            serde_json::to_vec_pretty(&ModelSpec::of(cfg)).expect("the spec serialises"),
        ),
        (
            out.join("model.onnx"),
            starnet_model::onnx::onnx_model(model, &cfg.model_config()),
        ),
        (
            out.join("golden.safetensors"),
            write_safetensors(&golden(model, 16, 32, cfg.seed), &BTreeMap::new()),
        ),
    ];
    if model.has_lstm() {
        let sweep = golden_stream(model, 16, 32, GOLDEN_SLICES, cfg.seed);
        files.push((
            out.join("golden_stream.safetensors"),
            write_safetensors(&sweep, &BTreeMap::new()),
        ));
    }
    for (path, bytes) in &files {
        atomic_write(path, bytes)?;
    }
    Ok(files.into_iter().map(|f| f.0).collect())
}

/// Reads an exported folder's `model.safetensors`: the model, built from the config in its
/// metadata with `sets` overrides applied.
pub fn load_exported(dir: &Path, sets: &[String]) -> Result<(StarNet, ExperimentConfig)> {
    let path = dir.join("model.safetensors");
    let bytes = std::fs::read(&path).map_err(|e| starnet_data::DataError::io(&path, e))?;
    exported_from_bytes(&bytes, &path, sets)
}

/// The model and config of an export's `model.safetensors` bytes (the file `path`): a
/// malformed file, another format or version, a bad embedded config or a tensor of the wrong
/// name or shape is an error naming `path`.
pub fn exported_from_bytes(bytes: &[u8], path: &Path, sets: &[String]) -> Result<(StarNet, ExperimentConfig)> {
    let err = |message: String| TrainError::Checkpoint {
        path: path.to_path_buf(),
        message,
    };
    let (tensors, meta) = starnet_model::export::read_safetensors(bytes).map_err(|e| err(e.to_string()))?;
    if meta.get("format").map(String::as_str) != Some("starnet") {
        return Err(err("not a starnet export (no `format: starnet` in __metadata__)".into()));
    }
    let version = meta.get("format_version").cloned().unwrap_or_default();
    if version != FORMAT_VERSION.to_string() {
        return Err(err(format!(
            "format_version `{version}`; this build reads {FORMAT_VERSION}"
        )));
    }
    let cfg = crate::config::parse_config(meta.get("config").map_or("", String::as_str), path, sets)?;
    let model = cfg.model_config().init(&starnet_model::backend::default_device());
    let model = starnet_model::export::load_weights(model, &tensors).map_err(|e| err(e.to_string()))?;
    Ok((model, cfg))
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_model::export::read_safetensors;

    fn small() -> ExperimentConfig {
        crate::config::load_config(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/quickstart.toml"),
            &[],
        )
        .unwrap()
    }

    #[test]
    fn the_export_reloads_and_reproduces_its_golden_outputs() {
        let cfg = small();
        let dir = tempfile::tempdir().unwrap();
        let model = cfg.model_config().init(&starnet_model::backend::default_device());
        let files = export(&model, &cfg, dir.path()).unwrap();
        assert_eq!(files.len(), 4);
        let (_, meta) = read_safetensors(&std::fs::read(dir.path().join("model.safetensors")).unwrap()).unwrap();
        assert_eq!(meta["format_version"], FORMAT_VERSION.to_string());
        // The reloaded weights, built from the embedded config, give the golden outputs exactly.
        let (reloaded, embedded) = load_exported(dir.path(), &[]).unwrap();
        assert_eq!(embedded, cfg);
        let (golden_file, _) =
            read_safetensors(&std::fs::read(dir.path().join("golden.safetensors")).unwrap()).unwrap();
        let again = golden(&reloaded, 16, 32, cfg.seed);
        for t in &again {
            assert_eq!(&golden_file[&t.name], t, "{}", t.name);
        }
        // The contract agrees with the tensors: A anchors × K classes in the head's output.
        let spec: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("model.json")).unwrap()).unwrap();
        let a = spec["anchors_per_center"].as_u64().unwrap() as usize;
        assert_eq!(golden_file["cls_logits"].shape, [16, a, cfg.data.classes.len()]);
        assert_eq!(spec["network"]["cell_dim"], 128);
        assert_eq!(
            golden_file.contains_key("dir_logits"),
            cfg.model.direction_classifier,
            "the golden outputs hold the direction logits exactly when the model has them"
        );
        assert_eq!(spec["direction"].is_null(), !cfg.model.direction_classifier);
        assert_eq!(spec["center_views"], serde_json::to_value(cfg.eval.views).unwrap());
    }

    #[test]
    fn the_lstm_variant_exports_a_slice_step_and_a_golden_sweep() {
        let cfg = crate::config::load_config(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/stream-car-lstm.toml"),
            &["model.lstm_hidden=16".into()],
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let model = cfg.model_config().init(&starnet_model::backend::default_device());
        let files = export(&model, &cfg, dir.path()).unwrap();
        assert_eq!(files.len(), 5);
        // The reloaded weights (the LSTM's among them) replay the golden sweep exactly.
        let (reloaded, _) = load_exported(dir.path(), &[]).unwrap();
        assert!(reloaded.has_lstm());
        let (file, _) =
            read_safetensors(&std::fs::read(dir.path().join("golden_stream.safetensors")).unwrap()).unwrap();
        let again = golden_stream(&reloaded, 16, 32, GOLDEN_SLICES, cfg.seed);
        assert_eq!(file.len(), again.len());
        for t in &again {
            assert_eq!(&file[&t.name], t, "{}", t.name);
        }
        // The state moves from slice to slice, and the repeats of odd slices are marked.
        assert_ne!(file["slice0.state_h"].data, file["slice1.state_h"].data);
        assert_eq!(
            file["slice1.center_valid"].data.iter().filter(|&&v| v == 0.0).count(),
            4
        );
        let spec: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("model.json")).unwrap()).unwrap();
        assert_eq!(spec["streaming"]["lstm_hidden"], 16);
        assert_eq!(file["slice0.state_c"].shape, [1, 16]);
        // A whole-sweep model says so.
        let plain = ModelSpec::of(&small());
        assert!(plain.streaming.is_none());
    }
}
