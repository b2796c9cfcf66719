//! [`LossTargets`]: a batch's per-anchor targets as the loss reads them.

use burn::prelude::*;

/// Per-anchor targets of a batch, as tensors.
#[derive(Debug, Clone)]
pub struct LossTargets {
    /// One-hot classes `[B, C, A, K]` (all zeros for background).
    pub classes: Tensor<4>,
    /// Classification weight `[B, C, A]`.
    pub cls_weight: Tensor<3>,
    /// Encoded residuals `[B, C, A, 7]`.
    pub residuals: Tensor<4>,
    /// Regression weight `[B, C, A]` (foreground only).
    pub reg_weight: Tensor<3>,
    /// Direction bin of the matched box `[B, C, A]` (0.0 or 1.0; see [`crate::coder`]).
    pub direction: Tensor<3>,
}
