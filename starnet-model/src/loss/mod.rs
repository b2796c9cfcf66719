//! StarNet's losses (paper §3.3, lingvo `starnet.py`): a sigmoid focal loss per class, Huber
//! (smooth-L1, δ = 1/9) on the foreground residuals, and the heading as Huber(sin Δ)
//! (direction-invariant, the authors' default) or Huber(wrap Δ) (direction-aware, needed for
//! APH). Every anchor carries the weight target assignment gave it (`1 / (C · max(1, n_fg))`);
//! terms are summed over centers, anchors and classes and averaged over the batch.
//! Total = 3 · (3 · location + 0.3 · dimension + 0.3 · rotation) + classification, plus
//! `direction_weight` · the cross-entropy of the direction bins on the foreground anchors when
//! the model has the direction classifier (OpenPCDet: weight 0.2, same anchor weights).
//!
//! On flex the five terms are one fused operation ([`op::loss_terms`], the maths in
//! [`kernel`]) unless [`LossConfig::fused`] is off; [`starnet_loss_composed`] is the reference
//! and the path on every other backend.

mod heading;
pub mod kernel;
pub mod op;
mod starnet_loss;
mod targets;

pub use heading::HeadingLoss;
pub use starnet_loss::{
    LossConfig, LossTerms, huber, sigmoid_focal, starnet_loss, starnet_loss_composed, two_bin_cross_entropy, wrap_angle,
};
pub use targets::LossTargets;
