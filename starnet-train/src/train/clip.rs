//! Gradient clipping by global norm (TensorFlow's `clip_by_global_norm`, the authors' 5.0).
//! Burn's built-in clipping works per parameter tensor, which is not the same thing.

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::prelude::*;

struct SquaredNorm<'a> {
    grads: &'a GradientsParams,
    sum: f64,
}

impl ModuleVisitor for SquaredNorm<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            self.sum += g.powi_scalar(2).sum().into_scalar::<f32>() as f64;
        }
    }
}

struct Scale<'a> {
    grads: &'a mut GradientsParams,
    factor: f32,
}

impl ModuleVisitor for Scale<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.remove::<D>(param.id) {
            self.grads.register::<D>(param.id, g.mul_scalar(self.factor));
        }
    }
}

/// Scales the gradients of `module` so their global L2 norm is at most `max_norm`; returns the
/// norm before clipping.
pub fn clip_global_norm<M: Module>(module: &M, grads: &mut GradientsParams, max_norm: f32) -> f32 {
    let mut n = SquaredNorm { grads, sum: 0.0 };
    module.visit(&mut n);
    let norm = n.sum.sqrt() as f32;
    if norm > max_norm && norm.is_finite() {
        module.visit(&mut Scale {
            grads,
            factor: max_norm / norm,
        });
    }
    norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::{Linear, LinearConfig};
    use starnet_model::backend::default_device;

    #[test]
    fn scales_to_the_global_norm() {
        let dev = default_device().autodiff();
        let l: Linear = LinearConfig::new(2, 1).init(&dev);
        // Loss 10·(w·x + b) with x = (3, 4): ∂/∂w = (30, 40), ∂/∂b = 10; global norm √2600.
        let x = Tensor::<2>::from_floats([[3.0, 4.0]], &dev);
        let loss = l.forward(x).sum().mul_scalar(10.0);
        let mut grads = GradientsParams::from_grads(loss.backward(), &l);
        let norm = clip_global_norm(&l, &mut grads, 5.0);
        assert!((norm - 2600f32.sqrt()).abs() < 1e-3, "{norm}");
        let mut after = SquaredNorm {
            grads: &grads,
            sum: 0.0,
        };
        l.visit(&mut after);
        assert!((after.sum.sqrt() - 5.0).abs() < 1e-4, "{}", after.sum.sqrt());
    }
}
