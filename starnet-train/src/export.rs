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
//!   [C, A, 2]`), for checking a port.

use crate::config::{ExperimentConfig, to_toml};
use crate::{Result, TrainError};
use burn::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use starnet_data::io::atomic_write;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::{AnchorGrid, CenterPoolConfig, CenterZ, GatherMetric, NUM_FEATURES, Sampler};
use starnet_model::export::{NamedTensor, named_tensors, write_safetensors};
use starnet_model::nn::{ModelInput, StarNet};
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
    /// Centers per frame C (evaluation default).
    pub num_centers: usize,
    /// Points per center P (evaluation default).
    pub num_points: usize,
    /// Neighbourhood radius, metres.
    pub radius: f32,
    /// What the radius bounds: `ball` (3D distance) or `cylinder` (distance in x, y).
    pub gather_metric: GatherMetric,
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
            num_centers: cfg.eval.num_centers,
            num_points: cfg.eval.num_points,
            radius: cfg.pipeline.gather.radius,
            gather_metric: cfg.pipeline.gather.metric,
        }
    }
}

/// A seeded input of `c` centers × `p` points (features uniform in [−1, 1), the last quarter of
/// each neighbourhood padded with zeros, as the gatherer writes them) and the model's outputs for
/// it. The input comes from its own seeded RNG, so it does not depend on the device's.
pub fn golden(model: &StarNet, c: usize, p: usize, seed: u64) -> Vec<NamedTensor> {
    let device = starnet_model::backend::default_device();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let real = p - p / 4;
    let m: Vec<f32> = (0..c * p).map(|i| if i % p < real { 1.0 } else { 0.0 }).collect();
    let values: Vec<f32> = m
        .iter()
        .flat_map(|&on| [0; NUM_FEATURES].map(|_| if on > 0.0 { rng.random_range(-1.0f32..1.0) } else { 0.0 }))
        .collect();
    let out = model.forward(ModelInput {
        points: Tensor::<1>::from_floats(values.as_slice(), &device).reshape([1, c, p, NUM_FEATURES]),
        mask: Tensor::<1>::from_floats(m.as_slice(), &device).reshape([1, c, p]),
        center_valid: Tensor::ones([1, c], &device),
    });
    let named = |name: &str, t: Vec<f32>, shape: Vec<usize>| NamedTensor {
        name: name.into(),
        shape,
        data: t,
    };
    let data = |t: Tensor<4>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
    let [_, _, a, k] = out.cls_logits.dims();
    let mut tensors = vec![
        named("points", values, vec![c, p, NUM_FEATURES]),
        named("mask", m, vec![c, p]),
        named("cls_logits", data(out.cls_logits), vec![c, a, k]),
        named("box_residuals", data(out.box_residuals), vec![c, a, 7]),
    ];
    if let Some(d) = out.dir_logits {
        tensors.push(named("dir_logits", data(d), vec![c, a, 2]));
    }
    tensors
}

/// Writes `model.safetensors`, `model.json`, `model.onnx` and `golden.safetensors` for `model`
/// (in validation mode) into `out`; returns the files written.
pub fn export(model: &StarNet, cfg: &ExperimentConfig, out: &Path) -> Result<Vec<PathBuf>> {
    if model.has_lstm() {
        // The ONNX graph and model.json describe the per-center network only; a half export
        // that silently drops the LSTM would detect differently.
        return Err(crate::TrainError::Unsupported(
            "exporting the streaming LSTM variant (model.lstm_hidden > 0) is not supported yet".into(),
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| starnet_data::DataError::io(out, e))?;
    let metadata = BTreeMap::from([
        ("format".to_string(), "starnet".to_string()),
        ("format_version".to_string(), FORMAT_VERSION.to_string()),
        ("config".to_string(), to_toml(cfg)),
    ]);
    let files = [
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
    }
}
