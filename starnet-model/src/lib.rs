//! StarNet model in Burn: featurizer, anchor heads, targets, losses, decoding and NMS
//! (built up by issue #5). Frames, box layout and shape letters (`B C P F A K`) are those of
//! [`starnet_data`]'s crate docs.
//!
//! The code is backend-agnostic: tensors live on a [`burn::prelude::Device`] chosen at run
//! time. [`backend::default_device`] gives the CPU device of the backend this build enables
//! (cargo features `flex` — the default, chosen by measurement in `BENCHMARKS.md` —,
//! `x86-v4` and `ndarray`).

#![warn(missing_docs)]

pub mod assign;
pub mod backend;
pub mod batch;
pub mod coder;
pub mod export;
mod flex_data;
pub mod flops;
pub mod loss;
pub mod nms;
pub mod nn;
pub mod onnx;
pub mod replicas;
#[cfg(test)]
mod testing;
