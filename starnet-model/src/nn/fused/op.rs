//! The fused block as a Burn operation on flex: the training forward records one autodiff node
//! whose backward is [`kernel::backward`]; the evaluation forward runs on plain flex tensors.
//! Both run on the real points only ([`Packed`]; padded slots come back as zeros). Both return
//! `None` when the tensors live elsewhere (another backend, another dtype, a
//! gradient-checkpointing strategy), and the caller then takes the composed path.

use super::kernel::{self, BlockDims, BlockParams, BlockSaved, BlockStats, BnStats, Forward, Normalization};
use super::packed::Packed;
use crate::flex_data::{flex, values};
use burn::backend::autodiff::NodeId;
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

/// The block's parameter tensors (as [`BlockParams`]).
#[derive(Debug, Clone)]
pub struct ParamTensors {
    /// BN₁ scale `[2d]`.
    pub gamma1: Tensor<1>,
    /// BN₁ shift `[2d]`.
    pub beta1: Tensor<1>,
    /// fc1's weight `[2d, H]`.
    pub w1: Tensor<2>,
    /// BN₂ scale `[H]`.
    pub gamma2: Tensor<1>,
    /// BN₂ shift `[H]`.
    pub beta2: Tensor<1>,
    /// fc2's weight `[H, O]`.
    pub w2: Tensor<2>,
    /// Added to the variances.
    pub epsilon: f32,
}

/// A training forward's result: the output and the batch statistics for the running averages.
#[derive(Debug)]
pub struct TrainOutput {
    /// `[N, P, O]`.
    pub out: Tensor<3>,
    /// The batch statistics.
    pub stats: BlockStats,
}

/// Registers the gradient of each tracked parent (`parents`: their ids, `None` where a parent
/// is not tracked; `values` and `shapes` in the same order).
pub(crate) fn register_parents<const N: usize>(
    parents: impl Iterator<Item = Option<NodeId>>,
    values: [Vec<f32>; N],
    shapes: impl Iterator<Item = Vec<usize>>,
    grads: &mut Gradients,
) {
    for ((parent, grad), shape) in parents.zip(values).zip(shapes) {
        if let Some(id) = parent {
            grads.register::<Flex>(id, flex(grad, shape));
        }
    }
}

/// The padded layout's `[N, P]` and the block's widths.
fn dims(x: &Tensor<3>, h: usize, o: usize) -> ([usize; 2], BlockDims) {
    let [centers, points, d_in] = x.dims();
    let dims = BlockDims {
        d_in,
        d_hidden: h,
        d_out: o,
    };
    ([centers, points], dims)
}

/// The seven float inputs in order: x, γ₁, β₁, W₁, γ₂, β₂, W₂ (the mask is separate).
fn inputs(x: Tensor<3>, p: ParamTensors) -> [Tensor<1>; 7] {
    let flat = |t: Tensor<2>| {
        let n = t.shape().num_elements();
        t.reshape([n])
    };
    let n = x.shape().num_elements();
    [
        x.reshape([n]),
        p.gamma1,
        p.beta1,
        flat(p.w1),
        p.gamma2,
        p.beta2,
        flat(p.w2),
    ]
}

/// The evaluation forward (running statistics) on plain flex tensors.
///
/// # Shapes
/// - `x`: `[N, P, d]`, `mask`: `[N, P]`; output `[N, P, O]`
pub fn forward_eval(
    x: Tensor<3>,
    mask: Tensor<2>,
    params: ParamTensors,
    bn1: &BnStats,
    bn2: &BnStats,
) -> Option<Tensor<3>> {
    let [h, o] = params.w2.dims();
    let ([n, p], dims) = dims(&x, h, o);
    let eps = params.epsilon;
    let prims: Vec<FlexTensor> = inputs(x, params)
        .into_iter()
        .map(|t| t.try_into_primitive::<Flex>().ok().filter(|t| t.dtype() == DType::F32))
        .collect::<Option<_>>()?;
    let mask = mask.try_into_primitive::<Flex>().ok()?;
    let v: Vec<Cow<[f32]>> = prims.iter().map(values).collect();
    let params = block_params(&v, eps);
    let rows = Packed::from_mask(&values(&mask), p);
    let x = rows.pack(&v[0], dims.d_in);
    let (out, _) = kernel::forward(&x, &rows, params, dims, Normalization::Fixed { bn1, bn2 });
    let out = flex(rows.unpack(&out, dims.d_out, n * p), vec![n, p, dims.d_out]);
    Some(Tensor::from_primitive::<Flex>(out))
}

fn block_params<'a>(v: &'a [Cow<'a, [f32]>], epsilon: f32) -> BlockParams<'a> {
    BlockParams {
        gamma1: &v[1],
        beta1: &v[2],
        w1: &v[3],
        gamma2: &v[4],
        beta2: &v[5],
        w2: &v[6],
        epsilon,
    }
}

/// What the backward keeps of the forward.
#[derive(Debug, Clone)]
struct Saved {
    /// x, γ₁, β₁, W₁, γ₂, β₂, W₂ (flattened).
    inputs: Arc<Vec<FlexTensor>>,
    rows: Arc<Packed>,
    /// The real rows of x `[R, d]` and of the output `[R, O]`.
    x: Arc<Vec<f32>>,
    out: Arc<Vec<f32>>,
    dims: BlockDims,
    epsilon: f32,
    saved: Arc<BlockSaved>,
}

#[derive(Debug)]
struct FusedBlockBackward;

impl Backward<Flex, 7> for FusedBlockBackward {
    type State = Saved;

    fn backward(self, ops: Ops<Saved, 7>, grads: &mut Gradients, _: &mut Checkpointer) {
        let d_out = grads.consume::<Flex>(&ops.node);
        let s = ops.state;
        let v: Vec<Cow<[f32]>> = s.inputs.iter().map(values).collect();
        let fwd = Forward {
            out: &s.out,
            saved: &s.saved,
        };
        let params = block_params(&v, s.epsilon);
        let d_out = s.rows.pack(&values(&d_out), s.dims.d_out);
        let g = kernel::backward(&s.x, &s.rows, params, s.dims, fwd, &d_out);
        let shapes = s.inputs.iter().map(|t| t.layout().shape().to_vec());
        let dx = s.rows.unpack(&g.x, s.dims.d_in, v[0].len() / s.dims.d_in.max(1));
        let values = [dx, g.gamma1, g.beta1, g.w1, g.gamma2, g.beta2, g.w2];
        register_parents(
            ops.parents.iter().map(|p| p.as_ref().map(|n| n.id)),
            values,
            shapes,
            grads,
        );
    }
}

/// The training forward (batch statistics) on autodiff-flex tensors, as one graph node.
///
/// # Shapes
/// - `x`: `[N, P, d]` (≥ 0, zero in padded slots), `mask`: `[N, P]`; output `[N, P, O]`
pub fn forward_train(x: Tensor<3>, mask: Tensor<2>, params: ParamTensors) -> Option<TrainOutput> {
    let [h, o] = params.w2.dims();
    let ([n, p], dims) = dims(&x, h, o);
    let epsilon = params.epsilon;
    let ad: Vec<_> = inputs(x, params)
        .into_iter()
        .map(|t| t.try_into_primitive::<Autodiff<Flex>>().ok())
        .collect::<Option<_>>()?;
    let mask = mask.try_into_primitive::<Autodiff<Flex>>().ok()?.into_primitive();
    let (prims, guards): (Vec<FlexTensor>, Vec<_>) = ad.into_iter().map(|t| t.into_parts()).unzip();
    if prims.iter().any(|t| t.dtype() != DType::F32) {
        return None;
    }
    let v: Vec<Cow<[f32]>> = prims.iter().map(values).collect();
    let params = block_params(&v, epsilon);
    let rows = Packed::from_mask(&values(&mask), p);
    let x = rows.pack(&v[0], dims.d_in);
    let (out, saved) = kernel::forward(&x, &rows, params, dims, Normalization::Batch);
    let dense = flex(rows.unpack(&out, dims.d_out, n * p), vec![n, p, dims.d_out]);
    let (bn1, bn2) = (saved.bn1.clone(), saved.bn2.clone());
    drop(v);
    let guards: [_; 7] = guards.try_into().expect("seven inputs");
    let out = match FusedBlockBackward
        .prepare::<NoCheckpointing>(guards)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => {
            let saved = Arc::new(saved);
            let state = Saved {
                inputs: Arc::new(prims),
                rows: Arc::new(rows),
                x: Arc::new(x),
                out: Arc::new(out),
                dims,
                epsilon,
                saved,
            };
            prep.finish(state, dense)
        }
        OpsKind::UnTracked(prep) => prep.finish(dense),
    };
    Some(TrainOutput {
        out: Tensor::from_primitive::<Autodiff<Flex>>(out),
        stats: BlockStats { bn1, bn2 },
    })
}
