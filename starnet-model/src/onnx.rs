//! The dense network as an ONNX graph (opset 13), built node by node as the typed messages of
//! the official `onnx.proto` (the `onnx-protobuf` crate): Burn's ONNX exporter
//! cannot lower the masked max and mean, `expand` or the masks (see issue #7), and the graph
//! here needs none of Burn's tracing. Host code does sampling, gathering, decoding and NMS
//! (`model.json` is their contract).
//!
//! - inputs: `points [C, P, F]` (f32; padded slots zero), `mask [C, P]` (1 real, 0 padded);
//! - outputs: `cls_logits [C, A, K]`, `box_residuals [C, A, 7]` (and `dir_logits [C, A, 2]`
//!   with the direction classifier);
//! - C and P are dynamic (`dim_param` "C" and "P").
//!
//! The streaming LSTM variant's graph is one slice step: it also takes `center_valid [C]` (1
//! real, 0 a repeat padding a small slice pool) and the state after the sweep's earlier slices,
//! `state_h [1, H]` and `state_c [1, H]` (zeros at a sweep's first slice), and also returns the
//! state after this slice, `state_h_out` and `state_c_out`: the host loops over the slices.
//!
//! The graph is the evaluation-mode forward of [`StarNet`]: each masked BatchNorm is folded
//! into a per-channel scale and shift (`x·s + t`, `s = γ/√(σ² + ε)`, `t = β − μ·s`) followed
//! by the mask (the projector's by `center_valid`, all ones outside the streaming variant).

use crate::export::{NamedTensor, named_tensors, transpose};
use crate::nn::{MaskedBatchNormConfig, StarNet, StarNetConfig};
use onnx_protobuf::attribute_proto::AttributeType;
use onnx_protobuf::tensor_proto::DataType;
use onnx_protobuf::tensor_shape_proto::{Dimension, dimension};
use onnx_protobuf::{
    AttributeProto, GraphProto, ModelProto, NodeProto, OperatorSetIdProto, TensorProto, TensorShapeProto, TypeProto,
    ValueInfoProto, type_proto,
};
use protobuf::{Message, MessageField};
use std::collections::BTreeMap;

/// The ONNX opset the graph uses.
pub const OPSET: i64 = 13;

/// A node attribute.
enum Attr {
    Int(i64),
    Ints(Vec<i64>),
}

/// The graph under construction.
#[derive(Default)]
struct Graph {
    nodes: Vec<NodeProto>,
    initializers: Vec<TensorProto>,
    next: usize,
}

impl Graph {
    /// A fresh value name.
    fn name(&mut self, stem: &str) -> String {
        self.next += 1;
        format!("{stem}_{}", self.next)
    }

    fn tensor(&mut self, name: &str, dims: &[usize], data_type: DataType, raw: Vec<u8>) {
        self.initializers.push(TensorProto {
            dims: dims.iter().map(|&d| d as i64).collect(),
            data_type: data_type as i32,
            name: name.into(),
            raw_data: raw,
            ..TensorProto::default()
        });
    }

    /// An f32 constant.
    fn floats(&mut self, stem: &str, dims: &[usize], values: &[f32]) -> String {
        let name = self.name(stem);
        self.tensor(
            &name,
            dims,
            DataType::FLOAT,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        );
        name
    }

    /// An i64 vector constant (shapes and axes).
    fn ints(&mut self, stem: &str, values: &[i64]) -> String {
        let name = self.name(stem);
        self.tensor(
            &name,
            &[values.len()],
            DataType::INT64,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        );
        name
    }

    /// Adds a node with one output; returns the output's name.
    fn op(&mut self, op_type: &str, inputs: &[&str], attrs: &[(&str, Attr)]) -> String {
        let out = self.name(&op_type.to_lowercase());
        self.op_into(op_type, inputs, attrs, &out);
        out
    }

    /// Adds a node writing `out`.
    fn op_into(&mut self, op_type: &str, inputs: &[&str], attrs: &[(&str, Attr)], out: &str) {
        let attribute = attrs
            .iter()
            .map(|(name, a)| {
                let mut p = AttributeProto {
                    name: (*name).into(),
                    ..AttributeProto::default()
                };
                match a {
                    Attr::Int(v) => (p.i, p.type_) = (*v, AttributeType::INT.into()),
                    Attr::Ints(vs) => (p.ints, p.type_) = (vs.clone(), AttributeType::INTS.into()),
                }
                p
            })
            .collect();
        self.nodes.push(NodeProto {
            input: inputs.iter().map(|i| (*i).into()).collect(),
            output: vec![out.into()],
            name: out.into(),
            op_type: op_type.into(),
            attribute,
            ..NodeProto::default()
        });
    }
}

/// A tensor value's type: f32 with these dims (`Err` = a named dynamic dim).
fn value_info(name: &str, dims: &[Result<usize, &str>]) -> ValueInfoProto {
    let dim = dims
        .iter()
        .map(|d| Dimension {
            value: Some(match d {
                Ok(v) => dimension::Value::DimValue(*v as i64),
                Err(p) => dimension::Value::DimParam((*p).into()),
            }),
            ..Dimension::default()
        })
        .collect();
    let tensor = type_proto::Tensor {
        elem_type: DataType::FLOAT as i32,
        shape: MessageField::some(TensorShapeProto {
            dim,
            ..TensorShapeProto::default()
        }),
        ..type_proto::Tensor::default()
    };
    ValueInfoProto {
        name: name.into(),
        type_: MessageField::some(TypeProto {
            value: Some(type_proto::Value::TensorType(tensor)),
            ..TypeProto::default()
        }),
        ..ValueInfoProto::default()
    }
}

/// `[out, in]` (PyTorch layout) → `[in, out]` values, for `x · W`.
fn transposed(t: &NamedTensor) -> (Vec<usize>, Vec<f32>) {
    let (o, i) = (t.shape[0], t.shape[1]);
    (vec![i, o], transpose(&t.data, o, i))
}

struct Weights {
    by_name: BTreeMap<String, NamedTensor>,
    epsilon: f64,
}

impl Weights {
    fn get(&self, name: &str) -> &NamedTensor {
        self.by_name
            .get(name)
            .unwrap_or_else(|| panic!("the model has no `{name}`"))
    }

    /// `x · W (+ b)` for the Linear at `prefix`.
    fn linear(&self, g: &mut Graph, x: &str, prefix: &str) -> String {
        let (dims, w) = transposed(self.get(&format!("{prefix}.weight")));
        let w = g.floats(&format!("{prefix}.weight"), &dims, &w);
        let y = g.op("MatMul", &[x, &w], &[]);
        match self.by_name.get(&format!("{prefix}.bias")) {
            Some(b) => {
                let b = g.floats(&format!("{prefix}.bias"), &b.shape, &b.data);
                g.op("Add", &[&y, &b], &[])
            }
            None => y,
        }
    }

    /// The masked BatchNorm at `prefix` in evaluation mode, folded; `mask` broadcasts over x.
    fn batch_norm(&self, g: &mut Graph, x: &str, prefix: &str, mask: Option<&str>) -> String {
        let [gamma, beta, mean, var] =
            ["weight", "bias", "running_mean", "running_var"].map(|f| self.get(&format!("{prefix}.{f}")));
        let scale: Vec<f32> = gamma
            .data
            .iter()
            .zip(&var.data)
            .map(|(g, v)| (f64::from(*g) / (f64::from(*v) + self.epsilon).sqrt()) as f32)
            .collect();
        let shift: Vec<f32> = beta
            .data
            .iter()
            .zip(&mean.data)
            .zip(&scale)
            .map(|((b, m), s)| b - m * s)
            .collect();
        let s = g.floats(&format!("{prefix}.scale"), &[scale.len()], &scale);
        let t = g.floats(&format!("{prefix}.shift"), &[shift.len()], &shift);
        let y = g.op("Mul", &[x, &s], &[]);
        let y = g.op("Add", &[&y, &t], &[]);
        match mask {
            Some(m) => g.op("Mul", &[&y, m], &[]),
            None => y,
        }
    }
}

/// The ONNX model (serialized `ModelProto`) of `model`, whose config is `cfg`: the per-center
/// network (featurizer, projector, heads) and, for the streaming variant, the LSTM's step over
/// one slice with its state as inputs and outputs.
pub fn onnx_model(model: &StarNet, cfg: &StarNetConfig) -> Vec<u8> {
    let w = Weights {
        by_name: named_tensors(model).into_iter().map(|t| (t.name.clone(), t)).collect(),
        epsilon: MaskedBatchNormConfig::new(1).epsilon,
    };
    let f = cfg.featurizer.d_input;
    let a = cfg.anchors.len();
    let k = cfg.num_classes;
    let mut g = Graph::default();
    let axis1 = g.ints("axis1", &[1]);
    let axis2 = g.ints("axis2", &[2]);
    let one = g.floats("one", &[1], &[1.0]);
    let m = g.op("Unsqueeze", &["mask", &axis2], &[]); // [C, P, 1]
    let count = g.op("ReduceSum", &[&m, &axis1], &[("keepdims", Attr::Int(1))]); // [C, 1, 1]
    let denom = g.op("Max", &[&count, &one], &[]);
    let masked_mean = |g: &mut Graph, h: &str| {
        let s = g.op("ReduceSum", &[h, &axis1], &[("keepdims", Attr::Int(1))]); // padded rows are 0
        g.op("Div", &[&s, &denom], &[]) // [C, 1, d]
    };
    // fc0: Linear + ReLU, padded rows zeroed.
    let h = w.linear(&mut g, "points", "featurizer.fc0");
    let h = g.op("Relu", &[&h], &[]);
    let mut h = g.op("Mul", &[&h, &m], &[]);
    let mut readout = vec![masked_mean(&mut g, &h)];
    for i in 0..cfg.featurizer.blocks.len() {
        let p = format!("featurizer.blocks.{i}");
        // max over P of the zero-padded ReLU outputs, broadcast back to every point.
        let pooled = g.op(
            "ReduceMax",
            &[&h],
            &[("axes", Attr::Ints(vec![1])), ("keepdims", Attr::Int(1))],
        );
        let shape = g.op("Shape", &[&h], &[]);
        let pooled = g.op("Expand", &[&pooled, &shape], &[]);
        let x = g.op("Concat", &[&h, &pooled], &[("axis", Attr::Int(2))]);
        let x = w.batch_norm(&mut g, &x, &format!("{p}.bn1"), Some(&m));
        let x = w.linear(&mut g, &x, &format!("{p}.fc1"));
        let x = g.op("Relu", &[&x], &[]);
        let x = w.batch_norm(&mut g, &x, &format!("{p}.bn2"), Some(&m));
        let x = w.linear(&mut g, &x, &format!("{p}.fc2"));
        h = g.op("Relu", &[&x], &[]);
        readout.push(masked_mean(&mut g, &h));
    }
    let refs: Vec<&str> = readout.iter().map(String::as_str).collect();
    let cell = g.op("Concat", &refs, &[("axis", Attr::Int(2))]); // [C, 1, cell]
    let cell_shape = g.ints("cell_shape", &[-1, cfg.featurizer.cell_dim() as i64]);
    let cell = g.op("Reshape", &[&cell, &cell_shape], &[]); // [C, cell]
    // The streaming variant's slices mark repeated centers; the projector's BatchNorm zeroes
    // their rows, as Burn's masked BatchNorm does, and the LSTM's context joins after it.
    let valid = cfg
        .lstm_hidden
        .map(|_| g.op("Unsqueeze", &["center_valid", &axis1], &[])); // [C, 1]
    let mut x = w.batch_norm(&mut g, &cell, "proj_bn", valid.as_deref());
    if let Some(v) = &valid {
        x = lstm_step(&w, &mut g, &x, v);
    }
    let shared_size = cfg.shared_size.then(|| w.linear(&mut g, &x, "size_head")); // [C, R·Pr·3]
    let x = w.linear(&mut g, &x, "proj");
    let x = g.op("Relu", &[&x], &[]); // [C, G²·D]
    let per_offset = g.ints("per_offset", &[-1, cfg.d_offset as i64]);
    let x = g.op("Reshape", &[&x, &per_offset], &[]); // [C·G², D]
    let cls = w.linear(&mut g, &x, "cls_head");
    if cfg.direction_classifier {
        let dir = w.linear(&mut g, &x, "dir_head");
        let dir_shape = g.ints("dir_shape", &[-1, a as i64, 2]);
        g.op_into("Reshape", &[&dir, &dir_shape], &[], "dir_logits");
    }
    let reg = w.linear(&mut g, &x, "box_head");
    let cls_shape = g.ints("cls_shape", &[-1, a as i64, k as i64]);
    let box_shape = g.ints("box_shape", &[-1, a as i64, 7]);
    g.op_into("Reshape", &[&cls, &cls_shape], &[], "cls_logits");
    let reg = match shared_size {
        Some(size) => with_shared_size(&mut g, &reg, &size, cfg),
        None => reg,
    };
    g.op_into("Reshape", &[&reg, &box_shape], &[], "box_residuals");

    model_proto(g, io_values(cfg, f, a, k))
}

/// A graph's inputs and outputs.
struct Io {
    inputs: Vec<ValueInfoProto>,
    outputs: Vec<ValueInfoProto>,
}

/// The graph's inputs and outputs for `cfg`, F features, A anchors, K classes.
fn io_values(cfg: &StarNetConfig, f: usize, a: usize, k: usize) -> Io {
    let mut inputs = vec![
        value_info("points", &[Err("C"), Err("P"), Ok(f)]),
        value_info("mask", &[Err("C"), Err("P")]),
    ];
    let mut outputs = vec![
        value_info("cls_logits", &[Err("C"), Ok(a), Ok(k)]),
        value_info("box_residuals", &[Err("C"), Ok(a), Ok(7)]),
    ];
    if cfg.direction_classifier {
        outputs.push(value_info("dir_logits", &[Err("C"), Ok(a), Ok(2)]));
    }
    if let Some(h) = cfg.lstm_hidden {
        inputs.push(value_info("center_valid", &[Err("C")]));
        inputs.push(value_info("state_h", &[Ok(1), Ok(h)]));
        inputs.push(value_info("state_c", &[Ok(1), Ok(h)]));
        outputs.push(value_info("state_h_out", &[Ok(1), Ok(h)]));
        outputs.push(value_info("state_c_out", &[Ok(1), Ok(h)]));
    }
    Io { inputs, outputs }
}

/// The serialized `ModelProto` around graph `g` with these inputs and outputs.
fn model_proto(g: Graph, io: Io) -> Vec<u8> {
    let graph = GraphProto {
        node: g.nodes,
        name: "starnet".into(),
        initializer: g.initializers,
        input: io.inputs,
        output: io.outputs,
        ..GraphProto::default()
    };
    let model = ModelProto {
        ir_version: 7, // IR version 7 goes with opset 13
        opset_import: vec![OperatorSetIdProto {
            domain: String::new(),
            version: OPSET,
            ..OperatorSetIdProto::default()
        }],
        producer_name: "starnet".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        graph: MessageField::some(graph),
        ..ModelProto::default()
    };
    model.write_to_bytes().expect("an in-memory ONNX model serialises")
}

/// The streaming LSTM's step over one slice, as `SliceLstm::forward` with one slice: the mean
/// of the valid centers' normalised cells drives one LSTM step (Burn's gates: input, forget and output
/// sigmoid, cell tanh; `c' = f·c + i·g`, `h' = o·tanh(c')`) from `state_h` / `state_c`, and its
/// output, projected back to the cell width, is added to every center's cell. Writes
/// `state_h_out` and `state_c_out`.
///
/// # Shapes
/// - `cell`: `[C, D]`; `valid` `[C, 1]`; state `[1, H]`
/// - output: `[C, D]`
fn lstm_step(w: &Weights, g: &mut Graph, cell: &str, valid: &str) -> String {
    let axis0 = g.ints("axis0", &[0]);
    let one = g.floats("one", &[1], &[1.0]);
    let keep = [("keepdims", Attr::Int(1))];
    let masked = g.op("Mul", &[cell, valid], &[]);
    let sum = g.op("ReduceSum", &[&masked, &axis0], &keep); // [1, D]
    let count = g.op("ReduceSum", &[valid, &axis0], &keep); // [1, 1]
    let count = g.op("Max", &[&count, &one], &[]); // a slice without centers: a zero input
    let mean = g.op("Div", &[&sum, &count], &[]);
    let mut gate = |name: &str, activation: &str| {
        let p = format!("lstm.lstm.{name}");
        let x = w.linear(g, &mean, &format!("{p}.input_transform"));
        let h = w.linear(g, "state_h", &format!("{p}.hidden_transform"));
        let z = g.op("Add", &[&x, &h], &[]);
        g.op(activation, &[&z], &[])
    };
    let i = gate("input_gate", "Sigmoid");
    let f = gate("forget_gate", "Sigmoid");
    let o = gate("output_gate", "Sigmoid");
    let c = gate("cell_gate", "Tanh");
    let kept = g.op("Mul", &[&f, "state_c"], &[]);
    let added = g.op("Mul", &[&i, &c], &[]);
    g.op_into("Add", &[&kept, &added], &[], "state_c_out");
    let squashed = g.op("Tanh", &["state_c_out"], &[]);
    g.op_into("Mul", &[&o, &squashed], &[], "state_h_out");
    let context = w.linear(g, "state_h_out", "lstm.out"); // [1, D]
    g.op("Add", &[cell, &context], &[])
}

/// The per-offset residuals `reg` `[C·G², R·Pr·7]` with their size residuals (3..6) replaced by
/// the per-center `size` `[C, R·Pr·3]` at every offset: `[C, G², R·Pr, 7]`.
fn with_shared_size(g: &mut Graph, reg: &str, size: &str, cfg: &StarNetConfig) -> String {
    let offsets = (cfg.anchors.grid * cfg.anchors.grid) as i64;
    let per = cfg.anchors_per_offset() as i64;
    let reg_shape = g.ints("reg_shape", &[-1, offsets, per, 7]);
    let reg = g.op("Reshape", &[reg, &reg_shape], &[]);
    let size_shape = g.ints("size_shape", &[-1, 1, per, 3]);
    let size = g.op("Reshape", &[size, &size_shape], &[]);
    let axis3 = g.ints("axis3", &[3]);
    let slice = |g: &mut Graph, from: i64, to: i64| {
        let (s, e) = (g.ints("start", &[from]), g.ints("end", &[to]));
        g.op("Slice", &[&reg, &s, &e, &axis3], &[])
    };
    let (position, heading) = (slice(g, 0, 3), slice(g, 6, 7));
    let shape = g.op("Shape", &[&position], &[]);
    let size = g.op("Expand", &[&size, &shape], &[]);
    g.op("Concat", &[&position, &size, &heading], &[("axis", Attr::Int(3))])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_parses_back_with_its_inputs_outputs_and_opset() {
        use crate::nn::StarNetConfig;
        let cfg = StarNetConfig::small_car().with_lstm_hidden(Some(8));
        let model = cfg.init(&crate::backend::default_device());
        let parsed = ModelProto::parse_from_bytes(&onnx_model(&model, &cfg)).unwrap();
        assert_eq!((parsed.ir_version, parsed.opset_import[0].version), (7, OPSET));
        let names = |v: &[ValueInfoProto]| v.iter().map(|i| i.name.clone()).collect::<Vec<_>>();
        let graph = parsed.graph.as_ref().unwrap();
        assert_eq!(
            names(&graph.input),
            ["points", "mask", "center_valid", "state_h", "state_c"]
        );
        assert_eq!(
            names(&graph.output),
            ["cls_logits", "box_residuals", "state_h_out", "state_c_out"]
        );
        // Every node's inputs are graph inputs, initializers or earlier nodes' outputs.
        let mut known: std::collections::BTreeSet<String> = names(&graph.input).into_iter().collect();
        known.extend(graph.initializer.iter().map(|t| t.name.clone()));
        for n in &graph.node {
            assert!(
                n.input.iter().all(|i| known.contains(i)),
                "{} reads an unknown value",
                n.name
            );
            known.extend(n.output.iter().cloned());
        }
        assert!(names(&graph.output).iter().all(|o| known.contains(o)));
    }

    #[test]
    fn transposing_swaps_the_layout() {
        let t = NamedTensor {
            name: "w".into(),
            shape: vec![2, 3],
            data: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        };
        assert_eq!(transposed(&t), (vec![3, 2], vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0]));
    }
}
