//! StarNet's loss: its settings, the element losses (focal, Huber, the two-bin heading) and their sum, fused or composed.

use super::{heading::HeadingLoss, targets::LossTargets};
use crate::nn::ModelOutput;
use burn::prelude::*;
use burn::tensor::activation::{relu, sigmoid};
use starnet_data::settings::{Checked, non_negative, positive, within};

/// Loss settings (the authors' Waymo defaults); the `[loss]` section of an experiment config.
#[derive(Config, Debug, PartialEq)]
pub struct LossConfig {
    /// Focal α.
    #[config(default = 0.25)]
    pub alpha: f64,
    /// Focal γ.
    #[config(default = 2.0)]
    pub gamma: f64,
    /// Huber δ.
    #[config(default = 0.1111111111111111)]
    pub huber_delta: f64,
    /// Weight of the position residuals inside localisation.
    #[config(default = 3.0)]
    pub location_weight: f64,
    /// Weight of the size residuals inside localisation.
    #[config(default = 0.3)]
    pub dimension_weight: f64,
    /// Weight of the heading residual inside localisation.
    #[config(default = 0.3)]
    pub rotation_weight: f64,
    /// Weight of localisation in the total.
    #[config(default = 3.0)]
    pub localization_weight: f64,
    /// Weight of classification in the total.
    #[config(default = 1.0)]
    pub classification_weight: f64,
    /// Heading comparison.
    #[config(default = "HeadingLoss::Sin")]
    pub heading: HeadingLoss,
    /// Weight of the direction-bin cross-entropy in the total (OpenPCDet's 0.2).
    #[config(default = 0.2)]
    pub direction_weight: f64,
    /// Weight of each class's focal term, in the order of the classes (lingvo's
    /// `per_class_loss_weight`: Pedestrian 3.5, Cyclist 3.25 in its KITTI pedestrian + cyclist
    /// model); every anchor's term for that class, foreground or background, is scaled. Empty:
    /// every class weighs 1.
    #[config(default = "Vec::new()")]
    pub class_weights: Vec<f64>,
    /// Compute the terms as one fused operation where the backend allows it (flex, f32): the
    /// same maths to float rounding, with a fraction of the memory passes; false: the composed
    /// Burn operations everywhere (the reference).
    #[config(default = true)]
    pub fused: bool,
}

impl LossConfig {
    /// α is a probability weight, γ and the weights are ≥ 0, δ > 0.
    pub fn validate(&self) -> Checked {
        within("alpha", self.alpha, 0.0, 1.0)?;
        non_negative("gamma", self.gamma)?;
        positive("huber_delta", self.huber_delta)?;
        for (key, w) in [
            ("location_weight", self.location_weight),
            ("dimension_weight", self.dimension_weight),
            ("rotation_weight", self.rotation_weight),
            ("localization_weight", self.localization_weight),
            ("classification_weight", self.classification_weight),
            ("direction_weight", self.direction_weight),
        ] {
            non_negative(key, w)?;
        }
        for (i, &w) in self.class_weights.iter().enumerate() {
            non_negative(&format!("class_weights[{i}]"), w)?;
        }
        Ok(())
    }

    /// The weight of class column `k` (1 when the list is empty).
    pub fn class_weight(&self, k: usize) -> f64 {
        self.class_weights.get(k).copied().unwrap_or(1.0)
    }
}

/// Each term of the loss, reported separately.
#[derive(Debug, Clone)]
pub struct LossTerms {
    /// The weighted total, to backpropagate.
    pub total: Tensor<1>,
    /// Focal classification term.
    pub classification: Tensor<1>,
    /// Position residuals (x, y, z).
    pub location: Tensor<1>,
    /// Size residuals (log dx, dy, dz).
    pub dimension: Tensor<1>,
    /// Heading residual.
    pub rotation: Tensor<1>,
    /// Direction-bin cross-entropy (0 without the direction classifier).
    pub direction: Tensor<1>,
}

/// Element-wise sigmoid focal loss: `BCE(x, y) · (1 − p_t)^γ · (α y + (1 − α)(1 − y))`, with the
/// cross-entropy in its stable form `max(x, 0) − x y + ln(1 + e^−|x|)`.
pub fn sigmoid_focal<const D: usize>(logits: Tensor<D>, targets: Tensor<D>, alpha: f64, gamma: f64) -> Tensor<D> {
    let ce = relu(logits.clone()) - logits.clone() * targets.clone() + (logits.clone().abs().neg().exp() + 1.0).log();
    let p = sigmoid(logits);
    let p_t = p.clone() * targets.clone() + (p.neg() + 1.0) * (targets.clone().neg() + 1.0);
    let modulator = (p_t.neg() + 1.0).powf_scalar(gamma);
    let alpha_t = targets.clone() * alpha + (targets.neg() + 1.0) * (1.0 - alpha);
    ce * modulator * alpha_t
}

/// Element-wise Huber (smooth-L1): `0.5 x² / δ` for |x| ≤ δ, else `|x| − 0.5 δ`.
pub fn huber<const D: usize>(x: Tensor<D>, delta: f64) -> Tensor<D> {
    let a = x.clone().abs();
    let small = a.clone().lower_equal_elem(delta).float();
    let quadratic = x.powi_scalar(2) * (0.5 / delta);
    let linear = a - 0.5 * delta;
    quadratic * small.clone() + linear * (small.neg() + 1.0)
}

/// Two-class softmax cross-entropy of logits `[.., 2]` against the class `y` (0.0 or 1.0)
/// `[..]`: with `d = l₁ − l₀` it is `softplus(d) − y d`, in the stable form
/// `max(d, 0) − d y + ln(1 + e^−|d|)`.
pub fn two_bin_cross_entropy(logits: Tensor<4>, y: Tensor<3>) -> Tensor<3> {
    let d = (logits.clone().slice_dim(3, 1..2) - logits.slice_dim(3, 0..1)).squeeze_dim::<3>(3);
    relu(d.clone()) - d.clone() * y + (d.abs().neg().exp() + 1.0).log()
}

/// Wraps angles to [−π, π).
pub fn wrap_angle<const D: usize>(x: Tensor<D>) -> Tensor<D> {
    let tau = std::f64::consts::TAU;
    x.clone() - ((x + std::f64::consts::PI) / tau).floor() * tau
}

/// The StarNet loss of a batch: fused where [`LossConfig::fused`] and the backend allow it,
/// else [`starnet_loss_composed`].
pub fn starnet_loss(out: &ModelOutput, t: &LossTargets, cfg: &LossConfig) -> LossTerms {
    if cfg.fused
        && let Some(terms) = super::op::loss_terms(out, t, &kernel_config(cfg))
    {
        return combine(terms.split(1, 0).try_into().expect("five terms"), cfg);
    }
    starnet_loss_composed(out, t, cfg)
}

pub(super) fn kernel_config(cfg: &LossConfig) -> super::kernel::KernelConfig {
    super::kernel::KernelConfig {
        alpha: cfg.alpha as f32,
        gamma: cfg.gamma as f32,
        huber_delta: cfg.huber_delta as f32,
        heading: cfg.heading,
        class_weights: cfg.class_weights.iter().map(|&w| w as f32).collect(),
    }
}

/// The weighted total beside its five terms (classification, location, dimension, rotation,
/// direction), each `[1]`.
fn combine([classification, location, dimension, rotation, direction]: [Tensor<1>; 5], cfg: &LossConfig) -> LossTerms {
    let localization = location.clone() * cfg.location_weight
        + dimension.clone() * cfg.dimension_weight
        + rotation.clone() * cfg.rotation_weight;
    let total = localization * cfg.localization_weight
        + classification.clone() * cfg.classification_weight
        + direction.clone() * cfg.direction_weight;
    LossTerms {
        total,
        classification,
        location,
        dimension,
        rotation,
        direction,
    }
}

/// The StarNet loss of a batch as composed Burn operations (the reference).
pub fn starnet_loss_composed(out: &ModelOutput, t: &LossTargets, cfg: &LossConfig) -> LossTerms {
    let [b, _, _, _] = out.cls_logits.dims();
    let per_batch = |x: Tensor<3>, w: &Tensor<3>| (x * w.clone()).sum().div_scalar(b as f32);
    let [.., k] = out.cls_logits.dims();
    let class_weights: Vec<f32> = (0..k).map(|c| cfg.class_weight(c) as f32).collect();
    let class_weights =
        Tensor::<1>::from_floats(class_weights.as_slice(), &out.cls_logits.device()).reshape([1, 1, 1, k]);
    let focal = (sigmoid_focal(out.cls_logits.clone(), t.classes.clone(), cfg.alpha, cfg.gamma) * class_weights)
        .sum_dim(3)
        .squeeze_dim::<3>(3);
    let classification = per_batch(focal, &t.cls_weight);
    let diff = out.box_residuals.clone() - t.residuals.clone(); // [B, C, A, 7]
    let part = |from: usize, to: usize| {
        huber(diff.clone().slice_dim(3, from..to), cfg.huber_delta)
            .sum_dim(3)
            .squeeze_dim::<3>(3)
    };
    let location = per_batch(part(0, 3), &t.reg_weight);
    let dimension = per_batch(part(3, 6), &t.reg_weight);
    let dh = diff.slice_dim(3, 6..7);
    let dh = match cfg.heading {
        HeadingLoss::Sin => dh.sin(),
        HeadingLoss::Wrap => wrap_angle(dh),
    };
    let rotation = per_batch(huber(dh, cfg.huber_delta).squeeze_dim::<3>(3), &t.reg_weight);
    let direction = match &out.dir_logits {
        Some(d) => per_batch(two_bin_cross_entropy(d.clone(), t.direction.clone()), &t.reg_weight),
        None => Tensor::zeros([1], &t.reg_weight.device()),
    };
    combine([classification, location, dimension, rotation, direction], cfg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;

    fn scalars<const D: usize>(t: Tensor<D>) -> Vec<f32> {
        t.into_data().iter::<f32>().collect()
    }

    /// Reference values from the definitions, in f64:
    /// ```python
    /// import math
    /// def focal(x, y, a=0.25, g=2.0):
    ///     p = 1 / (1 + math.exp(-x)); ce = -(y * math.log(p) + (1 - y) * math.log(1 - p))
    ///     pt = p * y + (1 - p) * (1 - y); return ce * (1 - pt) ** g * (a * y + (1 - a) * (1 - y))
    /// [focal(2.0, 1), focal(2.0, 0), focal(-4.595, 0), focal(-3.0, 1)]
    /// # -> [0.000524..., 0.0802..., 1.0219e-06..., 2.8675...]
    /// ```
    #[test]
    fn focal_matches_hand_values() {
        let dev = default_device();
        let f = |x: f64, y: f64| {
            let p = 1.0 / (1.0 + (-x).exp());
            let ce = -(y * p.ln() + (1.0 - y) * (1.0 - p).ln());
            let pt = p * y + (1.0 - p) * (1.0 - y);
            ce * (1.0 - pt).powi(2) * (0.25 * y + 0.75 * (1.0 - y))
        };
        let xs = [2.0f32, 2.0, -4.595, -3.0, 0.0];
        let ys = [1.0f32, 0.0, 0.0, 1.0, 1.0];
        let got = scalars(sigmoid_focal(
            Tensor::<1>::from_floats(xs, &dev),
            Tensor::<1>::from_floats(ys, &dev),
            0.25,
            2.0,
        ));
        for i in 0..5 {
            let want = f(xs[i] as f64, ys[i] as f64);
            assert!(
                (got[i] as f64 - want).abs() < 1e-6 * want.max(1.0),
                "{i}: {} vs {want}",
                got[i]
            );
        }
        // x = 0, y = 1: ln 2 · 0.5² · 0.25.
        assert!((got[4] - 2f32.ln() * 0.0625).abs() < 1e-7);
    }

    #[test]
    fn huber_matches_hand_values() {
        let dev = default_device();
        let d = 1.0 / 9.0;
        let got = scalars(huber(Tensor::<1>::from_floats([0.0, 0.05, -0.1, 0.5, -2.0], &dev), d));
        let want = [
            0.0,
            0.5 * 0.0025 * 9.0,
            0.5 * 0.01 * 9.0,
            0.5 - 0.5 / 9.0,
            2.0 - 0.5 / 9.0,
        ];
        assert!(got.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-6), "{got:?}");
    }

    #[test]
    fn gradients_match_finite_differences() {
        let dev = default_device().autodiff();
        let xs = [1.3f32, -0.7, 0.05, -2.5, 0.2];
        let ys = [1.0f32, 0.0, 1.0, 0.0, 0.0];
        let x = Tensor::<1>::from_floats(xs, &dev).require_grad();
        let y = Tensor::<1>::from_floats(ys, &dev);
        let loss = sigmoid_focal(x.clone(), y, 0.25, 2.0).sum() + huber(x.clone(), 1.0 / 9.0).sum();
        let grads = loss.backward();
        let g: Vec<f32> = x.grad(&grads).expect("gradient").into_data().iter::<f32>().collect();
        let plain = default_device();
        let value = |v: &[f32; 5]| -> f64 {
            let x = Tensor::<1>::from_floats(*v, &plain);
            let l = sigmoid_focal(x.clone(), Tensor::<1>::from_floats(ys, &plain), 0.25, 2.0).sum()
                + huber(x, 1.0 / 9.0).sum();
            l.into_scalar::<f32>() as f64
        };
        for i in 0..5 {
            let h = 1e-3;
            let (mut up, mut down) = (xs, xs);
            up[i] += h;
            down[i] -= h;
            let fd = (value(&up) - value(&down)) / (2.0 * h as f64);
            assert!(
                (g[i] as f64 - fd).abs() < 2e-3 * fd.abs().max(1.0),
                "{i}: autodiff {} vs finite difference {fd}",
                g[i]
            );
        }
    }

    #[test]
    fn two_bin_cross_entropy_matches_the_softmax() {
        let dev = default_device();
        let l = [[0.3f32, -1.2], [2.0, 2.5], [-4.0, 6.0]];
        let y = [1.0f32, 0.0, 1.0];
        let logits = Tensor::<1>::from_floats(l.as_flattened(), &dev).reshape([1, 1, 3, 2]);
        let got = scalars(two_bin_cross_entropy(
            logits,
            Tensor::<1>::from_floats(y, &dev).reshape([1, 1, 3]),
        ));
        for i in 0..3 {
            let (a, b) = (f64::from(l[i][0]), f64::from(l[i][1]));
            let z = a.exp() + b.exp();
            let want = -(if y[i] > 0.5 { b.exp() / z } else { a.exp() / z }).ln();
            assert!((f64::from(got[i]) - want).abs() < 1e-5, "{i}: {} vs {want}", got[i]);
        }
    }

    #[test]
    fn heading_terms() {
        let dev = default_device();
        let w = scalars(wrap_angle(Tensor::<1>::from_floats(
            [3.5, -3.5, 0.2, std::f32::consts::PI],
            &dev,
        )));
        let tau = std::f32::consts::TAU;
        let want = [3.5 - tau, -3.5 + tau, 0.2, -std::f32::consts::PI];
        assert!(w.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-5), "{w:?}");
    }
}
