//! Data-parallel training's one hook into the model: sums over the *replicas* (the processes or
//! threads that each hold a copy of the model and compute on their shard of a batch), so that
//! every BatchNorm normalises with the statistics of the whole batch — synchronised BatchNorm —
//! in the forward and in the backward through those statistics. With it, N replicas on shards
//! of a batch compute what one model computes on the whole batch, to float rounding.
//!
//! A group is installed for the calling thread with [`scope`]; the forwards and backwards run on
//! that thread inside it (Burn's autodiff runs a backward on the thread that calls it) sum their
//! BatchNorms' statistics, and the gradients through them, over the group. Every replica must run
//! the same operations in the same order, as a data-parallel step does. Outside a scope, or in a
//! group of one, nothing is summed.
//!
//! The fused blocks sum on the host; the composed BatchNorm ([`crate::nn::MaskedBatchNorm`])
//! through [`op::all_sum`], an autodiff operation on flex whose backward is again a sum.

mod group;
pub mod op;

pub use group::{Replicas, current, scope, sum, sum_scalar};
pub use op::supported;
