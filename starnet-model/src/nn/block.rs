//! The StarNet block (lingvo `builder_lib._GIN`, paper §3.2): every point's feature is joined
//! with the max over its neighbourhood, then passes two layers of BN → Linear (no bias) → ReLU.
//! On flex the block runs as one fused operation ([`super::fused`]) unless `fused` is off; the
//! composed form here is the reference and the path on every other backend.

use super::fused::kernel::{BlockStats, BnStats};
use super::fused::op::{self, ParamTensors};
use super::row_layout::{self, RowLayout};
use super::{Bias, MaskedBatchNorm, MaskedBatchNormConfig, linear};
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
    /// Run as the fused operation where the backend allows it (flex, f32), else composed.
    #[config(default = true)]
    pub fused: bool,
    /// How the composed form lays out its rows ([`RowLayout`]).
    #[config(default = "RowLayout::Auto")]
    pub rows: RowLayout,
}

/// One StarNet block.
#[derive(Module, Debug)]
pub struct StarNetBlock {
    bn1: MaskedBatchNorm,
    fc1: Linear,
    bn2: MaskedBatchNorm,
    fc2: Linear,
    fused: bool,
    #[module(skip)]
    rows: RowLayout,
}

impl StarNetBlock {
    /// Its BatchNorms, in order.
    pub fn batch_norms(&self) -> [&MaskedBatchNorm; 2] {
        [&self.bn1, &self.bn2]
    }
}

impl StarNetBlockConfig {
    /// Builds the block.
    pub fn init(&self, device: &Device) -> StarNetBlock {
        let bn = |width: usize| MaskedBatchNormConfig::new(width).with_rows(self.rows).init(device);
        StarNetBlock {
            bn1: bn(2 * self.d_input),
            fc1: linear(2 * self.d_input, self.d_hidden, Bias::Omitted, device),
            bn2: bn(self.d_hidden),
            fc2: linear(self.d_hidden, self.d_output, Bias::Omitted, device),
            fused: self.fused,
            rows: self.rows,
        }
    }
}

impl StarNetBlock {
    /// # Shapes
    /// - `f`: `[B·C, P, d]` (ReLU outputs, zero in padded rows)
    /// - `mask`: `[B·C, P, 1]`
    /// - output: `[B·C, P, d_output]`, zero in padded rows
    pub fn forward(&self, f: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
        if self.fused
            && let Some(out) = self.forward_fused(f.clone(), mask.clone())
        {
            return out;
        }
        self.forward_composed(f, mask)
    }

    /// The block as Burn tensor operations (the reference).
    ///
    /// # Shapes
    /// As [`Self::forward`].
    pub fn forward_composed(&self, f: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
        let [bc, p, d] = f.dims();
        let g = self.rows.groups(bc * p, &f.device());
        let pooled = masked_max(f.clone(), mask.clone()).expand([bc, p, d]);
        let x = Tensor::cat(vec![f, pooled], 2).reshape([g.groups, g.rows, 2 * d]); // [G, R, 2d]
        let m = mask.reshape([g.groups, g.rows, 1]);
        // BN zeroes padded rows and the linear layers have no bias, so padding stays 0.
        let h = relu(row_layout::linear(&self.fc1, self.bn1.forward_rows(x, m.clone())));
        let h = relu(row_layout::linear(&self.fc2, self.bn2.forward_rows(h, m)));
        let [_, _, out] = h.dims();
        h.reshape([bc, p, out])
    }

    /// The fused operation, or `None` where it does not apply (another backend; an autodiff
    /// device with the training flag off).
    fn forward_fused(&self, f: Tensor<3>, mask: Tensor<3>) -> Option<Tensor<3>> {
        let [bc, p, _] = f.dims();
        let mask = mask.reshape([bc, p]);
        let device = f.device();
        let params = self.param_tensors();
        if self.bn1.uses_batch_statistics(&device) {
            let out = op::forward_train(f, mask, params)?;
            self.record_batch_stats(out.stats);
            Some(out.out)
        } else if !device.is_autodiff() {
            let stats = self.running_stats();
            op::forward_eval(f, mask, params, &stats.bn1, &stats.bn2)
        } else {
            None
        }
    }
}

impl StarNetBlock {
    /// Whether the block runs as the fused operation where it can.
    pub(crate) fn is_fused(&self) -> bool {
        self.fused
    }

    /// Makes the block run fused (where it can) or composed.
    #[cfg(test)]
    pub(crate) fn set_fused(&mut self, fused: bool) {
        self.fused = fused;
    }

    /// Moves the running statistics towards a batch's (a fused forward computed them).
    pub(crate) fn record_batch_stats(&self, stats: BlockStats) {
        let device = self.bn1.gamma.val().device();
        for (bn, s) in [(&self.bn1, stats.bn1), (&self.bn2, stats.bn2)] {
            bn.update_running(stats_tensor(s.mean, &device), stats_tensor(s.var, &device));
        }
    }

    /// The running statistics, as the fused evaluation reads them.
    pub(crate) fn running_stats(&self) -> BlockStats {
        BlockStats {
            bn1: running(&self.bn1),
            bn2: running(&self.bn2),
        }
    }

    pub(crate) fn param_tensors(&self) -> ParamTensors {
        ParamTensors {
            gamma1: self.bn1.gamma.val(),
            beta1: self.bn1.beta.val(),
            w1: self.fc1.weight.val(),
            gamma2: self.bn2.gamma.val(),
            beta2: self.bn2.beta.val(),
            w2: self.fc2.weight.val(),
            epsilon: self.bn1.epsilon as f32,
        }
    }
}

fn stats_tensor(values: Vec<f32>, device: &Device) -> Tensor<1> {
    Tensor::from_floats(values.as_slice(), device)
}

/// A BatchNorm's running statistics.
fn running(bn: &MaskedBatchNorm) -> BnStats {
    let read = |t: Tensor<1>| t.into_data().iter::<f32>().collect();
    BnStats {
        mean: read(bn.running_mean.value()),
        var: read(bn.running_var.value()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use crate::testing;
    use burn::module::Param;
    use burn::tensor::activation::relu;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A block's shape and which slots are real: `real[n]` real points in center n's P slots
    /// (the rest padding).
    struct Case {
        p: usize,
        d: usize,
        h: usize,
        o: usize,
        real: Vec<usize>,
    }

    /// Values from a fixed seed: the comparison is exact up to rounding except where a ReLU's
    /// input is within rounding of 0 (the two paths then disagree on that unit, correctly for
    /// each), so the inputs are seeded rather than drawn anew on every run.
    fn random_param(n: usize, low: f32, high: f32, rng: &mut ChaCha8Rng, dev: &Device) -> Param<Tensor<1>> {
        Param::from_tensor(testing::uniform([n], low, high, rng, dev))
    }

    /// The composed block with non-trivial BN parameters, and a copy that runs fused.
    fn blocks(c: &Case, rng: &mut ChaCha8Rng, dev: &Device) -> (StarNetBlock, StarNetBlock) {
        let mut composed = StarNetBlockConfig::new(c.d, c.h, c.o).with_fused(false).init(dev);
        let weight = |rows: usize, cols: usize, rng: &mut ChaCha8Rng| {
            let bound = (6.0 / rows as f32).sqrt();
            Param::from_tensor(testing::uniform([rows, cols], -bound, bound, rng, dev))
        };
        composed.fc1.weight = weight(2 * c.d, c.h, rng);
        composed.fc2.weight = weight(c.h, c.o, rng);
        composed.bn1.gamma = random_param(2 * c.d, 0.5, 1.5, rng, dev);
        composed.bn1.beta = random_param(2 * c.d, -0.5, 0.5, rng, dev);
        composed.bn2.gamma = random_param(c.h, 0.5, 1.5, rng, dev);
        composed.bn2.beta = random_param(c.h, -0.5, 0.5, rng, dev);
        let mut fused = composed.clone();
        fused.fused = true;
        (composed, fused)
    }

    /// ReLU'd random points zero in padded slots `[N, P, d]`, the mask `[N, P, 1]`, and a
    /// random cotangent for the output `[N, P, O]`.
    fn inputs(c: &Case, rng: &mut ChaCha8Rng, dev: &Device) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
        let n = c.real.len();
        let mask: Vec<f32> = c
            .real
            .iter()
            .flat_map(|&r| (0..c.p).map(move |s| if s < r { 1.0 } else { 0.0 }))
            .collect();
        let mask = Tensor::<1>::from_floats(mask.as_slice(), dev).reshape([n, c.p, 1]);
        let x = relu(testing::uniform([n, c.p, c.d], -1.0, 2.0, rng, dev)) * mask.clone();
        let cot = testing::uniform([n, c.p, c.o], -1.0, 1.0, rng, dev);
        (x, mask, cot)
    }

    fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
        t.into_data().iter::<f32>().collect()
    }

    /// `a` within 1e-4 of `b`, relative to `b`'s largest magnitude.
    fn assert_close(a: Vec<f32>, b: Vec<f32>, what: &str) {
        assert_eq!(a.len(), b.len(), "{what}: lengths");
        let scale = b.iter().fold(0.0f32, |m, v| m.max(v.abs())).max(1e-6);
        let worst = a.iter().zip(&b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= 1e-4 * scale,
            "{what}: max |fused − composed| {worst} against scale {scale}"
        );
    }

    /// Forward, backward and running statistics of one training step, fused against composed.
    fn check_training(c: Case, seed: u64) {
        let dev = default_device().autodiff();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (composed, fused) = blocks(&c, &mut rng, &dev);
        let (x, mask, cot) = inputs(&c, &mut rng, &dev);
        let run = |block: &StarNetBlock| {
            let x = x.clone().detach().require_grad();
            let out = block.forward(x.clone(), mask.clone());
            let grads = (out.clone() * cot.clone()).sum().backward();
            let params = [
                block.bn1.gamma.val(),
                block.bn1.beta.val(),
                block.bn2.gamma.val(),
                block.bn2.beta.val(),
            ];
            let mut g: Vec<Vec<f32>> = params.iter().map(|p| values(p.grad(&grads).unwrap())).collect();
            g.push(values(block.fc1.weight.val().grad(&grads).unwrap()));
            g.push(values(block.fc2.weight.val().grad(&grads).unwrap()));
            g.push(values(x.grad(&grads).unwrap()));
            (values(out), g)
        };
        // The fused path must really run here, or this compares the composed block with itself.
        let [n, p, _] = x.dims();
        let mask2 = mask.clone().reshape([n, p]);
        assert!(op::forward_train(x.clone(), mask2, fused.param_tensors()).is_some());
        let (out_c, grads_c) = run(&composed);
        let (out_f, grads_f) = run(&fused);
        assert_close(out_f, out_c, "output");
        let names = ["dγ₁", "dβ₁", "dγ₂", "dβ₂", "dW₁", "dW₂", "dx"];
        for ((gf, gc), name) in grads_f.into_iter().zip(grads_c).zip(names) {
            assert_close(gf, gc, name);
        }
        for (f, c) in [(&fused.bn1, &composed.bn1), (&fused.bn2, &composed.bn2)] {
            assert_close(
                values(f.running_mean.value()),
                values(c.running_mean.value()),
                "running mean",
            );
            assert_close(
                values(f.running_var.value()),
                values(c.running_var.value()),
                "running variance",
            );
        }
    }

    #[test]
    fn fused_training_step_matches_the_composed_block() {
        // Widths unlike each other; full, partly padded, one-point and empty centers.
        check_training(
            Case {
                p: 8,
                d: 5,
                h: 7,
                o: 3,
                real: vec![8, 3, 1, 0, 5, 8],
            },
            1,
        );
        check_training(
            Case {
                p: 1,
                d: 4,
                h: 6,
                o: 9,
                real: vec![1, 0, 1, 1],
            },
            2,
        );
        check_training(
            Case {
                p: 16,
                d: 32,
                h: 64,
                o: 32,
                real: (0..40).map(|i| (i * 7) % 17).collect(),
            },
            3,
        );
    }

    #[test]
    fn fused_evaluation_matches_the_composed_block() {
        let c = Case {
            p: 12,
            d: 6,
            h: 10,
            o: 4,
            real: vec![12, 0, 1, 7, 12],
        };
        let train = default_device().autodiff();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let (composed, _) = blocks(&c, &mut rng, &train);
        // One training step moves the running statistics away from (0, 1).
        let (x, mask, _) = inputs(&c, &mut rng, &train);
        let _ = composed.forward(x, mask);
        let composed = composed.valid();
        let mut fused = composed.clone();
        fused.fused = true;
        let dev = default_device();
        let (x, mask, _) = inputs(&c, &mut rng, &dev);
        let want = values(composed.forward(x.clone(), mask.clone()));
        let [n, p, _] = x.dims();
        let (bn1, bn2) = (running(&fused.bn1), running(&fused.bn2));
        let mask2 = mask.clone().reshape([n, p]);
        assert!(op::forward_eval(x.clone(), mask2, fused.param_tensors(), &bn1, &bn2).is_some());
        assert_close(values(fused.forward(x, mask)), want, "evaluation output");
    }
}
