//! Weights in the [safetensors](https://huggingface.co/docs/safetensors) format with PyTorch's
//! names and layouts, so `safetensors.torch.load_file` gives a state dict a PyTorch port of the
//! model can load:
//!
//! - names are the module paths (`featurizer.blocks.0.fc1.weight`, `proj_bn.running_mean`, …);
//! - a Linear weight is `[out, in]` (Burn stores `[in, out]`), its bias `[out]`;
//! - a BatchNorm's γ / β are `weight` / `bias`, beside `running_mean` and `running_var`
//!   (biased variance, ε in the metadata of the caller's choosing);
//! - every tensor is little-endian f32, in visiting order, the header padded to 8 bytes.
//!
//! [`read_safetensors`] and [`load_weights`] are the inverse: a written file loads back into
//! the Burn model bit for bit.

use crate::nn::StarNet;
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::prelude::*;
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

/// Encodes tensors (in order) and string metadata as a safetensors file.
pub fn write_safetensors(tensors: &[NamedTensor], metadata: &BTreeMap<String, String>) -> Vec<u8> {
    let mut header = serde_json::Map::new();
    header.insert("__metadata__".into(), serde_json::json!(metadata));
    let mut offset = 0usize;
    for t in tensors {
        let end = offset + 4 * t.data.len();
        header.insert(
            t.name.clone(),
            serde_json::json!({"dtype": "F32", "shape": t.shape, "data_offsets": [offset, end]}),
        );
        offset = end;
    }
    let mut json = serde_json::to_string(&header).expect("header serialises").into_bytes();
    // The data starts 8-byte aligned (the format allows trailing spaces in the header).
    while !(8 + json.len()).is_multiple_of(8) {
        json.push(b' ');
    }
    let mut bytes = Vec::with_capacity(8 + json.len() + offset);
    bytes.extend_from_slice(&(json.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&json);
    for t in tensors {
        for v in &t.data {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    bytes
}

/// Tensors by name.
pub type TensorMap = BTreeMap<String, NamedTensor>;

/// Decodes a safetensors file of f32 tensors: the tensors by name, and the metadata.
pub fn read_safetensors(bytes: &[u8]) -> Result<(TensorMap, BTreeMap<String, String>), ExportError> {
    let bad = |m: &str| ExportError::Format(m.to_string());
    let n = u64::from_le_bytes(
        bytes
            .get(..8)
            .ok_or_else(|| bad("shorter than its 8-byte header length"))?
            .try_into()
            .expect("8 bytes"),
    ) as usize;
    let header = bytes
        .get(8..8usize.saturating_add(n))
        .ok_or_else(|| bad("header runs past the end"))?;
    let data = &bytes[8 + n..];
    let header: serde_json::Map<String, serde_json::Value> =
        serde_json::from_slice(header).map_err(|e| ExportError::Format(format!("header: {e}")))?;
    let mut tensors = BTreeMap::new();
    let mut metadata = BTreeMap::new();
    for (name, v) in header {
        if name == "__metadata__" {
            metadata = serde_json::from_value(v).map_err(|e| ExportError::Format(format!("__metadata__: {e}")))?;
            continue;
        }
        let entry = |m: &str| ExportError::Tensor {
            name: name.clone(),
            message: m.to_string(),
        };
        if v["dtype"] != "F32" {
            return Err(entry("only F32 tensors are supported"));
        }
        let shape: Vec<usize> = serde_json::from_value(v["shape"].clone()).map_err(|_| entry("bad shape"))?;
        let [begin, end]: [usize; 2] =
            serde_json::from_value(v["data_offsets"].clone()).map_err(|_| entry("bad data_offsets"))?;
        let raw = data
            .get(begin..end)
            .filter(|r| r.len() == 4 * shape.iter().product::<usize>())
            .ok_or_else(|| entry("data_offsets do not match the shape or the file"))?;
        let values = raw
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        tensors.insert(
            name.clone(),
            NamedTensor {
                name,
                shape,
                data: values,
            },
        );
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
                    Tensor::<1>::from_floats(values.as_slice(), &t.device()).reshape(t.shape())
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
    use burn::tensor::Distribution;

    fn input(dev: &Device) -> ModelInput {
        ModelInput {
            points: Tensor::<4>::random([1, 6, 8, 4], Distribution::Normal(0.0, 1.0), dev),
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
