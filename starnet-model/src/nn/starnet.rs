//! The StarNet model (paper §3.3, lingvo `starnet.ModelV2`): featurizer → projector (BN →
//! Linear(cell → G²·D) → ReLU, one D-dim feature per grid offset) → heads shared across offsets:
//! class logits (bias −4.595, a 0.01 prior) and box residuals (zero-initialised).

use super::{Featurizer, FeaturizerConfig, MaskedBatchNorm, MaskedBatchNormConfig, linear};
use burn::module::{Module, Param};
use burn::nn::Linear;
use burn::prelude::*;
use burn::tensor::activation::relu;
use starnet_data::sampling::AnchorGrid;

/// The model's inputs for a batch.
#[derive(Debug, Clone)]
pub struct ModelInput {
    /// Neighbourhood features `[B, C, P, F]`.
    pub points: Tensor<4>,
    /// `[B, C, P]`: 1.0 for real points, 0.0 for padding.
    pub mask: Tensor<3>,
    /// `[B, C]`: 1.0 for real centers, 0.0 for repeats that pad a small pool.
    pub center_valid: Tensor<2>,
}

/// The model's outputs for a batch.
#[derive(Debug, Clone)]
pub struct ModelOutput {
    /// Class logits `[B, C, A, K]`.
    pub cls_logits: Tensor<4>,
    /// Box residuals `[B, C, A, 7]` (see [`crate::coder`]).
    pub box_residuals: Tensor<4>,
}

/// Configuration of [`StarNet`].
#[derive(Config, Debug)]
pub struct StarNetConfig {
    /// The featurizer.
    pub featurizer: FeaturizerConfig,
    /// Per-offset feature width D.
    pub d_offset: usize,
    /// Anchors around each center (their count A and order fix the heads' layout).
    pub anchors: AnchorGrid,
    /// Classes K.
    pub num_classes: usize,
}

/// Logit of the classification prior 0.01: ln(0.01 / 0.99).
pub const CLASS_PRIOR_LOGIT: f32 = -4.595;

impl StarNetConfig {
    /// The paper's widths (cell 384, D = 128) with KITTI car anchors.
    pub fn paper_car() -> Self {
        Self::new(FeaturizerConfig::paper(), 128, AnchorGrid::kitti_car(), 1)
    }

    /// The CPU-sized preset (cell 128, D = 32) with KITTI car anchors.
    pub fn small_car() -> Self {
        Self::new(FeaturizerConfig::small(), 32, AnchorGrid::kitti_car(), 1)
    }

    /// Anchors per grid offset: rotations × priors.
    pub fn anchors_per_offset(&self) -> usize {
        self.anchors.rotations.len() * self.anchors.priors.len()
    }

    /// Builds the model.
    pub fn init(&self, device: &Device) -> StarNet {
        let cell = self.featurizer.cell_dim();
        let offsets = self.anchors.grid * self.anchors.grid;
        let per = self.anchors_per_offset();
        let mut cls_head = linear(self.d_offset, per * self.num_classes, true, device);
        cls_head.bias = Some(Param::from_tensor(Tensor::full(
            [per * self.num_classes],
            CLASS_PRIOR_LOGIT,
            device,
        )));
        let mut box_head = linear(self.d_offset, per * 7, false, device);
        box_head.weight = Param::from_tensor(Tensor::zeros([self.d_offset, per * 7], device));
        StarNet {
            featurizer: self.featurizer.init(device),
            proj_bn: MaskedBatchNormConfig::new(cell).init(device),
            proj: linear(cell, offsets * self.d_offset, true, device),
            cls_head,
            box_head,
            d_offset: self.d_offset,
            num_classes: self.num_classes,
        }
    }
}

/// StarNet.
#[derive(Module, Debug)]
pub struct StarNet {
    featurizer: Featurizer,
    proj_bn: MaskedBatchNorm,
    proj: Linear,
    cls_head: Linear,
    box_head: Linear,
    d_offset: usize,
    num_classes: usize,
}

impl StarNet {
    /// # Shapes
    /// - input: points `[B, C, P, F]`, mask `[B, C, P]`, center_valid `[B, C]`
    /// - output: cls_logits `[B, C, A, K]`, box_residuals `[B, C, A, 7]`
    pub fn forward(&self, input: ModelInput) -> ModelOutput {
        let [b, c, _, _] = input.points.dims();
        let cell = self.featurizer.forward(input.points, input.mask); // [B, C, cell]
        let [_, _, d_cell] = cell.dims();
        let rows = self
            .proj_bn
            .forward(cell.reshape([b * c, d_cell]), input.center_valid.reshape([b * c, 1]));
        let per_offset = relu(self.proj.forward(rows)); // [BC, G²·D]
        let [_, width] = per_offset.dims();
        let offsets = width / self.d_offset;
        let f = per_offset.reshape([b * c * offsets, self.d_offset]); // [BC·G², D]
        let cls = self.cls_head.forward(f.clone()); // [BC·G², R·Pr·K]
        let reg = self.box_head.forward(f); // [BC·G², R·Pr·7]
        let per = cls.dims()[1] / self.num_classes;
        ModelOutput {
            cls_logits: cls.reshape([b, c, offsets * per, self.num_classes]),
            box_residuals: reg.reshape([b, c, offsets * per, 7]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use burn::tensor::Distribution;

    fn input(dev: &Device, b: usize, c: usize, p: usize, real: usize) -> ModelInput {
        let points = Tensor::<4>::random([b, c, p, 4], Distribution::Normal(0.0, 1.0), dev);
        let m: Vec<f32> = (0..b * c * p).map(|i| if i % p < real { 1.0 } else { 0.0 }).collect();
        ModelInput {
            points,
            mask: Tensor::<1>::from_floats(m.as_slice(), dev).reshape([b, c, p]),
            center_valid: Tensor::ones([b, c], dev),
        }
    }

    #[test]
    fn output_shapes() {
        let dev = default_device();
        let cfg = StarNetConfig::small_car();
        let out = cfg.init(&dev).forward(input(&dev, 2, 8, 16, 10));
        assert_eq!(out.cls_logits.dims(), [2, 8, 100, 1]);
        assert_eq!(out.box_residuals.dims(), [2, 8, 100, 7]);
        // The box head starts at zero.
        assert!(out.box_residuals.into_data().iter::<f32>().all(|v| v == 0.0));
        // Without real points every feature is 0, so the logits are the class bias: the prior.
        let empty = cfg.init(&dev).forward(input(&dev, 1, 4, 16, 0));
        assert!(
            empty
                .cls_logits
                .into_data()
                .iter::<f32>()
                .all(|v| (v - CLASS_PRIOR_LOGIT).abs() < 1e-6)
        );
    }
}
