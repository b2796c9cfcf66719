//! The featurizer (paper §3.2, lingvo `starnet.ModelV2`): fc0 (Linear + ReLU, no BN), a stack of
//! StarNet blocks, and a readout concatenating the masked mean over P of fc0's output and of
//! every block's output into one cell feature per center.

use super::fused::stack_op::{self, StackTensors};
use super::row_layout::{self, RowLayout};
use super::{Bias, MaskedBatchNorm, StarNetBlock, StarNetBlockConfig, linear};
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
    /// Run the featurizer (fc0, the blocks, the readout) as one fused operation where the
    /// backend allows it (flex, f32), and [`crate::nn::StarNet`]'s projector and heads as
    /// another; off: the composed Burn operations everywhere (the reference).
    #[config(default = true)]
    pub fused: bool,
    /// How the composed layers lay out a batch's rows ([`RowLayout`]; the fused ones need none).
    #[config(default = "RowLayout::Auto")]
    pub rows: RowLayout,
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
                    .with_rows(self.rows)
                    .init(device);
                d = out;
                b
            })
            .collect();
        Featurizer {
            fc0: linear(self.d_input, self.d_fc0, Bias::Zero, device),
            blocks,
            rows: self.rows,
        }
    }
}

/// Point features to cell features.
#[derive(Module, Debug)]
pub struct Featurizer {
    fc0: Linear,
    blocks: Vec<StarNetBlock>,
    #[module(skip)]
    rows: RowLayout,
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
        if let Some(cell) = self.forward_fused(points.clone(), mask.clone()) {
            return cell;
        }
        self.forward_composed(points, mask)
    }

    /// Whether the featurizer runs as one fused operation on flex (every block is fused); the
    /// projector and heads then run fused too.
    pub fn is_fused(&self) -> bool {
        !self.blocks.is_empty() && self.blocks.iter().all(StarNetBlock::is_fused)
    }

    /// The whole featurizer as one fused operation, or `None` where it does not apply (a block
    /// not fused, no block, another backend, an autodiff device with the training flag off).
    fn forward_fused(&self, points: Tensor<4>, mask: Tensor<3>) -> Option<Tensor<3>> {
        let first = self.blocks.first()?;
        if !self.blocks.iter().all(StarNetBlock::is_fused) {
            return None;
        }
        let [b, c, p, f] = points.dims();
        let (points, mask) = (points.reshape([b * c, p, f]), mask.reshape([b * c, p]));
        let device = points.device();
        let params = StackTensors {
            w0: self.fc0.weight.val(),
            b0: self.fc0.bias.as_ref()?.val(),
            blocks: self.blocks.iter().map(StarNetBlock::param_tensors).collect(),
        };
        let cell = if first.batch_norms()[0].uses_batch_statistics(&device) {
            let out = stack_op::forward_train(points, mask, params)?;
            self.blocks
                .iter()
                .zip(out.stats)
                .for_each(|(k, s)| k.record_batch_stats(s));
            out.cell
        } else if !device.is_autodiff() {
            let running: Vec<_> = self.blocks.iter().map(StarNetBlock::running_stats).collect();
            stack_op::forward_eval(points, mask, params, &running)?
        } else {
            return None;
        };
        let [_, d] = cell.dims();
        Some(cell.reshape([b, c, d]))
    }

    /// fc0, the blocks and the readout as Burn tensor operations, block by block (each block
    /// fused or not as it is configured).
    ///
    /// # Shapes
    /// As [`Self::forward`].
    pub fn forward_composed(&self, points: Tensor<4>, mask: Tensor<3>) -> Tensor<3> {
        let [b, c, p, f] = points.dims();
        let m = mask.reshape([b * c, p, 1]);
        // fc0 has a bias: zero the padded rows so every later max and mean can ignore them.
        let g = self.rows.groups(b * c * p, &points.device());
        let h = relu(row_layout::linear(&self.fc0, points.reshape([g.groups, g.rows, f]))); // [G, R, d0]
        let [_, _, d0] = h.dims();
        let mut h = h.reshape([b * c, p, d0]) * m.clone(); // [BC, P, d0]
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
    use crate::testing;
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

    /// Moves every parameter and running statistic off its initial value, by a seeded amount
    /// (variances stay positive: at least 0.4 of their start). Randomly initialised weights are
    /// first redrawn from the seed (Kaiming-uniform, as `linear` draws them), so the values do not depend on
    /// the device's shared generator, which tests running beside this one draw from too: with
    /// weights that changed from run to run, the fused and composed gradients (equal in exact
    /// arithmetic) drifted apart past the tolerance now and then.
    struct Perturb(rand_chacha::ChaCha8Rng);

    impl burn::module::ModuleMapper for Perturb {
        fn map_float<const D: usize>(
            &mut self,
            param: burn::module::Param<Tensor<D>>,
        ) -> burn::module::Param<Tensor<D>> {
            let rng = &mut self.0;
            param.map(|t| {
                let (shape, dev, is_param) = (t.shape(), t.device(), t.is_require_grad());
                let v: Vec<f32> = t.into_data().iter::<f32>().collect();
                let drawn = v.iter().any(|x| *x != v[0]);
                let v: Vec<f32> = if drawn {
                    let bound = (6.0 / shape.dims::<D>()[0] as f32).sqrt();
                    v.iter().map(|_| rng.random_range(-bound..bound)).collect()
                } else {
                    v
                };
                let v: Vec<f32> = v
                    .iter()
                    .map(|x| x * (1.0 + rng.random_range(-0.4..0.4)) + rng.random_range(-0.2..0.2))
                    .collect();
                let moved = Tensor::<1>::from_floats(v.as_slice(), &dev).reshape(shape);
                if is_param { moved.require_grad() } else { moved }
            })
        }
    }

    /// Every parameter's gradient, in visiting order.
    struct Grads<'a>(&'a burn::tensor::Gradients, Vec<Vec<f32>>);

    impl burn::module::ModuleVisitor for Grads<'_> {
        fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<Tensor<D>>) {
            if let Some(g) = param.val().grad(self.0) {
                self.1.push(g.into_data().iter::<f32>().collect());
            }
        }
    }

    /// `a` within 1e-4 of `b`, relative to `b`'s largest magnitude.
    fn assert_close(a: &[f32], b: &[f32], what: &str) {
        assert_eq!(a.len(), b.len(), "{what}: lengths");
        let scale = b.iter().fold(1e-6f32, |m, v| m.max(v.abs()));
        let worst = a.iter().zip(b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= 1e-4 * scale,
            "{what}: max |fused − composed| {worst} against scale {scale}"
        );
    }

    /// One training step's features, gradients and running statistics, the whole featurizer as
    /// one fused operation against the composed blocks. `real[n]`: real points of center n.
    fn check_fused_training(cfg: FeaturizerConfig, p: usize, real: &[usize], seed: u64) {
        let dev = default_device().autodiff();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let fused = cfg
            .init(&dev)
            .map(&mut Perturb(rand_chacha::ChaCha8Rng::seed_from_u64(seed)));
        let mut composed = fused.clone();
        composed.blocks.iter_mut().for_each(|b| b.set_fused(false));
        let n = real.len();
        let x = testing::uniform([1, n, p, cfg.d_input], -2.0, 2.0, &mut rng, &dev);
        let m: Vec<f32> = real
            .iter()
            .flat_map(|&r| (0..p).map(move |s| f32::from(s < r)))
            .collect();
        let m = Tensor::<1>::from_floats(m.as_slice(), &dev).reshape([1, n, p]);
        let cot = testing::uniform([1, n, cfg.cell_dim()], -1.0, 1.0, &mut rng, &dev);
        assert!(
            fused.forward_fused(x.clone(), m.clone()).is_some(),
            "the fused path must run"
        );
        let run = |f: &Featurizer| {
            let cell = f.forward(x.clone(), m.clone());
            let grads = (cell.clone() * cot.clone()).sum().backward();
            let mut g = Grads(&grads, Vec::new());
            f.visit(&mut g);
            let cell: Vec<f32> = cell.into_data().iter::<f32>().collect();
            (cell, g.1)
        };
        // The check above moved the fused running statistics once already: run the composed
        // forward once more too, so both have seen the batch twice.
        let _ = composed.forward(x.clone(), m.clone());
        let (cell_f, grads_f) = run(&fused);
        let (cell_c, grads_c) = run(&composed);
        assert_close(&cell_f, &cell_c, "cell features");
        assert_eq!(grads_f.len(), grads_c.len());
        assert_eq!(
            grads_f.len(),
            2 + 6 * cfg.blocks.len(),
            "a gradient for every parameter"
        );
        for (i, (gf, gc)) in grads_f.iter().zip(&grads_c).enumerate() {
            assert_close(gf, gc, &format!("gradient {i}"));
        }
        for (bf, bc) in fused.batch_norms().into_iter().zip(composed.batch_norms()) {
            let values = |t: Tensor<1>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
            assert_close(
                &values(bf.running_mean.value()),
                &values(bc.running_mean.value()),
                "running mean",
            );
            assert_close(
                &values(bf.running_var.value()),
                &values(bc.running_var.value()),
                "running variance",
            );
        }
    }

    #[test]
    fn the_fused_featurizer_trains_as_the_composed_blocks_do() {
        // The quickstart's widths; full, partly padded, one-point and empty centers.
        check_fused_training(FeaturizerConfig::small(), 16, &[16, 5, 1, 0, 9, 16, 12, 3], 1);
        // Widths unlike each other, P = 1, one block.
        check_fused_training(FeaturizerConfig::new(5, vec![[7, 3]]), 1, &[1, 0, 1, 1, 0], 2);
        check_fused_training(FeaturizerConfig::new(6, vec![[9, 4], [5, 8]]), 6, &[6, 2, 0, 4], 3);
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
