//! The projector's Linear and ReLU and the heads after it, forward and backward on raw f32
//! rows. The heads share one product, their weights side by side: each alone is a few columns
//! wide (4, 8 and 28 at the quickstart's settings), where a product runs far below its speed,
//! and nothing between the layers goes back to Burn.

use super::gemm::{Mat, Op, matmul_new, matmul_tn};
use super::kernel::{column_sums, relu_backward_sum};
use super::rows::{add, for_rows, relu};

/// The sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeadDims {
    /// Input rows M (B · C).
    pub rows: usize,
    /// Input width c (the cell feature's).
    pub d_in: usize,
    /// Grid offsets G².
    pub offsets: usize,
    /// Per-offset feature width D.
    pub d_offset: usize,
    /// The heads' outputs side by side, K.
    pub d_out: usize,
}

impl HeadDims {
    /// The projector's output width G² · D.
    fn d_proj(&self) -> usize {
        self.offsets * self.d_offset
    }

    /// Rows of the heads' product, M · G².
    fn head_rows(&self) -> usize {
        self.rows * self.offsets
    }
}

/// The parameters, in Burn's layouts.
#[derive(Debug, Clone, Copy)]
pub struct HeadParams<'a> {
    /// The projector's weight `[c, G²·D]`.
    pub w_proj: &'a [f32],
    /// The projector's bias `[G²·D]`.
    pub b_proj: &'a [f32],
    /// The heads' weights side by side `[D, K]`.
    pub w_heads: &'a [f32],
    /// The heads' biases side by side `[K]`.
    pub b_heads: &'a [f32],
}

/// Gradients with respect to the input and the parameters (shapes as theirs).
#[derive(Debug, Clone)]
pub struct HeadGrads {
    /// `[M, c]`.
    pub x: Vec<f32>,
    /// `[c, G²·D]`.
    pub w_proj: Vec<f32>,
    /// `[G²·D]`.
    pub b_proj: Vec<f32>,
    /// `[D, K]`.
    pub w_heads: Vec<f32>,
    /// `[K]`.
    pub b_heads: Vec<f32>,
}

/// The forward: the heads' outputs `[M·G², K]`, and the projector's ReLU output `[M·G², D]`
/// (the same values as `[M, G²·D]`), which the backward needs.
///
/// # Shapes
/// - `x`: `[M, c]`
pub fn forward(x: &[f32], p: HeadParams, dims: HeadDims) -> (Vec<f32>, Vec<f32>) {
    let (gd, k) = (dims.d_proj(), dims.d_out);
    let mut f = matmul_new(
        Mat::new(x, dims.rows, dims.d_in),
        Op::N,
        Mat::new(p.w_proj, dims.d_in, gd),
        Op::N,
    );
    for_rows(&mut f, gd, |_, row| {
        row.iter_mut().zip(p.b_proj).for_each(|(v, b)| *v = relu(*v + b));
    });
    let features = Mat::new(&f, dims.head_rows(), dims.d_offset);
    let mut z = matmul_new(features, Op::N, Mat::new(p.w_heads, dims.d_offset, k), Op::N);
    for_rows(&mut z, k, |_, row| add(row, p.b_heads));
    (z, f)
}

/// The backward of [`forward`], from the outputs' gradient `dz` `[M·G², K]`; `f` is the
/// forward's projector output.
pub fn backward(x: &[f32], p: HeadParams, dims: HeadDims, f: &[f32], dz: &[f32]) -> HeadGrads {
    let (gd, k, d) = (dims.d_proj(), dims.d_out, dims.d_offset);
    let dz_mat = Mat::new(dz, dims.head_rows(), k);
    let b_heads = column_sums(dz, k);
    let w_heads = matmul_tn(Mat::new(f, dims.head_rows(), d), dz_mat);
    let mut df = matmul_new(dz_mat, Op::N, Mat::new(p.w_heads, d, k), Op::T);
    let b_proj = relu_backward_sum(&mut df, f, gd);
    let df = Mat::new(&df, dims.rows, gd);
    let w_proj = matmul_tn(Mat::new(x, dims.rows, dims.d_in), df);
    let x = matmul_new(df, Op::N, Mat::new(p.w_proj, dims.d_in, gd), Op::T);
    HeadGrads {
        x,
        w_proj,
        b_proj,
        w_heads,
        b_heads,
    }
}
