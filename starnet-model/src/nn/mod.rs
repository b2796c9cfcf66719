//! The network's layers: masked batch normalisation, the StarNet block, the featurizer, and
//! the model with its projector and heads, and the streaming variant's LSTM over slices; how the
//! composed layers lay out a batch's rows for the backend ([`row_layout`]).

mod block;
mod featurizer;
pub mod fused;
mod masked_bn;
pub mod row_layout;
mod slice_lstm;
mod starnet;

pub use block::{StarNetBlock, StarNetBlockConfig, masked_max, masked_mean};
pub use featurizer::{Featurizer, FeaturizerConfig};
pub use masked_bn::{MaskedBatchNorm, MaskedBatchNormConfig, RunningStats};
pub use row_layout::{RowGroups, RowLayout};
pub use slice_lstm::{SliceLstm, SliceLstmConfig, SliceState};
pub use starnet::{ModelInput, ModelOutput, StarNet, StarNetConfig};

use burn::nn::{Initializer, Linear, LinearConfig};
use burn::prelude::Device;

/// A linear layer with lingvo's initialisation: Kaiming-uniform weights with bound √(6 / fan_in)
/// (gain √2) and, if it has one, a zero bias.
pub(crate) fn linear(d_in: usize, d_out: usize, bias: bool, device: &Device) -> Linear {
    let mut l = LinearConfig::new(d_in, d_out)
        .with_bias(bias)
        .with_initializer(Initializer::KaimingUniform {
            gain: std::f64::consts::SQRT_2,
            fan_out_only: false,
        })
        .init(device);
    if bias {
        l.bias = Some(Initializer::Zeros.init([d_out], device));
    }
    l
}
