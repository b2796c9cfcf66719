//! The dense network as an ONNX graph (opset 13), built node by node: Burn's ONNX exporter
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
use std::collections::BTreeMap;

/// The ONNX opset the graph uses.
pub const OPSET: i64 = 13;

/// Minimal protobuf writer: the wire format the ONNX messages need.
#[derive(Default)]
struct Pb(Vec<u8>);

impl Pb {
    fn varint(&mut self, mut v: u64) {
        while v >= 0x80 {
            self.0.push((v as u8) | 0x80);
            v >>= 7;
        }
        self.0.push(v as u8);
    }

    fn key(&mut self, field: u32, wire: u8) {
        self.varint((u64::from(field) << 3) | u64::from(wire));
    }

    fn int(&mut self, field: u32, v: i64) {
        self.key(field, 0);
        self.varint(v as u64);
    }

    fn bytes(&mut self, field: u32, b: &[u8]) {
        self.key(field, 2);
        self.varint(b.len() as u64);
        self.0.extend_from_slice(b);
    }

    fn str(&mut self, field: u32, s: &str) {
        self.bytes(field, s.as_bytes());
    }

    fn msg(&mut self, field: u32, m: &Pb) {
        self.bytes(field, &m.0);
    }
}

const FLOAT: i64 = 1;
const INT64: i64 = 7;

/// A node attribute.
enum Attr {
    Int(i64),
    Ints(Vec<i64>),
}

/// The graph under construction.
#[derive(Default)]
struct Graph {
    nodes: Vec<Pb>,
    initializers: Vec<Pb>,
    next: usize,
}

impl Graph {
    /// A fresh value name.
    fn name(&mut self, stem: &str) -> String {
        self.next += 1;
        format!("{stem}_{}", self.next)
    }

    fn tensor(&mut self, name: &str, dims: &[usize], data_type: i64, raw: Vec<u8>) {
        let mut t = Pb::default();
        for &d in dims {
            t.int(1, d as i64);
        }
        t.int(2, data_type);
        t.str(8, name);
        t.bytes(9, &raw);
        self.initializers.push(t);
    }

    /// An f32 constant.
    fn floats(&mut self, stem: &str, dims: &[usize], values: &[f32]) -> String {
        let name = self.name(stem);
        self.tensor(
            &name,
            dims,
            FLOAT,
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
            INT64,
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
        let mut n = Pb::default();
        for i in inputs {
            n.str(1, i);
        }
        n.str(2, out);
        n.str(3, out);
        n.str(4, op_type);
        for (name, a) in attrs {
            let mut p = Pb::default();
            p.str(1, name);
            match a {
                Attr::Int(v) => {
                    p.int(3, *v);
                    p.int(20, 2);
                }
                Attr::Ints(vs) => {
                    for v in vs {
                        p.int(8, *v);
                    }
                    p.int(20, 7);
                }
            }
            n.msg(5, &p);
        }
        self.nodes.push(n);
    }
}

/// A tensor value's type: f32 with these dims (`Err` = a named dynamic dim).
fn value_info(name: &str, dims: &[Result<usize, &str>]) -> Pb {
    let mut shape = Pb::default();
    for d in dims {
        let mut dim = Pb::default();
        match d {
            Ok(v) => dim.int(1, *v as i64),
            Err(p) => dim.str(2, p),
        }
        shape.msg(1, &dim);
    }
    let mut tensor = Pb::default();
    tensor.int(1, FLOAT);
    tensor.msg(2, &shape);
    let mut ty = Pb::default();
    ty.msg(1, &tensor);
    let mut vi = Pb::default();
    vi.str(1, name);
    vi.msg(2, &ty);
    vi
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
    let mut cell = g.op("Reshape", &[&cell, &cell_shape], &[]); // [C, cell]
    // The streaming variant's slices mark repeated centers; the projector's BatchNorm zeroes
    // their rows, as Burn's masked BatchNorm does.
    let mut valid = None;
    if cfg.lstm_hidden.is_some() {
        let v = g.op("Unsqueeze", &["center_valid", &axis1], &[]); // [C, 1]
        cell = lstm_step(&w, &mut g, &cell, &v);
        valid = Some(v);
    }
    let x = w.batch_norm(&mut g, &cell, "proj_bn", valid.as_deref());
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

    let mut graph = Pb::default();
    for n in &g.nodes {
        graph.msg(1, n);
    }
    graph.str(2, "starnet");
    for t in &g.initializers {
        graph.msg(5, t);
    }
    graph.msg(11, &value_info("points", &[Err("C"), Err("P"), Ok(f)]));
    graph.msg(11, &value_info("mask", &[Err("C"), Err("P")]));
    if let Some(h) = cfg.lstm_hidden {
        graph.msg(11, &value_info("center_valid", &[Err("C")]));
        graph.msg(11, &value_info("state_h", &[Ok(1), Ok(h)]));
        graph.msg(11, &value_info("state_c", &[Ok(1), Ok(h)]));
    }
    graph.msg(12, &value_info("cls_logits", &[Err("C"), Ok(a), Ok(k)]));
    graph.msg(12, &value_info("box_residuals", &[Err("C"), Ok(a), Ok(7)]));
    if cfg.direction_classifier {
        graph.msg(12, &value_info("dir_logits", &[Err("C"), Ok(a), Ok(2)]));
    }
    if let Some(h) = cfg.lstm_hidden {
        graph.msg(12, &value_info("state_h_out", &[Ok(1), Ok(h)]));
        graph.msg(12, &value_info("state_c_out", &[Ok(1), Ok(h)]));
    }
    let mut opset = Pb::default();
    opset.str(1, "");
    opset.int(2, OPSET);
    let mut model_pb = Pb::default();
    model_pb.int(1, 7); // IR version 7 goes with opset 13
    model_pb.str(2, "starnet");
    model_pb.str(3, env!("CARGO_PKG_VERSION"));
    model_pb.msg(7, &graph);
    model_pb.msg(8, &opset);
    model_pb.0
}

/// The streaming LSTM's step over one slice, as `SliceLstm::forward` with one slice: the mean
/// of the valid centers' cells drives one LSTM step (Burn's gates: input, forget and output
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
    fn varints_follow_the_protobuf_encoding() {
        let mut p = Pb::default();
        p.varint(1);
        p.varint(300);
        p.int(1, -1);
        assert_eq!(p.0[..3], [0x01, 0xac, 0x02]);
        // A negative int64 is ten bytes after its key.
        assert_eq!(p.0.len(), 3 + 1 + 10);
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
