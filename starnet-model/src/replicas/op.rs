//! [`all_sum`]: a tensor summed over the replica group as one autodiff operation. With
//! `y = Σ_r x_r` on every replica and the global loss `Σ_r L_r`, the gradient reaching `x_r` is
//! `Σ_r ∂L_r/∂y`: the backward is the same sum, of the gradients.

use super::{current, sum};
use crate::flex_data::{flex, values};
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops};
use burn::backend::flex::FlexTensor;
use burn::backend::{Autodiff, Flex};
use burn::prelude::*;
use burn::tensor::TensorData;

#[derive(Debug)]
struct AllSumBackward;

impl Backward<Flex, 1> for AllSumBackward {
    type State = ();

    fn backward(self, ops: Ops<(), 1>, grads: &mut Gradients, _: &mut Checkpointer) {
        let upstream = grads.consume::<Flex>(&ops.node);
        let [parent] = ops.parents;
        if let Some(node) = parent {
            grads.register::<Flex>(node.id, summed(&upstream));
        }
    }
}

/// The element-wise sum of `t` over the calling thread's group, as a new flex tensor.
fn summed(t: &FlexTensor) -> FlexTensor {
    let mut v = values(t).into_owned();
    sum(&mut v);
    flex(v, t.layout().shape().to_vec())
}

/// `x` summed element-wise over the calling thread's replica group ([`super::scope`]),
/// differentiably; `x` itself outside a group.
///
/// # Panics
/// Inside a group of more than one, on an autodiff device other than flex's (f32): the
/// distributed trainer checks the device before it installs a group.
pub fn all_sum<const D: usize>(x: Tensor<D>) -> Tensor<D> {
    if current().is_none() {
        return x;
    }
    let device = x.device();
    if !device.is_autodiff() {
        let shape = x.shape();
        let mut v: Vec<f32> = x.into_data().iter::<f32>().collect();
        sum(&mut v);
        return Tensor::from_data(TensorData::new(v, shape), &device);
    }
    let (prim, guard) = x
        .try_into_primitive::<Autodiff<Flex>>()
        .expect("synchronised BatchNorm runs on autodiff-flex")
        .into_parts();
    let out = AllSumBackward
        .prepare::<NoCheckpointing>([guard])
        .compute_bound()
        .stateless(summed(&prim));
    Tensor::from_primitive::<Autodiff<Flex>>(out)
}

/// Whether synchronised BatchNorm can train on `device`: autodiff over flex.
pub fn supported(device: &Device) -> bool {
    device.is_autodiff()
        && Tensor::<1>::zeros([1], device)
            .try_into_primitive::<Autodiff<Flex>>()
            .is_ok()
}
