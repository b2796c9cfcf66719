//! Batch normalisation that ignores padded rows (lingvo's padding-aware BN): the batch mean
//! and variance are taken over real rows only, padded outputs are set to 0, and running
//! statistics (for evaluation) are updated from the real rows. Burn's stock `BatchNorm` has no
//! mask. Mode follows Burn's convention: batch statistics on an autodiff device with the
//! training flag on (`model.valid()` turns both off), running statistics otherwise.

use super::row_layout::{self, RowLayout};
use crate::replicas::op::all_sum;
use burn::module::{Flag, Module, Param, RunningState};
use burn::nn::Initializer;
use burn::prelude::*;

/// Configuration of [`MaskedBatchNorm`].
#[derive(Config, Debug)]
pub struct MaskedBatchNormConfig {
    /// Channels.
    pub num_features: usize,
    /// Added to the variance (lingvo: 1e-3).
    #[config(default = 1e-3)]
    pub epsilon: f64,
    /// Weight of a new batch in the running statistics (lingvo's decay 0.99 → 0.01).
    #[config(default = 0.01)]
    pub momentum: f64,
    /// How the composed forward lays out its rows ([`RowLayout`]).
    #[config(default = "RowLayout::Auto")]
    pub rows: RowLayout,
}

/// Masked batch normalisation over rows `[N, D]`.
#[derive(Module, Debug)]
pub struct MaskedBatchNorm {
    /// Scale γ `[D]`.
    pub gamma: Param<Tensor<1>>,
    /// Shift β `[D]`.
    pub beta: Param<Tensor<1>>,
    /// Training flag (off after `valid()`).
    pub training: Param<Flag>,
    /// Running mean `[D]`.
    pub running_mean: RunningState<Tensor<1>>,
    /// Running (biased) variance `[D]`.
    pub running_var: RunningState<Tensor<1>>,
    /// See the config.
    pub momentum: f64,
    /// See the config.
    pub epsilon: f64,
    /// See the config.
    #[module(skip)]
    pub rows: RowLayout,
}

impl MaskedBatchNormConfig {
    /// Builds the layer: γ = 1, β = 0, running mean 0 and variance 1.
    pub fn init(&self, device: &Device) -> MaskedBatchNorm {
        assert!(self.num_features > 0, "num_features must be positive");
        MaskedBatchNorm {
            gamma: Initializer::Ones.init([self.num_features], device),
            beta: Initializer::Zeros.init([self.num_features], device),
            training: Param::from_bool(true),
            running_mean: RunningState::new(Tensor::zeros([self.num_features], device)),
            running_var: RunningState::new(Tensor::ones([self.num_features], device)),
            momentum: self.momentum,
            epsilon: self.epsilon,
            rows: self.rows,
        }
    }
}

impl MaskedBatchNorm {
    /// # Shapes
    /// - `x`: `[N, D]`
    /// - `mask`: `[N, 1]`, 1.0 for real rows and 0.0 for padding
    /// - output: `[N, D]`, zero in padded rows
    pub fn forward(&self, x: Tensor<2>, mask: Tensor<2>) -> Tensor<2> {
        let [n, d] = x.dims();
        let g = self.rows.groups(n, &x.device());
        let x = x.reshape([g.groups, g.rows, d]);
        self.forward_rows(x, mask.reshape([g.groups, g.rows, 1]))
            .reshape([n, d])
    }

    /// [`Self::forward`] on rows already laid out as `[G, R, ·]` ([`super::row_layout`]).
    ///
    /// # Shapes
    /// - `x`: `[G, R, D]`
    /// - `mask`: `[G, R, 1]`
    /// - output: `[G, R, D]`, zero in padded rows
    pub fn forward_rows(&self, x: Tensor<3>, mask: Tensor<3>) -> Tensor<3> {
        let [_, r, d] = x.dims();
        let (mean, var) = if self.uses_batch_statistics(&x.device()) {
            // Sums over the replica group, when training data-parallel: the statistics are the
            // whole batch's (synchronised BatchNorm); `all_sum` is the identity otherwise.
            let count = all_sum(row_layout::sum_rows(mask.clone())).clamp_min(1.0); // [1, 1, 1]
            let mean = all_sum(row_layout::sum_rows(x.clone() * mask.clone())) / count.clone(); // [1, 1, D]
            let centred = (x.clone() - row_layout::per_channel(mean.clone(), r)) * mask.clone();
            let var = all_sum(row_layout::sum_rows(centred.powi_scalar(2))) / count; // [1, 1, D]
            self.update_running(mean.clone().reshape([d]), var.clone().reshape([d]));
            (mean, var)
        } else {
            let dev = x.device();
            (
                self.running_mean.value().to_device(&dev).reshape([1, 1, d]),
                self.running_var.value().to_device(&dev).reshape([1, 1, d]),
            )
        };
        let scale = self.gamma.val().reshape([1, 1, d]) / (var + self.epsilon).sqrt();
        let shifted = x - row_layout::per_channel(mean, r);
        (shifted * row_layout::per_channel(scale, r) + row_layout::per_channel(self.beta.val(), r)) * mask
    }
}

/// A BatchNorm's running mean and variance, `[D]` each.
#[derive(Debug, Clone)]
pub struct RunningStats {
    /// Running mean.
    pub mean: Tensor<1>,
    /// Running (biased) variance.
    pub var: Tensor<1>,
}

impl MaskedBatchNorm {
    /// The running statistics now.
    pub fn running(&self) -> RunningStats {
        RunningStats {
            mean: self.running_mean.value_sync(),
            var: self.running_var.value_sync(),
        }
    }

    /// Sets the running statistics (e.g. back to those [`Self::running`] returned).
    pub fn set_running(&self, stats: RunningStats) {
        for (state, value) in [(&self.running_mean, stats.mean), (&self.running_var, stats.var)] {
            state.update(value);
            let _ = state.value_sync();
        }
    }

    /// Moves the running statistics `momentum` of the way towards a batch's mean and biased
    /// variance (`[D]` each; detached here).
    pub fn update_running(&self, mean: Tensor<1>, var: Tensor<1>) {
        let update = |state: &RunningState<Tensor<1>>, batch: Tensor<1>| {
            let old = state.value_sync().to_device(&batch.device());
            let new = old.mul_scalar(1.0 - self.momentum) + batch.detach().mul_scalar(self.momentum);
            state.update(new.detach());
            // Fold the update in now: Burn parks it per thread until the next sync, and
            // saving (which reads the synced value) would otherwise lag one step behind.
            let _ = state.value_sync();
        };
        update(&self.running_mean, mean);
        update(&self.running_var, var);
    }

    /// Whether `forward` on `device` normalises with the batch's statistics (training).
    pub fn uses_batch_statistics(&self, device: &Device) -> bool {
        device.is_autodiff() && self.training.is_enabled()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;

    fn data(dev: &Device) -> (Tensor<2>, Tensor<2>) {
        // Rows 0..3 real, rows 3..5 padding holding large junk.
        let x = Tensor::<2>::from_floats([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0], [1e3, -1e3], [7.0, 7.0]], dev);
        let m = Tensor::<2>::from_floats([[1.0], [1.0], [1.0], [0.0], [0.0]], dev);
        (x, m)
    }

    #[test]
    fn training_uses_real_rows_only_and_zeroes_padding() {
        let dev = default_device().autodiff();
        let bn = MaskedBatchNormConfig::new(2).with_epsilon(0.0).init(&dev);
        let (x, m) = data(&dev);
        let y: Vec<f32> = bn.forward(x, m).into_data().iter::<f32>().collect();
        // Real column 0 is (1, 2, 3): mean 2, biased variance 2/3 → (x − 2)/√(2/3).
        let s = (2.0f32 / 3.0).sqrt();
        let want = [-1.0 / s, -1.0 / s, 0.0, 0.0, 1.0 / s, 1.0 / s, 0.0, 0.0, 0.0, 0.0];
        assert!(y.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-5), "{y:?}");
        // Running stats moved 1 % towards (2, 20) and (2/3, 200/3), and are visible without a
        // sync (as saving sees them).
        let rm: Vec<f32> = bn.running_mean.value().into_data().iter::<f32>().collect();
        assert!((rm[0] - 0.02).abs() < 1e-6 && (rm[1] - 0.2).abs() < 1e-5, "{rm:?}");
    }

    #[test]
    fn evaluation_uses_running_statistics() {
        let dev = default_device();
        let bn = MaskedBatchNormConfig::new(2).with_epsilon(0.0).init(&dev);
        let (x, m) = data(&dev);
        let y: Vec<f32> = bn.forward(x, m).into_data().iter::<f32>().collect();
        // Running mean 0, variance 1: the identity on real rows.
        assert_eq!(y, [1.0, 10.0, 2.0, 20.0, 3.0, 30.0, 0.0, 0.0, 0.0, 0.0]);
    }
}
