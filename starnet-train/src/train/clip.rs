//! Gradient clipping by global norm (TensorFlow's `clip_by_global_norm`, the authors' 5.0).
//! Burn's built-in clipping works per parameter tensor, which is not the same thing.

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::prelude::*;

struct SquaredNorms<'a> {
    grads: &'a GradientsParams,
    squares: Vec<Tensor<1>>,
}

impl ModuleVisitor for SquaredNorms<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            self.squares.push(g.powi_scalar(2).sum());
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

/// Each parameter's squared gradient norm, `[1]` each in visiting order, left on the device:
/// a caller reads them back with whatever else it needs from the step, in one transfer.
pub fn squared_grad_norms<M: Module>(module: &M, grads: &GradientsParams) -> Vec<Tensor<1>> {
    let mut n = SquaredNorms {
        grads,
        squares: Vec::new(),
    };
    module.visit(&mut n);
    n.squares
}

/// The global L2 norm of per-parameter squared norms (summed in f64, in order).
pub fn global_norm(squares: &[f32]) -> f32 {
    squares.iter().map(|&s| f64::from(s)).sum::<f64>().sqrt() as f32
}

/// Scales the gradients of `module` so that their global norm, `norm`, becomes at most
/// `max_norm` (a non-finite norm leaves them).
pub fn scale_to_norm<M: Module>(module: &M, grads: &mut GradientsParams, norm: f32, max_norm: f32) {
    if norm > max_norm && norm.is_finite() {
        module.visit(&mut Scale {
            grads,
            factor: max_norm / norm,
        });
    }
}

/// Scales the gradients of `module` so their global L2 norm is at most `max_norm`; returns the
/// norm before clipping.
pub fn clip_global_norm<M: Module>(module: &M, grads: &mut GradientsParams, max_norm: f32) -> f32 {
    let squares = squared_grad_norms(module, grads);
    let norm = match squares.is_empty() {
        true => 0.0,
        false => global_norm(&Tensor::cat(squares, 0).into_data().iter::<f32>().collect::<Vec<_>>()),
    };
    scale_to_norm(module, grads, norm, max_norm);
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
        let after: Vec<f32> = squared_grad_norms(&l, &grads)
            .into_iter()
            .map(|t| t.into_scalar::<f32>())
            .collect();
        assert!((global_norm(&after) - 5.0).abs() < 1e-4, "{after:?}");
    }
}
