//! The network's layers: masked batch normalisation, the StarNet block, the featurizer, and
//! the model with its projector and heads, and the streaming variant's LSTM over slices; how the
//! composed layers lay out a batch's rows for the backend ([`row_layout`]).

mod block;
mod featurizer;
pub mod fused;
mod linear;
mod masked_bn;
pub mod row_layout;
mod slice_lstm;
mod starnet;

pub use block::{StarNetBlock, StarNetBlockConfig, masked_max, masked_mean};
pub use featurizer::{Featurizer, FeaturizerConfig};
pub(crate) use linear::{Bias, linear};
pub use masked_bn::{MaskedBatchNorm, MaskedBatchNormConfig, RunningStats};
pub use row_layout::{RowGroups, RowLayout};
pub use slice_lstm::{SliceLstm, SliceLstmConfig, SliceState};
pub use starnet::{ModelInput, ModelOutput, StarNet, StarNetConfig};
