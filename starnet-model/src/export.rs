//! Weights in the [safetensors](https://huggingface.co/docs/safetensors) format with PyTorch's
//! names and layouts, so `safetensors.torch.load_file` gives a state dict a PyTorch port of the
//! model can load:
//!
//! - names are the module paths (`featurizer.blocks.0.fc1.weight`, `proj_bn.running_mean`, …);
//! - a Linear weight is `[out, in]` (Burn stores `[in, out]`), its bias `[out]`;
//! - a BatchNorm's γ / β are `weight` / `bias`, beside `running_mean` and `running_var`
//!   (biased variance, ε in the metadata of the caller's choosing);
//! - every tensor is little-endian f32; the file is written and read by Hugging Face's
//!   `safetensors` crate.
//!
//! [`read_safetensors`] and [`load_weights`] are the inverse: a written file loads back into
//! the Burn model bit for bit.

use crate::nn::StarNet;
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::prelude::*;
use safetensors::tensor::TensorView;
use safetensors::{Dtype, SafeTensors};
use std::collections::BTreeMap;

/// Errors reading a safetensors file or loading it into a model.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The bytes are not a safetensors file this module can read.
    #[error("not a valid safetensors file: {0}")]
    Format(String),
    /// The file lacks a tensor the model has, or holds it in another shape.
    #[error("tensor `{name}`: {message}")]
    Tensor {
        /// The tensor name.
        name: String,
        /// What is wrong.
        message: String,
    },
}

/// One named f32 tensor.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedTensor {
    /// PyTorch-style name.
    pub name: String,
    /// Shape.
    pub shape: Vec<usize>,
    /// Values, row-major.
    pub data: Vec<f32>,
}

/// Where the visitor stands: field names and container types from the root.
#[derive(Default)]
struct Path {
    fields: Vec<String>,
    containers: Vec<String>,
}

impl Path {
    fn enter(&mut self, name: &str, container: &str) {
        self.fields.push(name.to_string());
        self.containers.push(container.to_string());
    }

    fn exit(&mut self) {
        self.fields.pop();
        self.containers.pop();
    }

    /// The PyTorch name of the current field, and whether it is a Linear weight.
    fn torch_name(&self) -> (String, bool) {
        let parent = self.containers.last().map_or("", String::as_str);
        let leaf = self.fields.last().map_or("", String::as_str);
        let renamed = match (parent, leaf) {
            ("Struct:MaskedBatchNorm", "gamma") => "weight",
            ("Struct:MaskedBatchNorm", "beta") => "bias",
            _ => leaf,
        };
        let mut parts: Vec<&str> = self.fields[..self.fields.len().saturating_sub(1)]
            .iter()
            .map(String::as_str)
            .collect();
        parts.push(renamed);
        (parts.join("."), parent == "Struct:Linear" && leaf == "weight")
    }
}

struct Collect {
    path: Path,
    out: Vec<NamedTensor>,
}

impl ModuleVisitor for Collect {
    fn enter_module(&mut self, name: &str, container_type: &str) {
        self.path.enter(name, container_type);
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.exit();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let (name, linear_weight) = self.path.torch_name();
        let mut t = param.val();
        if linear_weight && D == 2 {
            t = t.swap_dims(0, 1);
        }
        let shape = t.dims().to_vec();
        let data = t.into_data().iter::<f32>().collect();
        self.out.push(NamedTensor { name, shape, data });
    }
}

/// Every parameter and BatchNorm running statistic of `model`, with PyTorch names and layouts.
pub fn named_tensors(model: &StarNet) -> Vec<NamedTensor> {
    let mut c = Collect {
        path: Path::default(),
        out: Vec::new(),
    };
    model.valid().visit(&mut c);
    c.out
}

/// Encodes tensors and string metadata as a safetensors file (the `safetensors` crate lays the
/// tensors out by dtype and name, 8-byte aligned).
pub fn write_safetensors(tensors: &[NamedTensor], metadata: &BTreeMap<String, String>) -> Vec<u8> {
    let bytes: Vec<Vec<u8>> = tensors
        .iter()
        .map(|t| t.data.iter().flat_map(|v| v.to_le_bytes()).collect())
        .collect();
    let views = tensors.iter().zip(&bytes).map(|(t, b)| {
        let view = TensorView::new(Dtype::F32, t.shape.clone(), b).expect("4 bytes per value of the shape");
        (t.name.as_str(), view)
    });
    let info = (!metadata.is_empty()).then(|| metadata.clone().into_iter().collect());
    let bytes = safetensors::serialize(views, info).expect("f32 tensors with distinct names serialise");
    canonical_header(bytes)
}

/// The file with its JSON header's keys in sorted order: the crate writes the metadata from a
/// `HashMap`, whose order changes from run to run, and the same model must give the same bytes.
/// The header stays padded with spaces to a multiple of 8 bytes, as the crate pads it.
fn canonical_header(bytes: Vec<u8>) -> Vec<u8> {
    let n = u64::from_le_bytes(bytes[..8].try_into().expect("8 length bytes")) as usize;
    let mut header: BTreeMap<String, serde_json::Value> =
        serde_json::from_slice(&bytes[8..8 + n]).expect("the crate writes a JSON object");
    if let Some(meta) = header.get_mut("__metadata__") {
        let sorted: BTreeMap<String, String> =
            serde_json::from_value(meta.take()).expect("the metadata is a map of strings");
        *meta = serde_json::to_value(sorted).expect("strings serialise");
    }
    let mut text = serde_json::to_vec(&header).expect("JSON values serialise");
    text.resize(text.len().next_multiple_of(8), b' ');
    let mut out = (text.len() as u64).to_le_bytes().to_vec();
    out.extend_from_slice(&text);
    out.extend_from_slice(&bytes[8 + n..]);
    out
}

/// Tensors by name.
pub type TensorMap = BTreeMap<String, NamedTensor>;

/// Decodes a safetensors file of f32 tensors: the tensors by name, and the metadata.
pub fn read_safetensors(bytes: &[u8]) -> Result<(TensorMap, BTreeMap<String, String>), ExportError> {
    let bad = |e: safetensors::SafeTensorError| ExportError::Format(e.to_string());
    let (_, header) = SafeTensors::read_metadata(bytes).map_err(bad)?;
    let file = SafeTensors::deserialize(bytes).map_err(bad)?;
    let metadata = header.metadata().clone().unwrap_or_default().into_iter().collect();
    let mut tensors = BTreeMap::new();
    for (name, view) in file.tensors() {
        if view.dtype() != Dtype::F32 {
            return Err(ExportError::Tensor {
                name,
                message: format!("dtype {:?}; only F32 tensors are supported", view.dtype()),
            });
        }
        let data = view
            .data()
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        let shape = view.shape().to_vec();
        tensors.insert(name.clone(), NamedTensor { name, shape, data });
    }
    Ok((tensors, metadata))
}

struct Load<'a> {
    path: Path,
    tensors: &'a TensorMap,
    error: Option<ExportError>,
}

impl ModuleMapper for Load<'_> {
    fn enter_module(&mut self, name: &str, container_type: &str) {
        self.path.enter(name, container_type);
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.exit();
    }

    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let (name, linear_weight) = self.path.torch_name();
        let tensors = self.tensors;
        let mut error = None;
        let param = param.map(|t| {
            let mut want = t.dims().to_vec();
            if linear_weight && D == 2 {
                want.swap(0, 1);
            }
            match tensors.get(&name) {
                Some(found) if found.shape == want => {
                    // Back to Burn's `[in, out]` by copying, not as a transposed view: a strided
                    // weight would take another matmul path and round differently.
                    let values = match linear_weight && D == 2 {
                        true => transpose(&found.data, want[0], want[1]),
                        false => found.data.clone(),
                    };
                    let loaded = Tensor::<1>::from_floats(values.as_slice(), &t.device()).reshape(t.shape());
                    // A trainable parameter stays one (fine-tuning from loaded weights).
                    if t.is_require_grad() {
                        loaded.require_grad()
                    } else {
                        loaded
                    }
                }
                Some(found) => {
                    error = Some(ExportError::Tensor {
                        name: name.clone(),
                        message: format!("shape {:?} in the file, {want:?} in the model", found.shape),
                    });
                    t
                }
                None => {
                    error = Some(ExportError::Tensor {
                        name: name.clone(),
                        message: "missing from the file".into(),
                    });
                    t
                }
            }
        });
        if self.error.is_none() {
            self.error = error;
        }
        param
    }
}

/// The `[cols, rows]` transpose of a row-major `[rows, cols]` matrix.
pub(crate) fn transpose(data: &[f32], rows: usize, cols: usize) -> Vec<f32> {
    let mut out = vec![0.0; data.len()];
    for r in 0..rows {
        for c in 0..cols {
            out[c * rows + r] = data[r * cols + c];
        }
    }
    out
}

/// Loads named tensors (as [`named_tensors`] produces them) into `model`.
pub fn load_weights(model: StarNet, tensors: &TensorMap) -> Result<StarNet, ExportError> {
    let mut load = Load {
        path: Path::default(),
        tensors,
        error: None,
    };
    let model = model.map(&mut load);
    match load.error {
        Some(e) => Err(e),
        None => Ok(model),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use crate::nn::{ModelInput, StarNetConfig};
    use crate::testing;

    fn input(dev: &Device) -> ModelInput {
        ModelInput {
            points: testing::normal([1, 6, 8, 4], 1.0, &mut testing::rng(0), dev),
            mask: Tensor::ones([1, 6, 8], dev),
            center_valid: Tensor::ones([1, 6], dev),
        }
    }

    #[test]
    fn names_and_layouts_are_pytorch_style() {
        let dev = default_device();
        let cfg = StarNetConfig::small_car();
        let tensors = named_tensors(&cfg.init(&dev));
        let find = |n: &str| tensors.iter().find(|t| t.name == n).unwrap_or_else(|| panic!("{n}"));
        // fc0: Linear(4 → 32): weight [out, in].
        assert_eq!(find("featurizer.fc0.weight").shape, [32, 4]);
        assert_eq!(find("featurizer.fc0.bias").shape, [32]);
        // Block 0: BN over 2·32 inputs, then Linear(64 → 64) without bias.
        assert_eq!(find("featurizer.blocks.0.bn1.weight").shape, [64]);
        assert_eq!(find("featurizer.blocks.0.bn1.running_var").shape, [64]);
        assert_eq!(find("featurizer.blocks.0.fc1.weight").shape, [64, 64]);
        assert!(!tensors.iter().any(|t| t.name == "featurizer.blocks.0.fc1.bias"));
        // Heads: 100 anchors per center = 25 offsets × 4 rotations; per offset 4 anchors × 7.
        assert_eq!(find("box_head.weight").shape, [28, 32]);
        assert_eq!(find("cls_head.bias").shape, [4]);
        assert!(
            !tensors
                .iter()
                .any(|t| t.name.contains("gamma") || t.name.contains("beta"))
        );
    }

    #[test]
    fn the_same_tensors_and_metadata_give_the_same_bytes() {
        let tensors = named_tensors(&StarNetConfig::small_car().init(&default_device()));
        let meta: BTreeMap<String, String> = (0..12).map(|i| (format!("key{i}"), format!("value {i}"))).collect();
        let first = write_safetensors(&tensors, &meta);
        // The crate's metadata map is a HashMap, ordered afresh for every instance.
        for _ in 0..8 {
            assert!(
                write_safetensors(&tensors, &meta) == first,
                "the bytes changed between writes"
            );
        }
        assert_eq!(read_safetensors(&first).unwrap().1, meta);
    }

    #[test]
    fn a_written_file_loads_back_bit_for_bit() {
        let dev = default_device();
        let cfg = StarNetConfig::small_car();
        let a = cfg.init(&dev);
        // Give the box head (zero at init) and a running statistic values to carry.
        let mut tensors = named_tensors(&a);
        for t in tensors.iter_mut() {
            if t.name == "box_head.weight" || t.name == "proj_bn.running_mean" {
                t.data.iter_mut().enumerate().for_each(|(i, v)| *v = i as f32 * 1e-3);
            }
        }
        let meta = BTreeMap::from([("format_version".to_string(), "1".to_string())]);
        let bytes = write_safetensors(&tensors, &meta);
        assert_eq!((u64::from_le_bytes(bytes[..8].try_into().unwrap()) + 8) % 8, 0);
        let (read, read_meta) = read_safetensors(&bytes).unwrap();
        assert_eq!(read_meta, meta);
        let a = load_weights(a, &read).unwrap();
        let b = load_weights(cfg.init(&dev), &read).unwrap();
        assert_eq!(named_tensors(&b), tensors);
        let x = input(&dev);
        let (oa, ob) = (a.forward(x.clone()), b.forward(x));
        assert_eq!(oa.cls_logits.into_data(), ob.cls_logits.into_data());
        assert_eq!(oa.box_residuals.into_data(), ob.box_residuals.into_data());
    }

    #[test]
    fn bad_files_and_mismatched_models_are_named() {
        assert!(matches!(read_safetensors(b"\x01\x00"), Err(ExportError::Format(_))));
        let mut truncated = write_safetensors(
            &named_tensors(&StarNetConfig::small_car().init(&default_device())),
            &BTreeMap::new(),
        );
        truncated.truncate(truncated.len() - 10);
        assert!(read_safetensors(&truncated).is_err());
        let dev = default_device();
        let small = named_tensors(&StarNetConfig::small_car().init(&dev));
        let (read, _) = read_safetensors(&write_safetensors(&small, &BTreeMap::new())).unwrap();
        let err = load_weights(StarNetConfig::paper_car().init(&dev), &read)
            .unwrap_err()
            .to_string();
        assert!(err.contains("featurizer.fc0.weight") && err.contains("shape"), "{err}");
    }
}
