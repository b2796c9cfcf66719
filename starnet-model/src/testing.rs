//! Seeded random tensors for the tests.
//!
//! `Tensor::random` draws from the backend's generator, which is seeded from entropy unless
//! `Backend::seed` ran first; tests built on it would see other inputs on every run (and
//! `Backend::seed` is process-wide, shared by tests running in parallel). These draw from an
//! explicit [`ChaCha8Rng`] instead.

use burn::prelude::{Device, Tensor};
use burn::tensor::TensorData;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The generator every test helper draws from, started at `seed`.
pub(crate) fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A tensor of `shape` with independent N(0, `std`²) entries.
pub(crate) fn normal<const D: usize>(shape: [usize; D], std: f32, rng: &mut ChaCha8Rng, dev: &Device) -> Tensor<D> {
    let normal = Normal::new(0.0f32, std).expect("a finite, non-negative deviation");
    let values = (0..shape.iter().product()).map(|_| normal.sample(rng)).collect();
    tensor(values, shape, dev)
}

/// A tensor of `shape` with independent entries uniform in `[low, high)`, drawn one by one
/// with `Rng::random_range` in row-major order.
pub(crate) fn uniform<const D: usize>(
    shape: [usize; D],
    low: f32,
    high: f32,
    rng: &mut ChaCha8Rng,
    dev: &Device,
) -> Tensor<D> {
    let values = (0..shape.iter().product())
        .map(|_| rng.random_range(low..high))
        .collect();
    tensor(values, shape, dev)
}

fn tensor<const D: usize>(values: Vec<f32>, shape: [usize; D], dev: &Device) -> Tensor<D> {
    Tensor::from_data(TensorData::new(values, shape), dev)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;

    #[test]
    fn the_same_seed_draws_the_same_tensor_and_another_seed_another() {
        let dev = default_device();
        let draw = |seed| {
            normal([3, 5], 1.0, &mut rng(seed), &dev)
                .into_data()
                .try_into_vec::<f32>()
                .unwrap()
        };
        assert_eq!(draw(7), draw(7));
        assert_ne!(draw(7), draw(8));
        let u = uniform([1000], -2.0, 3.0, &mut rng(1), &dev)
            .into_data()
            .try_into_vec::<f32>()
            .unwrap();
        assert!(u.iter().all(|v| (-2.0..3.0).contains(v)));
        // 1000 draws of U(-2, 3): mean 0.5, standard error 5 / sqrt(12 · 1000) ≈ 0.046.
        let mean = u.iter().sum::<f32>() / 1000.0;
        assert!((mean - 0.5).abs() < 0.2, "{mean}");
    }
}
