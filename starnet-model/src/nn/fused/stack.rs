//! The whole featurizer on raw f32 rows: fc0 (Linear + ReLU), the StarNet blocks
//! ([`super::kernel`]) and the readout (each layer's mean over a center's real points,
//! concatenated), forward and backward as one operation. Nothing between the layers goes back
//! to Burn: the readout's gradient is added to each layer's output gradient in place instead of
//! being broadcast to a tensor of its own, and fc0's bias and ReLU cost no pass of their own.

use super::gemm::{Mat, Op, matmul_new, matmul_tn};
use super::kernel::{self, BlockDims, BlockGrads, BlockParams, BlockSaved, Forward, Normalization, relu_backward_sum};
use super::packed::Packed;
use super::rows::{add, add_scaled, for_rows, relu};

/// The featurizer's widths.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StackDims {
    /// Per-point input features F.
    pub d_input: usize,
    /// fc0's width d0.
    pub d_fc0: usize,
    /// Per block, `[hidden, output]`.
    pub blocks: Vec<[usize; 2]>,
}

impl StackDims {
    /// Width of every layer's output, fc0 first: the readout's pieces.
    pub fn widths(&self) -> Vec<usize> {
        std::iter::once(self.d_fc0)
            .chain(self.blocks.iter().map(|b| b[1]))
            .collect()
    }

    /// Width of the cell feature (the widths' sum).
    pub fn cell_dim(&self) -> usize {
        self.widths().iter().sum()
    }

    fn block(&self, k: usize) -> BlockDims {
        let [d_hidden, d_out] = self.blocks[k];
        BlockDims {
            d_in: self.widths()[k],
            d_hidden,
            d_out,
        }
    }
}

/// The featurizer's parameters, in Burn's layouts.
#[derive(Debug, Clone)]
pub struct StackParams<'a> {
    /// fc0's weight `[F, d0]`.
    pub w0: &'a [f32],
    /// fc0's bias `[d0]`.
    pub b0: &'a [f32],
    /// Each block's.
    pub blocks: Vec<BlockParams<'a>>,
}

/// What the forward keeps for the backward.
#[derive(Debug, Clone)]
pub struct StackSaved {
    /// Every layer's output `[R, width]`, fc0's first.
    pub outputs: Vec<Vec<f32>>,
    /// Each block's own.
    pub blocks: Vec<BlockSaved>,
}

/// Gradients with respect to the input and every parameter.
#[derive(Debug, Clone)]
pub struct StackGrads {
    /// `[R, F]`.
    pub x: Vec<f32>,
    /// `[F, d0]`.
    pub w0: Vec<f32>,
    /// `[d0]`.
    pub b0: Vec<f32>,
    /// Each block's (its `x`, the previous layer's gradient, moved on: empty).
    pub blocks: Vec<BlockGrads>,
}

/// `1 / max(real points, 1)` per center: the readout's divisor.
fn inverse_counts(rows: &Packed) -> Vec<f32> {
    rows.counts().into_iter().map(|c| 1.0 / c.max(1.0)).collect()
}

/// fc0: `relu(x W₀ + b₀)` `[R, d0]`.
fn fc0(x: &[f32], rows: &Packed, w0: &[f32], b0: &[f32], dims: &StackDims) -> Vec<f32> {
    let (f, d0) = (dims.d_input, dims.d_fc0);
    let mut h = matmul_new(Mat::new(x, rows.rows(), f), Op::N, Mat::new(w0, f, d0), Op::N);
    for_rows(&mut h, d0, |_, row| {
        row.iter_mut().zip(b0).for_each(|(v, b)| *v = relu(*v + b));
    });
    h
}

/// Writes each center's mean of `h` (`[R, w]`) into columns `from..from + w` of `cell`.
fn read_out(cell: &mut [f32], h: &[f32], from: usize, inv: &[f32], rows: &Packed, cell_dim: usize) {
    let w = h.len() / rows.rows().max(1);
    for_rows(cell, cell_dim, |n, row| {
        let out = &mut row[from..from + w];
        for r in rows.range(n) {
            add(out, &h[r * w..(r + 1) * w]);
        }
        out.iter_mut().for_each(|v| *v *= inv[n]);
    });
}

/// The training (`norms` all [`Normalization::Batch`]) or evaluation forward.
///
/// # Shapes
/// - `x`: `[R, F]`, the rows of `rows`; `norms`: one per block
/// - returns the cell features `[N, cell_dim]` and what the backward needs
pub fn forward(
    x: &[f32],
    rows: &Packed,
    params: &StackParams,
    dims: &StackDims,
    norms: &[Normalization],
) -> (Vec<f32>, StackSaved) {
    let (inv, cell_dim) = (inverse_counts(rows), dims.cell_dim());
    let mut cell = vec![0.0; rows.centers() * cell_dim];
    let mut outputs = vec![fc0(x, rows, params.w0, params.b0, dims)];
    let mut blocks = Vec::with_capacity(dims.blocks.len());
    let mut from = 0;
    for (k, (bp, norm)) in params.blocks.iter().zip(norms).enumerate() {
        let input = &outputs[k];
        read_out(&mut cell, input, from, &inv, rows, cell_dim);
        from += dims.widths()[k];
        let (out, saved) = kernel::forward(input, rows, *bp, dims.block(k), *norm);
        outputs.push(out);
        blocks.push(saved);
    }
    read_out(
        &mut cell,
        outputs.last().expect("fc0's output"),
        from,
        &inv,
        rows,
        cell_dim,
    );
    (cell, StackSaved { outputs, blocks })
}

/// `grad += ` each row's share of its center's readout gradient (columns `from..` of `d_cell`).
fn add_readout_grad(grad: &mut [f32], d_cell: &[f32], from: usize, inv: &[f32], rows: &Packed, cell_dim: usize) {
    let w = grad.len() / rows.rows().max(1);
    for_rows(grad, w, |r, row| {
        let n = rows.center_of(r);
        add_scaled(row, &d_cell[n * cell_dim + from..n * cell_dim + from + w], inv[n]);
    });
}

/// The backward of the training forward.
///
/// # Shapes
/// - `x`, `rows`: as in [`forward`]; `saved`: its; `d_cell`: `[N, cell_dim]`
pub fn backward(
    x: &[f32],
    rows: &Packed,
    params: &StackParams,
    dims: &StackDims,
    saved: &StackSaved,
    d_cell: &[f32],
) -> StackGrads {
    let (inv, cell_dim) = (inverse_counts(rows), dims.cell_dim());
    let widths = dims.widths();
    let offsets: Vec<usize> = widths
        .iter()
        .scan(0, |at, w| Some(std::mem::replace(at, *at + w)))
        .collect();
    let last = dims.blocks.len();
    let mut grad = vec![0.0; rows.rows() * widths[last]];
    add_readout_grad(&mut grad, d_cell, offsets[last], &inv, rows, cell_dim);
    let mut blocks = Vec::with_capacity(last);
    for k in (0..last).rev() {
        let fwd = Forward {
            out: &saved.outputs[k + 1],
            saved: &saved.blocks[k],
        };
        let mut g = kernel::backward(&saved.outputs[k], rows, params.blocks[k], dims.block(k), fwd, &grad);
        grad = std::mem::take(&mut g.x);
        add_readout_grad(&mut grad, d_cell, offsets[k], &inv, rows, cell_dim);
        blocks.push(g);
    }
    blocks.reverse();
    let (w0, b0, x) = fc0_backward(x, params.w0, &saved.outputs[0], grad, dims);
    StackGrads { x, w0, b0, blocks }
}

/// fc0's `(dW₀, db₀, dx)` from its output's gradient.
fn fc0_backward(
    x: &[f32],
    w0: &[f32],
    h0: &[f32],
    mut grad: Vec<f32>,
    dims: &StackDims,
) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let (f, d0) = (dims.d_input, dims.d_fc0);
    let rows = h0.len() / d0.max(1);
    // The ReLU passes a gradient only where h₀ > 0.
    let b0 = relu_backward_sum(&mut grad, h0, d0);
    let dz = Mat::new(&grad, rows, d0);
    let w = matmul_tn(Mat::new(x, rows, f), dz);
    let dx = matmul_new(dz, Op::N, Mat::new(w0, f, d0), Op::T);
    (w, b0, dx)
}
