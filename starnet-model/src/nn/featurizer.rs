//! The featurizer (paper §3.2, lingvo `starnet.ModelV2`): fc0 (Linear + ReLU, no BN), a stack of
//! StarNet blocks, and a readout concatenating the masked mean over P of fc0's output and of
//! every block's output into one cell feature per center.

use super::{MaskedBatchNorm, StarNetBlock, StarNetBlockConfig, linear};
use burn::module::Module;
use burn::nn::Linear;
use burn::prelude::*;
use burn::tensor::activation::relu;

/// Configuration of the [`Featurizer`].
#[derive(Config, Debug)]
pub struct FeaturizerConfig {
    /// Per-point input features F (4: dx, dy, dz, reflectance).
    #[config(default = 4)]
    pub d_input: usize,
    /// Width of fc0, d0.
    pub d_fc0: usize,
    /// Per block, `[hidden, output]` widths.
    pub blocks: Vec<[usize; 2]>,
    /// Run the blocks as the fused operation where the backend allows it (flex, f32); off:
    /// the composed Burn operations everywhere (the reference).
    #[config(default = true)]
    pub fused: bool,
}

impl FeaturizerConfig {
    /// The paper's Waymo featurizer: d0 = 64, five blocks 128 → 256 → 64, cell feature 384.
    pub fn paper() -> Self {
        Self::new(64, vec![[256, 64]; 5])
    }

    /// A CPU-sized featurizer for the quickstart: d0 = 32, three blocks 64 → 64 → 32, cell 128.
    pub fn small() -> Self {
        Self::new(32, vec![[64, 32]; 3])
    }

    /// Width of the cell feature: d0 plus every block's output.
    pub fn cell_dim(&self) -> usize {
        self.d_fc0 + self.blocks.iter().map(|b| b[1]).sum::<usize>()
    }

    /// Builds the featurizer.
    pub fn init(&self, device: &Device) -> Featurizer {
        let mut d = self.d_fc0;
        let blocks = self
            .blocks
            .iter()
            .map(|&[hidden, out]| {
                let b = StarNetBlockConfig::new(d, hidden, out)
                    .with_fused(self.fused)
                    .init(device);
                d = out;
                b
            })
            .collect();
        Featurizer {
            fc0: linear(self.d_input, self.d_fc0, true, device),
            blocks,
        }
    }
}

/// Point features to cell features.
#[derive(Module, Debug)]
pub struct Featurizer {
    fc0: Linear,
    blocks: Vec<StarNetBlock>,
}

impl Featurizer {
    /// The blocks' BatchNorms, in order.
    pub fn batch_norms(&self) -> Vec<&MaskedBatchNorm> {
        self.blocks.iter().flat_map(StarNetBlock::batch_norms).collect()
    }

    /// # Shapes
    /// - `points`: `[B, C, P, F]`
    /// - `mask`: `[B, C, P]` (1.0 real, 0.0 padded)
    /// - output: `[B, C, cell_dim]`
    pub fn forward(&self, points: Tensor<4>, mask: Tensor<3>) -> Tensor<3> {
        let [b, c, p, f] = points.dims();
        let m = mask.reshape([b * c, p, 1]);
        // fc0 has a bias: zero the padded rows so every later max and mean can ignore them.
        let mut h = relu(self.fc0.forward(points.reshape([b * c, p, f]))) * m.clone(); // [BC, P, d0]
        // Every h is zero in padded rows (fc0's by the mask, a block's because its BatchNorm
        // zeroes them and its Linears have no bias), so the masked mean needs no mask product:
        // the sum over P divided by the real-point count, counted once.
        let count = m.clone().sum_dim(1).clamp_min(1.0); // [BC, 1, 1]
        let mean = |h: &Tensor<3>| h.clone().sum_dim(1) / count.clone();
        let mut readout = vec![mean(&h)];
        for block in &self.blocks {
            h = block.forward(h, m.clone());
            readout.push(mean(&h));
        }
        let cell = Tensor::cat(readout, 2); // [BC, 1, cell]
        let [_, _, d] = cell.dims();
        cell.reshape([b, c, d])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use rand::{Rng, SeedableRng};

    /// One center with `real` points of `p` slots; padded slots hold `junk`.
    fn center(pts: &[[f32; 4]], p: usize, junk: f32, dev: &Device) -> (Tensor<4>, Tensor<3>) {
        let mut data = Vec::new();
        let mut mask = Vec::new();
        for i in 0..p {
            data.extend_from_slice(&pts.get(i).copied().unwrap_or([junk; 4]));
            mask.push(if i < pts.len() { 1.0 } else { 0.0 });
        }
        (
            Tensor::<1>::from_floats(data.as_slice(), dev).reshape([1, 1, p, 4]),
            Tensor::<1>::from_floats(mask.as_slice(), dev).reshape([1, 1, p]),
        )
    }

    fn feature(f: &Featurizer, pts: &[[f32; 4]], p: usize, junk: f32, dev: &Device) -> Vec<f32> {
        let (x, m) = center(pts, p, junk, dev);
        f.forward(x, m).into_data().iter::<f32>().collect()
    }

    #[test]
    fn eval_features_ignore_order_padding_values_and_padding_length() {
        // A plain (non-autodiff) device: BatchNorm uses its running statistics.
        let dev = default_device();
        let f = FeaturizerConfig::small().init(&dev);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let pts: Vec<[f32; 4]> = (0..32)
            .map(|_| std::array::from_fn(|_| rng.random_range(-2.0..2.0)))
            .collect();
        let base = feature(&f, &pts, 32, 0.0, &dev);
        assert_eq!(base.len(), FeaturizerConfig::small().cell_dim());
        assert!(base.iter().any(|v| *v != 0.0));
        let close = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-5 * x.abs().max(1.0));
        let mut shuffled = pts.clone();
        shuffled.reverse();
        shuffled.swap(3, 17);
        assert!(
            close(&base, &feature(&f, &shuffled, 32, 0.0, &dev)),
            "permutation changed the feature"
        );
        let padded = feature(&f, &pts, 64, 0.0, &dev);
        assert!(close(&base, &padded), "padding to 64 changed the feature");
        assert!(
            close(&padded, &feature(&f, &pts, 64, 1e4, &dev)),
            "values in padded slots leaked in"
        );
    }
}
