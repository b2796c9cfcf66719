//! The streaming model's recurrent bottleneck (the streaming-detection paper, §3.4): per slice,
//! the mean of its centers' cell features (as the projector's BatchNorm leaves them) feeds a
//! single-layer LSTM whose output, projected back to the cell width, is added to every center's
//! normalised cell feature of that slice. The state runs across the slices of one sweep, so a
//! slice sees a summary of the sweep so far. The projection starts at zero, so an untrained
//! LSTM leaves the stateless model as it is (every slice starts without a random offset).

use burn::module::Module;
use burn::nn::{Initializer, Linear, LinearConfig, Lstm, LstmConfig, LstmState};
use burn::prelude::*;

/// Configuration of [`SliceLstm`].
#[derive(Config, Debug)]
pub struct SliceLstmConfig {
    /// Cell-feature width (the LSTM's input and the projection's output).
    pub d_cell: usize,
    /// LSTM hidden width (the paper: 128).
    #[config(default = 128)]
    pub d_hidden: usize,
}

impl SliceLstmConfig {
    /// Builds the module.
    pub fn init(&self, device: &Device) -> SliceLstm {
        SliceLstm {
            lstm: LstmConfig::new(self.d_cell, self.d_hidden, true).init(device),
            out: zero_linear(self.d_hidden, self.d_cell, device),
        }
    }
}

/// A Linear whose weight and bias start at zero.
fn zero_linear(d_in: usize, d_out: usize, device: &Device) -> Linear {
    LinearConfig::new(d_in, d_out)
        .with_initializer(Initializer::Zeros)
        .init(device)
}

/// LSTM over slices, with an output projection to the cell width.
#[derive(Module, Debug)]
pub struct SliceLstm {
    lstm: Lstm,
    out: Linear,
}

/// The recurrent state after a slice: cell and hidden, `[B, H]` each.
pub type SliceState = LstmState<2>;

impl SliceLstm {
    /// # Shapes
    /// - `cells`: `[B, S, C, D]` normalised cell features of S consecutive slices of B sweeps
    /// - `valid`: `[B, S, C]` 1.0 for real centers (repeats pad a slice's small pool)
    /// - `state`: after the sweeps' earlier slices, `None` at a sweep's start
    /// - output: `[B, S, 1, D]` to add to every center of each slice, and the state after slice S
    pub fn forward(&self, cells: Tensor<4>, valid: Tensor<3>, state: Option<SliceState>) -> (Tensor<4>, SliceState) {
        let [b, s, _, d] = cells.dims();
        let v = valid.unsqueeze_dim::<4>(3); // [B, S, C, 1]
        // Mean over the real centers; a slice without any gets a zero input.
        let mean = (cells * v.clone()).sum_dim(2) / v.sum_dim(2).clamp_min(1.0); // [B, S, 1, D]
        let (h, state) = self.lstm.forward(mean.reshape([b, s, d]), state); // [B, S, H]
        let [_, _, hidden] = h.dims();
        let ctx = self.out.forward(h.reshape([b * s, hidden])); // [BS, D]
        (ctx.reshape([b, s, 1, d]), state)
    }
}
