//! The StarNet block (lingvo `builder_lib._GIN`, paper §3.2): every point's feature is joined
//! with the max over its neighbourhood, then passes two layers of BN → Linear (no bias) → ReLU.

use super::{MaskedBatchNorm, MaskedBatchNormConfig, linear};
use burn::module::Module;
use burn::nn::Linear;
use burn::prelude::*;
use burn::tensor::activation::relu;

/// Max over the points of each neighbourhood. Inputs are ReLU outputs with padded rows zeroed
/// (every layer here keeps them so), so a plain max of `f · mask` ignores padding, and a fully
/// padded neighbourhood gives 0, as in lingvo.
///
/// # Shapes
/// - `f`: `[B·C, P, D]`, `mask`: `[B·C, P, 1]` (1.0 real, 0.0 padded)
/// - output: `[B·C, 1, D]`
pub fn masked_max(f: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
    (f * mask).max_dim(1)
}

/// Mean over the real points of each neighbourhood (0 if there is none).
///
/// # Shapes
/// - `f`: `[B·C, P, D]`, `mask`: `[B·C, P, 1]`
/// - output: `[B·C, 1, D]`
pub fn masked_mean(f: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
    (f * mask.clone()).sum_dim(1) / mask.sum_dim(1).clamp_min(1.0)
}

/// Configuration of a [`StarNetBlock`].
#[derive(Config, Debug)]
pub struct StarNetBlockConfig {
    /// Per-point input width d.
    pub d_input: usize,
    /// Hidden width (the first layer maps 2d to it).
    pub d_hidden: usize,
    /// Output width.
    pub d_output: usize,
}

/// One StarNet block.
#[derive(Module, Debug)]
pub struct StarNetBlock {
    bn1: MaskedBatchNorm,
    fc1: Linear,
    bn2: MaskedBatchNorm,
    fc2: Linear,
}

impl StarNetBlockConfig {
    /// Builds the block.
    pub fn init(&self, device: &Device) -> StarNetBlock {
        StarNetBlock {
            bn1: MaskedBatchNormConfig::new(2 * self.d_input).init(device),
            fc1: linear(2 * self.d_input, self.d_hidden, false, device),
            bn2: MaskedBatchNormConfig::new(self.d_hidden).init(device),
            fc2: linear(self.d_hidden, self.d_output, false, device),
        }
    }
}

impl StarNetBlock {
    /// # Shapes
    /// - `f`: `[B·C, P, d]` (ReLU outputs, zero in padded rows)
    /// - `mask`: `[B·C, P, 1]`
    /// - output: `[B·C, P, d_output]`, zero in padded rows
    pub fn forward(&self, f: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
        let [bc, p, d] = f.dims();
        let pooled = masked_max(f.clone(), mask.clone()).expand([bc, p, d]);
        let g = Tensor::cat(vec![f, pooled], 2).reshape([bc * p, 2 * d]); // [N, 2d]
        let m = mask.reshape([bc * p, 1]);
        // BN zeroes padded rows and the linear layers have no bias, so padding stays 0.
        let h = relu(self.fc1.forward(self.bn1.forward(g, m.clone())));
        let h = relu(self.fc2.forward(self.bn2.forward(h, m)));
        let [_, out] = h.dims();
        h.reshape([bc, p, out])
    }
}
