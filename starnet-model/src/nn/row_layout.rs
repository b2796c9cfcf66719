//! Products and sums over every point of a batch, in the shape a backend runs well (issue #50).
//!
//! A per-point layer's weight gradient and a BatchNorm's statistics reduce over all N = B·C·P
//! rows of a batch (131,072 at batch 16). Burn's `Linear` flattens every leading dimension into
//! that one long inner dimension, and a broadcast's backward sums it in one reduction. On the
//! CPU that is what the kernels want (and flex runs its fused kernels anyway); a GPU's matmul
//! and reduction kernels without split-K give such a reduction one workgroup. Laid out as
//! `[G, R, D]` with G·R = N, G and R both near √N, the same maths becomes G short products
//! summed over G, and every sum over rows two short sums (over R, then over G) — in the
//! forward and, through `expand`, in the backward.

use burn::nn::Linear;
use burn::prelude::*;
use serde::{Deserialize, Serialize};

/// How the composed layers lay out the rows of a batch: chosen by the backend unless set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RowLayout {
    /// Grouped on a GPU, flat on the CPU backends.
    #[default]
    Auto,
    /// One product and one sum over all N rows, as Burn's `Linear` and a plain broadcast compute them.
    Flat,
    /// `[G, R, D]` with G and R near √N (see the module docs).
    Grouped,
}

/// The `[G, R, ·]` view of N rows: `groups · rows = N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowGroups {
    /// G.
    pub groups: usize,
    /// R, rows per group.
    pub rows: usize,
}

/// Fewer groups than this gain nothing over one long reduction: N stays flat.
const MIN_GROUPS: usize = 4;

impl RowLayout {
    /// The view of `n` rows on `device`.
    pub fn groups(self, n: usize, device: &Device) -> RowGroups {
        let grouped = match self {
            Self::Auto => !on_a_cpu_backend(device),
            Self::Flat => false,
            Self::Grouped => true,
        };
        if grouped {
            RowGroups::balanced(n)
        } else {
            RowGroups::flat(n)
        }
    }
}

impl RowGroups {
    /// All `n` rows in one group.
    pub fn flat(n: usize) -> Self {
        Self { groups: 1, rows: n }
    }

    /// The largest G ≤ √n that divides n, or flat where that G is under 4 (n
    /// with no divisor near its root; batches of power-of-two widths always have one).
    pub fn balanced(n: usize) -> Self {
        let root = n.isqrt();
        let groups = (1..=root).rev().find(|g| n.is_multiple_of(*g)).unwrap_or(1);
        if groups < MIN_GROUPS {
            return Self::flat(n);
        }
        Self {
            groups,
            rows: n / groups,
        }
    }
}

/// Whether `device` is one of the CPU backends (flex, ndarray), with or without autodiff.
fn on_a_cpu_backend(device: &Device) -> bool {
    let device = device.clone().inner();
    #[cfg(feature = "flex")]
    if device == Device::flex() {
        return true;
    }
    #[cfg(feature = "ndarray")]
    #[allow(deprecated)] // ndarray is deprecated upstream; kept only as a comparison backend
    if device == Device::ndarray() {
        return true;
    }
    false
}

/// A `Linear` applied per row, as G products (and, for its bias, a per-channel vector whose
/// backward sums R rows, then G).
///
/// # Shapes
/// - `x`: `[G, R, C]`
/// - output: `[G, R, O]`
pub fn linear(layer: &Linear, x: Tensor<3>) -> Tensor<3> {
    let [_, r, _] = x.dims();
    let y = x.matmul(layer.weight.val().unsqueeze_dim(0)); // [G, R, O]
    match &layer.bias {
        Some(b) => y + per_channel(b.val(), r),
        None => y,
    }
}

/// [`linear`] on flat rows, laid out by `layout` on their device.
///
/// # Shapes
/// - `x`: `[N, C]`
/// - output: `[N, O]`
pub fn linear_flat(layout: RowLayout, layer: &Linear, x: Tensor<2>) -> Tensor<2> {
    let [n, c] = x.dims();
    let g = layout.groups(n, &x.device());
    let y = linear(layer, x.reshape([g.groups, g.rows, c]));
    let [_, _, o] = y.dims();
    y.reshape([n, o])
}

/// The sum over every row, R first, then G.
///
/// # Shapes
/// - `x`: `[G, R, D]`
/// - output: `[1, 1, D]`
pub fn sum_rows(x: Tensor<3>) -> Tensor<3> {
    x.sum_dim(1).sum_dim(0)
}

/// A per-channel vector laid over R rows, to be broadcast over G: its gradient sums G, then R.
///
/// # Shapes
/// - `v`: `[D]` (or anything of D elements, such as `[1, 1, D]`)
/// - output: `[1, R, D]`
pub fn per_channel<const K: usize>(v: Tensor<K>, rows: usize) -> Tensor<3> {
    let d = v.shape().num_elements();
    v.reshape([1, 1, d]).expand([1, rows, d])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;

    #[test]
    fn balanced_groups_are_divisors_near_the_root() {
        let g = |n| {
            let RowGroups { groups, rows } = RowGroups::balanced(n);
            (groups, rows)
        };
        assert_eq!(g(16_384), (128, 128)); // batch 2 × 256 centers × 32 points
        assert_eq!(g(131_072), (256, 512)); // batch 16 × 256 × 32
        assert_eq!(g(512 * 9), (64, 72));
        assert_eq!(g(12), (1, 12)); // the root's divisor is 3 < MIN_GROUPS: flat
        assert_eq!(g(131_071), (1, 131_071)); // a prime: flat
        assert_eq!(g(0), (1, 0));
    }

    #[test]
    fn auto_is_flat_on_the_cpu_and_the_choices_are_kept() {
        let dev = default_device();
        assert_eq!(RowLayout::Auto.groups(16_384, &dev), RowGroups::flat(16_384));
        assert_eq!(
            RowLayout::Auto.groups(16_384, &dev.clone().autodiff()),
            RowGroups::flat(16_384)
        );
        assert_eq!(RowLayout::Grouped.groups(16_384, &dev).groups, 128);
        assert_eq!(RowLayout::Flat.groups(16_384, &dev).groups, 1);
    }

    #[test]
    fn grouped_products_and_sums_equal_the_flat_ones() {
        let dev = default_device();
        let values: Vec<f32> = (0..24 * 5).map(|v| v as f32 / 7.0).collect();
        let x = Tensor::<1>::from_floats(values.as_slice(), &dev).reshape([24, 5]);
        let layer = crate::nn::linear(5, 3, crate::nn::Bias::Zero, &dev);
        let flat = layer.forward(x.clone());
        let grouped = linear(&layer, x.clone().reshape([4, 6, 5])).reshape([24, 3]);
        let diff: f32 = (flat - grouped).abs().max().into_scalar();
        assert!(diff < 1e-5, "{diff}");
        let sums: Vec<f32> = sum_rows(x.reshape([6, 4, 5])).into_data().iter::<f32>().collect();
        // Column j sums (5i + j)/7 over i < 24: (5·276 + 24 j)/7.
        let want: Vec<f32> = (0..5).map(|j| (5.0 * 276.0 + 24.0 * j as f32) / 7.0).collect();
        assert!(sums.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-3), "{sums:?}");
    }
}
