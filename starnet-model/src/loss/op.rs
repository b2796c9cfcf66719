//! The fused loss as a Burn operation on flex: one autodiff node from the three prediction
//! tensors to the five terms, whose backward is [`kernel::backward`]. `None` when the tensors
//! live elsewhere (another backend or dtype, a checkpointing strategy): the caller then takes
//! the composed path.

use super::kernel::{self, KernelConfig, Predictions, Slopes, Targets, Terms};
use super::targets::LossTargets;
use crate::flex_data::values;
use crate::nn::ModelOutput;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::flex::FlexTensor;
use burn::backend::{Autodiff, Flex};
use burn::prelude::*;
use burn::tensor::{DType, TensorData};
use std::borrow::Cow;

fn flatten<const D: usize>(t: Tensor<D>) -> Tensor<1> {
    let n = t.shape().num_elements();
    t.reshape([n])
}

/// The flex primitive of a tensor that is not differentiated (a target), on either device.
fn constant<const D: usize>(t: &Tensor<D>) -> Option<FlexTensor> {
    let t = flatten(t.clone());
    let prim = if t.device().is_autodiff() {
        t.try_into_primitive::<Autodiff<Flex>>().ok()?.into_primitive()
    } else {
        t.try_into_primitive::<Flex>().ok()?
    };
    (prim.dtype() == DType::F32).then_some(prim)
}

/// The targets' five tensors, flattened, in [`Targets`]' order.
fn target_prims(t: &LossTargets) -> Option<[FlexTensor; 5]> {
    Some([
        constant(&t.classes)?,
        constant(&t.cls_weight)?,
        constant(&t.residuals)?,
        constant(&t.reg_weight)?,
        constant(&t.direction)?,
    ])
}

fn targets_of<'a>(v: &'a [Cow<'a, [f32]>; 5]) -> Targets<'a> {
    Targets {
        classes: &v[0],
        cls_weight: &v[1],
        residuals: &v[2],
        reg_weight: &v[3],
        direction: &v[4],
    }
}

fn predictions_of<'a>(v: &'a [Cow<'a, [f32]>], has_direction: bool) -> Predictions<'a> {
    Predictions {
        cls_logits: &v[0],
        box_residuals: &v[1],
        dir_logits: has_direction.then(|| &*v[2]),
    }
}

fn terms_tensor(terms: Terms) -> FlexTensor {
    FlexTensor::from_data(TensorData::new(terms.to_array().to_vec(), vec![5]))
}

/// What the backward keeps: the forward's slopes and the predictions' shapes.
#[derive(Debug, Clone)]
struct Saved {
    slopes: Slopes,
    batch: usize,
    shapes: [Vec<usize>; 3],
}

#[derive(Debug)]
struct FusedLossBackward;

impl Backward<Flex, 3> for FusedLossBackward {
    type State = Saved;

    fn backward(self, ops: Ops<Saved, 3>, grads: &mut Gradients, _: &mut Checkpointer) {
        let upstream = grads.consume::<Flex>(&ops.node);
        let upstream: [f32; 5] = values(&upstream).as_ref().try_into().expect("five terms");
        let s = ops.state;
        let g = kernel::backward(&s.slopes, s.batch, Terms::from_array(upstream));
        let values = [Some(g.cls_logits), Some(g.box_residuals), g.dir_logits];
        for ((parent, grad), shape) in ops.parents.into_iter().zip(values).zip(s.shapes) {
            if let (Some(node), Some(grad)) = (parent, grad) {
                grads.register::<Flex>(node.id, FlexTensor::from_data(TensorData::new(grad, shape)));
            }
        }
    }
}

/// The five terms `[5]` (classification, location, dimension, rotation, direction; see
/// [`Terms`]) of a batch, as one graph node on autodiff-flex or as plain values on flex.
///
/// # Shapes
/// The predictions `[B, C, A, K | 7 | 2]` and targets of [`LossTargets`].
pub fn loss_terms(out: &ModelOutput, t: &LossTargets, cfg: &KernelConfig) -> Option<Tensor<1>> {
    let [batch, _, _, _] = out.cls_logits.dims();
    let has_direction = out.dir_logits.is_some();
    let device = out.cls_logits.device();
    // Without the classifier a one-element stand-in fills the third slot, untracked.
    let dir = out
        .dir_logits
        .clone()
        .unwrap_or_else(|| Tensor::zeros([1, 1, 1, 1], &device));
    let predictions = [out.cls_logits.clone(), out.box_residuals.clone(), dir].map(flatten);
    let targets = target_prims(t)?;
    let fwd = |prims: &[FlexTensor]| {
        let p: Vec<Cow<[f32]>> = prims.iter().map(values).collect();
        let t = targets.each_ref().map(values);
        kernel::forward(predictions_of(&p, has_direction), targets_of(&t), cfg, batch)
    };
    if !device.is_autodiff() {
        let prims = predictions.map(|t| t.try_into_primitive::<Flex>().ok());
        let prims: Vec<FlexTensor> = prims.into_iter().collect::<Option<Vec<_>>>().filter(|p| all_f32(p))?;
        return Some(Tensor::from_primitive::<Flex>(terms_tensor(fwd(&prims).terms)));
    }
    let ad = predictions.map(|t| t.try_into_primitive::<Autodiff<Flex>>().ok());
    let ad: Vec<_> = ad.into_iter().collect::<Option<_>>()?;
    let (prims, guards): (Vec<FlexTensor>, Vec<_>) = ad.into_iter().map(|t| t.into_parts()).unzip();
    if !all_f32(&prims) {
        return None;
    }
    let kernel::Forward { terms, slopes } = fwd(&prims);
    let terms = terms_tensor(terms);
    let guards: [_; 3] = guards.try_into().expect("three inputs");
    let out = match FusedLossBackward
        .prepare::<NoCheckpointing>(guards)
        .compute_bound()
        .stateful()
    {
        OpsKind::Tracked(prep) => {
            let shapes = prims.iter().map(|t| t.layout().shape().to_vec()).collect::<Vec<_>>();
            let state = Saved {
                slopes,
                batch,
                shapes: shapes.try_into().expect("three inputs"),
            };
            prep.finish(state, terms)
        }
        OpsKind::UnTracked(prep) => prep.finish(terms),
    };
    Some(Tensor::from_primitive::<Autodiff<Flex>>(out))
}

fn all_f32(prims: &[FlexTensor]) -> bool {
    prims.iter().all(|t| t.dtype() == DType::F32)
}

#[cfg(test)]
mod tests {
    use super::super::{HeadingLoss, LossConfig, LossTerms, starnet_loss, starnet_loss_composed};
    use super::*;
    use crate::backend::default_device;
    use crate::testing;

    /// Predictions and targets of `b · c · a` anchors with `k` classes: a third foreground
    /// (one-hot class, a regression weight), some anchors ignored (no weight at all).
    fn case(dev: &Device, k: usize, direction: bool, seed: u64) -> (ModelOutput, LossTargets) {
        let (b, c, a) = (2, 5, 6);
        let rng = std::cell::RefCell::new(testing::rng(seed));
        let normal = |shape: [usize; 4], s: f32| testing::normal(shape, s, &mut rng.borrow_mut(), dev);
        let uniform = |shape: [usize; 3]| testing::uniform(shape, 0.0, 1.0, &mut rng.borrow_mut(), dev);
        let fg = uniform([b, c, a]).lower_elem(0.33).float();
        let class = (uniform([b, c, a]) * k as f32).floor();
        let classes = Tensor::cat(
            (0..k)
                .map(|j| class.clone().equal_elem(j as f32).float().unsqueeze_dim::<4>(3))
                .collect(),
            3,
        ) * fg.clone().unsqueeze_dim::<4>(3);
        let weight = uniform([b, c, a]) * uniform([b, c, a]).greater_elem(0.1).float();
        let tracked = |t: Tensor<4>| if dev.is_autodiff() { t.require_grad() } else { t };
        let out = ModelOutput {
            cls_logits: tracked(normal([b, c, a, k], 2.0)),
            box_residuals: tracked(normal([b, c, a, 7], 0.3)),
            dir_logits: direction.then(|| tracked(normal([b, c, a, 2], 1.5))),
        };
        let targets = LossTargets {
            classes,
            cls_weight: weight.clone(),
            residuals: normal([b, c, a, 7], 0.3),
            reg_weight: weight * fg,
            direction: uniform([b, c, a]).greater_elem(0.5).float(),
        };
        (out, targets)
    }

    fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
        t.into_data().iter::<f32>().collect()
    }

    fn terms(t: &LossTerms) -> Vec<f32> {
        [
            &t.total,
            &t.classification,
            &t.location,
            &t.dimension,
            &t.rotation,
            &t.direction,
        ]
        .iter()
        .flat_map(|t| values((*t).clone()))
        .collect()
    }

    fn assert_close(what: &str, a: &[f32], b: &[f32], tol: f32) {
        assert_eq!(a.len(), b.len(), "{what}: lengths");
        let scale = b.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-6);
        let worst = a.iter().zip(b).fold(0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= tol * scale,
            "{what}: max |fused − composed| {worst} against scale {scale}"
        );
    }

    #[test]
    fn fused_terms_and_gradients_equal_the_composed_loss() {
        let dev = default_device().autodiff();
        for (seed, k, direction, heading) in [
            (1, 1, true, HeadingLoss::Sin),
            (2, 3, false, HeadingLoss::Wrap),
            (3, 2, true, HeadingLoss::Wrap),
        ] {
            let (out, targets) = case(&dev, k, direction, seed);
            let cfg = LossConfig::new()
                .with_heading(heading)
                .with_gamma(if k == 3 { 1.5 } else { 2.0 })
                .with_class_weights(if k == 2 { vec![3.5, 3.25] } else { Vec::new() });
            let fused = starnet_loss(&out, &targets, &cfg);
            let composed = starnet_loss_composed(&out, &targets, &cfg);
            let (f, c) = (terms(&fused), terms(&composed));
            assert!(c[2] > 0.0 && c[1] > 0.0, "the case has foreground and background");
            assert_close("terms", &f, &c, 1e-5);
            let (gf, gc) = (fused.total.backward(), composed.total.backward());
            let mut inputs = vec![
                ("class logits", out.cls_logits.clone()),
                ("box residuals", out.box_residuals.clone()),
            ];
            inputs.extend(out.dir_logits.clone().map(|d| ("direction logits", d)));
            for (what, x) in inputs {
                let (a, b) = (
                    x.grad(&gf).expect("fused gradient"),
                    x.grad(&gc).expect("composed gradient"),
                );
                assert_close(what, &values(a), &values(b), 1e-4);
            }
        }
    }

    #[test]
    fn fused_terms_on_a_plain_device_equal_the_composed_loss() {
        let dev = default_device();
        let (out, targets) = case(&dev, 1, true, 4);
        let cfg = LossConfig::new();
        assert!(
            op_applies(&out, &targets, &cfg),
            "the plain flex device takes the fused path"
        );
        assert_close(
            "terms",
            &terms(&starnet_loss(&out, &targets, &cfg)),
            &terms(&starnet_loss_composed(&out, &targets, &cfg)),
            1e-5,
        );
    }

    /// Class weights scale each class's column: the weighted term is the weighted sum of the
    /// terms each class alone gives, on both paths.
    #[test]
    fn class_weights_scale_their_columns() {
        let dev = default_device();
        let (out, targets) = case(&dev, 2, false, 5);
        let classification = |w: Vec<f64>, fused: bool| {
            let cfg = LossConfig::new().with_class_weights(w).with_fused(fused);
            values(starnet_loss(&out, &targets, &cfg).classification)[0]
        };
        for fused in [true, false] {
            let (first, second) = (
                classification(vec![1.0, 0.0], fused),
                classification(vec![0.0, 1.0], fused),
            );
            assert!(first > 0.0 && second > 0.0);
            let both = classification(vec![3.5, 3.25], fused);
            assert!(
                (both - (3.5 * first + 3.25 * second)).abs() < 1e-5 * both,
                "fused {fused}: {both}"
            );
            let unweighted = classification(Vec::new(), fused);
            assert!((unweighted - (first + second)).abs() < 1e-5 * unweighted);
        }
    }

    fn op_applies(out: &ModelOutput, t: &LossTargets, cfg: &LossConfig) -> bool {
        loss_terms(out, t, &crate::loss::starnet_loss::kernel_config(cfg)).is_some()
    }
}
