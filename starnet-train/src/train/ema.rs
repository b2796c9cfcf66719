//! Exponential moving average of the weights, used for evaluation (lingvo's `ema_decay`).
//!
//! After every optimizer step each float parameter's shadow moves toward it:
//! `shadow ← d·shadow + (1 − d)·w`, with TensorFlow's warm-up `d = min(decay, (1 + t) / (10 + t))`
//! at step `t` (lingvo passes the global step as `num_updates`), so the early shadows are not
//! dominated by the random initialisation. Like lingvo, the BatchNorm running statistics are not
//! averaged: [`WeightEma::apply`] takes them from the live model.

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::prelude::*;
use starnet_model::nn::StarNet;

/// The shadow weights, one flattened tensor per float parameter in visiting order.
#[derive(Debug, Clone)]
pub struct WeightEma {
    decay: f64,
    shadows: Vec<Tensor<1>>,
}

impl WeightEma {
    /// Starts the shadows at `model`'s current weights.
    pub fn new(decay: f64, model: &StarNet) -> Self {
        Self {
            decay,
            shadows: flat_params(model),
        }
    }

    /// The decay used after step `step` (1-based count of optimizer steps).
    pub fn decay_at(&self, step: u64) -> f64 {
        self.decay.min((1.0 + step as f64) / (10.0 + step as f64))
    }

    /// Moves the shadows toward `model`'s weights after step `step`.
    pub fn update(&mut self, model: &StarNet, step: u64) {
        let d = self.decay_at(step);
        let current = flat_params(model);
        assert_eq!(current.len(), self.shadows.len(), "EMA of a different architecture");
        for (s, w) in self.shadows.iter_mut().zip(current) {
            *s = s.clone().mul_scalar(d).add(w.mul_scalar(1.0 - d));
        }
    }

    /// `model` (in validation mode) with its float parameters replaced by the shadows; the
    /// BatchNorm running statistics stay `model`'s.
    pub fn apply(&self, model: &StarNet) -> StarNet {
        model.valid().map(&mut Replace {
            field: Vec::new(),
            shadows: &self.shadows,
            next: 0,
        })
    }
}

/// Every float parameter of `model`, flattened, on a plain (non-autodiff) device.
fn flat_params(model: &StarNet) -> Vec<Tensor<1>> {
    let mut collect = Collect {
        field: Vec::new(),
        params: Vec::new(),
    };
    model.valid().visit(&mut collect);
    collect.params
}

/// Whether the innermost field is a BatchNorm running statistic: Burn visits those
/// (`RunningState`) like parameters, but they are buffers, not weights.
fn is_running_stat(field: &[String]) -> bool {
    field.last().is_some_and(|f| f.starts_with("running_"))
}

struct Collect {
    field: Vec<String>,
    params: Vec<Tensor<1>>,
}

impl ModuleVisitor for Collect {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.field.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.field.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if !is_running_stat(&self.field) {
            self.params.push(param.val().flatten(0, D - 1));
        }
    }
}

struct Replace<'a> {
    field: Vec<String>,
    shadows: &'a [Tensor<1>],
    next: usize,
}

impl ModuleMapper for Replace<'_> {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.field.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.field.pop();
    }

    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        if is_running_stat(&self.field) {
            return param;
        }
        let shadow = self.shadows[self.next].clone();
        self.next += 1;
        param.map(|t| shadow.reshape(t.shape()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_model::nn::StarNetConfig;

    fn first_param(model: &StarNet) -> Vec<f32> {
        flat_params(model)[0].to_data().try_to_vec::<f32>().unwrap()
    }

    #[test]
    fn warm_up_then_fixed_decay() {
        let device = starnet_model::backend::default_device();
        let ema = WeightEma::new(0.99, &StarNetConfig::small_car().init(&device));
        assert!((ema.decay_at(0) - 0.1).abs() < 1e-12);
        assert!((ema.decay_at(8) - 0.5).abs() < 1e-12);
        assert_eq!(ema.decay_at(10_000), 0.99);
    }

    #[test]
    fn shadows_follow_the_hand_computed_average() {
        let device = starnet_model::backend::default_device();
        let a = StarNetConfig::small_car().init(&device);
        let b = StarNetConfig::small_car().init(&device);
        let (wa, wb) = (first_param(&a), first_param(&b));
        let mut ema = WeightEma::new(0.99, &a);
        // Step 8: d = 9/18 = 0.5, so the shadow is the midpoint of a and b.
        ema.update(&b, 8);
        let got = first_param(&ema.apply(&a));
        for ((g, x), y) in got.iter().zip(&wa).zip(&wb) {
            assert!((g - 0.5 * (x + y)).abs() < 1e-6, "{g} vs {x} {y}");
        }
        // Every parameter is replaced, in order: applying a's own shadows gives a back.
        let same = WeightEma::new(0.99, &a).apply(&b);
        let (pa, ps) = (flat_params(&a), flat_params(&same));
        assert_eq!(pa.len(), ps.len());
        for (x, y) in pa.iter().zip(&ps) {
            assert_eq!(x.to_data(), y.to_data());
        }
    }

    #[test]
    fn running_statistics_are_not_averaged() {
        let device = starnet_model::backend::default_device();
        let model = StarNetConfig::small_car().init(&device);
        // Weights only: per BatchNorm γ and β, not the running mean and variance.
        struct All<'a>(&'a mut usize);
        impl ModuleVisitor for All<'_> {
            fn visit_float<const D: usize>(&mut self, _: &Param<Tensor<D>>) {
                *self.0 += 1;
            }
        }
        let mut count = 0;
        model.visit(&mut All(&mut count));
        let shadows = WeightEma::new(0.99, &model).shadows.len();
        // small_car: 7 BatchNorms (2 per block × 3 + the projector), each with 2 running stats.
        assert_eq!(count - shadows, 14);
    }
}
