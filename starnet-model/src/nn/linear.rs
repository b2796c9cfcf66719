//! The linear layers of every block and head, initialised as lingvo initialises them.

use burn::nn::{Initializer, Linear, LinearConfig};
use burn::prelude::Device;

/// Whether a linear layer adds a bias.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Bias {
    /// A bias, initialised to zero.
    Zero,
    /// None: the layers a BatchNorm follows (its shift does a bias's work), and the heads built
    /// without one.
    Omitted,
}

/// A linear layer with lingvo's initialisation: Kaiming-uniform weights with bound √(6 / fan_in)
/// (gain √2) and, if it has one, a zero bias.
pub(crate) fn linear(d_in: usize, d_out: usize, bias: Bias, device: &Device) -> Linear {
    let mut l = LinearConfig::new(d_in, d_out)
        .with_bias(bias == Bias::Zero)
        .with_initializer(Initializer::KaimingUniform {
            gain: std::f64::consts::SQRT_2,
            fan_out_only: false,
        })
        .init(device);
    if bias == Bias::Zero {
        l.bias = Some(Initializer::Zeros.init([d_out], device));
    }
    l
}
