//! [`average_gradients`]: every parameter's gradient averaged over the replicas in one sum of
//! one flat buffer per step (`MPI_Allreduce` of the whole model, not one call per tensor).

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::prelude::*;
use burn::tensor::TensorData;
use starnet_model::replicas::Replicas;

/// Collects the gradients, flattened, in visiting order.
struct Gather<'a> {
    grads: &'a GradientsParams,
    flat: Vec<Tensor<1>>,
}

impl ModuleVisitor for Gather<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            let n = g.shape().num_elements();
            self.flat.push(g.reshape([n]));
        }
    }
}

/// Puts the averaged values back, in the same order.
struct Scatter<'a> {
    grads: &'a mut GradientsParams,
    values: &'a [f32],
    at: usize,
}

impl ModuleVisitor for Scatter<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.remove::<D>(param.id) {
            let shape = g.shape();
            let n = shape.num_elements();
            let data = TensorData::new(self.values[self.at..self.at + n].to_vec(), shape);
            self.grads.register::<D>(param.id, Tensor::from_data(data, &g.device()));
            self.at += n;
        }
    }
}

/// Replaces the gradients of `module` by their mean over `group` (every member calls it, with
/// the same module; those of a group of one are left as they are).
pub fn average_gradients<M: Module>(module: &M, grads: &mut GradientsParams, group: &dyn Replicas) {
    if group.size() < 2 {
        return;
    }
    let mut gather = Gather {
        grads,
        flat: Vec::new(),
    };
    module.visit(&mut gather);
    if gather.flat.is_empty() {
        return;
    }
    let mut values: Vec<f32> = Tensor::cat(gather.flat, 0).into_data().iter::<f32>().collect();
    group.sum_f32(&mut values);
    let n = group.size() as f32;
    values.iter_mut().for_each(|v| *v /= n);
    module.visit(&mut Scatter {
        grads,
        values: &values,
        at: 0,
    });
}
