//! The fused projector and heads ([`super::head`]) as one Burn operation on flex: on autodiff
//! tensors a single graph node whose backward is [`head::backward`], on plain flex tensors the
//! forward alone. `None` when the tensors live elsewhere: the caller then takes Burn's
//! operations.

use super::head::{self, HeadDims, HeadParams};
use super::op::register_parents;
use crate::flex_data::{flex, values};
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::flex::FlexTensor;
use burn::backend::{Autodiff, Flex};
use burn::prelude::*;
use burn::tensor::DType;
use std::borrow::Cow;
use std::sync::Arc;

/// The parameter tensors (as [`HeadParams`]).
#[derive(Debug, Clone)]
pub struct HeadTensors {
    /// The projector's weight `[c, G²·D]`.
    pub w_proj: Tensor<2>,
    /// The projector's bias `[G²·D]`.
    pub b_proj: Tensor<1>,
    /// The heads' weights side by side `[D, K]`.
    pub w_heads: Tensor<2>,
    /// The heads' biases side by side `[K]`.
    pub b_heads: Tensor<1>,
}

impl HeadTensors {
    fn dims(&self, x: &Tensor<2>) -> HeadDims {
        let ([rows, d_in], [_, d_proj], [d_offset, d_out]) = (x.dims(), self.w_proj.dims(), self.w_heads.dims());
        HeadDims {
            rows,
            d_in,
            offsets: d_proj / d_offset.max(1),
            d_offset,
            d_out,
        }
    }

    /// The five inputs flattened, in order: x, the projector's weight and bias, the heads'.
    fn inputs(self, x: Tensor<2>) -> [Tensor<1>; 5] {
        let flat = |t: Tensor<2>| {
            let n = t.shape().num_elements();
            t.reshape([n])
        };
        [
            flat(x),
            flat(self.w_proj),
            self.b_proj,
            flat(self.w_heads),
            self.b_heads,
        ]
    }
}

fn params<'a>(v: &'a [Cow<'a, [f32]>]) -> HeadParams<'a> {
    HeadParams {
        w_proj: &v[1],
        b_proj: &v[2],
        w_heads: &v[3],
        b_heads: &v[4],
    }
}

/// What the backward keeps of the forward.
#[derive(Debug, Clone)]
struct Saved {
    inputs: Arc<Vec<FlexTensor>>,
    dims: HeadDims,
    /// The projector's ReLU output `[M·G², D]`.
    features: Arc<Vec<f32>>,
}

#[derive(Debug)]
struct HeadBackward;

impl Backward<Flex, 5> for HeadBackward {
    type State = Saved;

    fn backward(self, ops: Ops<Saved, 5>, grads: &mut Gradients, _: &mut Checkpointer) {
        let dz = grads.consume::<Flex>(&ops.node);
        let s = ops.state;
        let v: Vec<Cow<[f32]>> = s.inputs.iter().map(values).collect();
        let g = head::backward(&v[0], params(&v), s.dims, &s.features, &values(&dz));
        let shapes = s.inputs.iter().map(|t| t.layout().shape().to_vec());
        let values = [g.x, g.w_proj, g.b_proj, g.w_heads, g.b_heads];
        register_parents(
            ops.parents.iter().map(|p| p.as_ref().map(|n| n.id)),
            values,
            shapes,
            grads,
        );
    }
}

/// The projector's Linear and ReLU and the heads, on autodiff-flex tensors (one graph node) or
/// plain flex ones.
///
/// # Shapes
/// - `x`: `[M, c]` (the projector's BatchNorm output); returns the heads' outputs side by side
///   per offset `[M·G², K]`
pub fn forward(x: Tensor<2>, params: HeadTensors) -> Option<Tensor<2>> {
    forward_autodiff(x.clone(), params.clone()).or_else(|| forward_plain(x, params))
}

fn forward_autodiff(x: Tensor<2>, p: HeadTensors) -> Option<Tensor<2>> {
    let dims = p.dims(&x);
    let ad: Vec<_> = p
        .inputs(x)
        .into_iter()
        .map(|t| t.try_into_primitive::<Autodiff<Flex>>().ok())
        .collect::<Option<_>>()?;
    let (prims, guards): (Vec<FlexTensor>, Vec<_>) = ad.into_iter().map(|t| t.into_parts()).unzip();
    if prims.iter().any(|t| t.dtype() != DType::F32) {
        return None;
    }
    let (z, features) = {
        let v: Vec<Cow<[f32]>> = prims.iter().map(values).collect();
        head::forward(&v[0], params(&v), dims)
    };
    let out = flex(z, vec![dims.rows * dims.offsets, dims.d_out]);
    let guards: [_; 5] = guards.try_into().expect("five inputs");
    let out = match HeadBackward
        .prepare::<NoCheckpointing>(guards)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => {
            let state = Saved {
                inputs: Arc::new(prims),
                dims,
                features: Arc::new(features),
            };
            prep.finish(state, out)
        }
        OpsKind::UnTracked(prep) => prep.finish(out),
    };
    Some(Tensor::from_primitive::<Autodiff<Flex>>(out))
}

fn forward_plain(x: Tensor<2>, p: HeadTensors) -> Option<Tensor<2>> {
    let dims = p.dims(&x);
    let prims: Vec<FlexTensor> = p
        .inputs(x)
        .into_iter()
        .map(|t| t.try_into_primitive::<Flex>().ok().filter(|t| t.dtype() == DType::F32))
        .collect::<Option<_>>()?;
    let v: Vec<Cow<[f32]>> = prims.iter().map(values).collect();
    let (z, _) = head::forward(&v[0], params(&v), dims);
    Some(Tensor::from_primitive::<Flex>(flex(
        z,
        vec![dims.rows * dims.offsets, dims.d_out],
    )))
}
