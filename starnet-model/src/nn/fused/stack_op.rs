//! The fused featurizer ([`super::stack`]) as one Burn operation on flex: the training forward
//! records a single autodiff node for fc0, every block and the readout, whose parameters enter
//! as one flat tensor (Burn's concatenation hands each parameter its slice of the gradient);
//! the evaluation forward runs on plain flex tensors. Both pack the real points first
//! ([`Packed`]), so padded slots cost nothing. Both return `None` when the tensors live
//! elsewhere, and the caller then takes the block-by-block path.

use super::kernel::{BlockParams, BlockStats, Normalization};
use super::op::ParamTensors;
use super::packed::Packed;
use super::stack::{self, StackDims, StackGrads, StackParams, StackSaved};
use crate::flex_data::{flex, values};
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::flex::FlexTensor;
use burn::backend::{Autodiff, Flex};
use burn::prelude::*;
use burn::tensor::DType;
use std::sync::Arc;

/// The featurizer's parameter tensors.
#[derive(Debug, Clone)]
pub struct StackTensors {
    /// fc0's weight `[F, d0]`.
    pub w0: Tensor<2>,
    /// fc0's bias `[d0]`.
    pub b0: Tensor<1>,
    /// Each block's.
    pub blocks: Vec<ParamTensors>,
}

/// A training forward's result.
#[derive(Debug)]
pub struct StackTrainOutput {
    /// The cell features `[N, cell_dim]`.
    pub cell: Tensor<2>,
    /// Each block's batch statistics, for the running averages.
    pub stats: Vec<BlockStats>,
}

impl StackTensors {
    fn dims(&self) -> StackDims {
        let [d_input, d_fc0] = self.w0.dims();
        StackDims {
            d_input,
            d_fc0,
            blocks: self.blocks.iter().map(|b| b.w2.dims()).collect(),
        }
    }

    /// Every parameter flattened into one vector, in the order [`split`] reads.
    fn flat(self) -> (Tensor<1>, Vec<f32>) {
        let flat = |t: Tensor<2>| {
            let n = t.shape().num_elements();
            t.reshape([n])
        };
        let epsilons = self.blocks.iter().map(|b| b.epsilon).collect();
        let mut parts = vec![flat(self.w0), self.b0];
        for b in self.blocks {
            parts.extend([b.gamma1, b.beta1, flat(b.w1), b.gamma2, b.beta2, flat(b.w2)]);
        }
        (Tensor::cat(parts, 0), epsilons)
    }
}

/// The sizes of the flat parameter vector's pieces, in order: W₀, b₀, then per block γ₁, β₁,
/// W₁, γ₂, β₂, W₂.
fn piece_sizes(dims: &StackDims) -> Vec<usize> {
    let mut sizes = vec![dims.d_input * dims.d_fc0, dims.d_fc0];
    for (k, &[h, o]) in dims.blocks.iter().enumerate() {
        let d2 = 2 * dims.widths()[k];
        sizes.extend([d2, d2, d2 * h, h, h, h * o]);
    }
    sizes
}

/// The parameters as slices of the flat vector.
fn split<'a>(flat: &'a [f32], dims: &StackDims, epsilons: &[f32]) -> StackParams<'a> {
    let mut rest = flat;
    let mut pieces = piece_sizes(dims).into_iter().map(|n| {
        let (piece, tail) = rest.split_at(n);
        rest = tail;
        piece
    });
    let mut next = || pieces.next().expect("a piece per parameter");
    let (w0, b0) = (next(), next());
    let blocks = epsilons
        .iter()
        .map(|&epsilon| BlockParams {
            gamma1: next(),
            beta1: next(),
            w1: next(),
            gamma2: next(),
            beta2: next(),
            w2: next(),
            epsilon,
        })
        .collect();
    StackParams { w0, b0, blocks }
}

/// The gradients laid out as the flat parameter vector.
fn flat_grads(g: StackGrads) -> Vec<f32> {
    let mut flat = g.w0;
    flat.extend(g.b0);
    for b in g.blocks {
        for part in [b.gamma1, b.beta1, b.w1, b.gamma2, b.beta2, b.w2] {
            flat.extend(part);
        }
    }
    flat
}

/// What the backward keeps of the forward.
#[derive(Debug, Clone)]
struct Saved {
    /// The real points, packed `[R, F]`.
    x: Arc<Vec<f32>>,
    rows: Arc<Packed>,
    /// The points' shape `[N, P, F]`.
    shape: [usize; 3],
    flat: FlexTensor,
    dims: StackDims,
    epsilons: Vec<f32>,
    saved: Arc<StackSaved>,
}

#[derive(Debug)]
struct StackBackward;

impl Backward<Flex, 2> for StackBackward {
    type State = Saved;

    fn backward(self, ops: Ops<Saved, 2>, grads: &mut Gradients, _: &mut Checkpointer) {
        let d_cell = grads.consume::<Flex>(&ops.node);
        let s = ops.state;
        let flat_values = values(&s.flat);
        let params = split(&flat_values, &s.dims, &s.epsilons);
        let mut g = stack::backward(&s.x, &s.rows, &params, &s.dims, &s.saved, &values(&d_cell));
        let [points, flat] = ops.parents;
        if let Some(node) = points {
            let [n, p, f] = s.shape;
            let dx = s.rows.unpack(&std::mem::take(&mut g.x), f, n * p);
            grads.register::<Flex>(node.id, flex(dx, vec![n * p * f]));
        }
        if let Some(node) = flat {
            let g = flat_grads(g);
            let n = g.len();
            grads.register::<Flex>(node.id, flex(g, vec![n]));
        }
    }
}

/// The training forward (batch statistics) on autodiff-flex tensors, as one graph node.
///
/// # Shapes
/// - `points`: `[N, P, F]`, `mask`: `[N, P]` (1.0 real, 0.0 padded); output `[N, cell_dim]`
pub fn forward_train(points: Tensor<3>, mask: Tensor<2>, params: StackTensors) -> Option<StackTrainOutput> {
    let [n, p, f] = points.dims();
    let dims = params.dims();
    let (flat, epsilons) = params.flat();
    let ad = [points.reshape([n * p * f]), flat].map(|t| t.try_into_primitive::<Autodiff<Flex>>().ok());
    let [Some(x), Some(flat)] = ad else { return None };
    let mask = mask.try_into_primitive::<Autodiff<Flex>>().ok()?.into_primitive();
    let ((x, gx), (flat, gf)) = (x.into_parts(), flat.into_parts());
    if x.dtype() != DType::F32 || flat.dtype() != DType::F32 {
        return None;
    }
    let rows = Packed::from_mask(&values(&mask), p);
    let x = rows.pack(&values(&x), f);
    let norms = vec![Normalization::Batch; dims.blocks.len()];
    let (cell, saved) = stack::forward(&x, &rows, &split(&values(&flat), &dims, &epsilons), &dims, &norms);
    let stats = saved
        .blocks
        .iter()
        .map(|b| BlockStats {
            bn1: b.bn1.clone(),
            bn2: b.bn2.clone(),
        })
        .collect();
    let out = flex(cell, vec![n, dims.cell_dim()]);
    let out = match StackBackward
        .prepare::<NoCheckpointing>([gx, gf])
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => {
            let state = Saved {
                x: Arc::new(x),
                rows: Arc::new(rows),
                shape: [n, p, f],
                flat,
                dims,
                epsilons,
                saved: Arc::new(saved),
            };
            prep.finish(state, out)
        }
        OpsKind::UnTracked(prep) => prep.finish(out),
    };
    Some(StackTrainOutput {
        cell: Tensor::from_primitive::<Autodiff<Flex>>(out),
        stats,
    })
}

/// The evaluation forward (each block's running statistics) on plain flex tensors.
///
/// # Shapes
/// - `points`: `[N, P, F]`, `mask`: `[N, P]`; output `[N, cell_dim]`
pub fn forward_eval(
    points: Tensor<3>,
    mask: Tensor<2>,
    params: StackTensors,
    running: &[BlockStats],
) -> Option<Tensor<2>> {
    let [n, p, f] = points.dims();
    let dims = params.dims();
    let (flat, epsilons) = params.flat();
    let x = points.reshape([n * p * f]).try_into_primitive::<Flex>().ok()?;
    let flat = flat.try_into_primitive::<Flex>().ok()?;
    if x.dtype() != DType::F32 || flat.dtype() != DType::F32 {
        return None;
    }
    let mask = mask.try_into_primitive::<Flex>().ok()?;
    let norms: Vec<Normalization> = running
        .iter()
        .map(|s| Normalization::Fixed {
            bn1: &s.bn1,
            bn2: &s.bn2,
        })
        .collect();
    let rows = Packed::from_mask(&values(&mask), p);
    let fv = values(&flat);
    let (cell, _) = stack::forward(
        &rows.pack(&values(&x), f),
        &rows,
        &split(&fv, &dims, &epsilons),
        &dims,
        &norms,
    );
    Some(Tensor::from_primitive::<Flex>(flex(cell, vec![n, dims.cell_dim()])))
}
