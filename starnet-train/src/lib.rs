//! StarNet training, streaming and temporal evaluation, export and visualisation: the library
//! behind the `starnet` binary, so other front-ends and tests can call every command as a
//! function. Frames, box layout and shape letters are those of [`starnet_data`]'s crate docs;
//! the metrics and result scoring are [`starnet_eval`]'s.
//!
//! One module per concept, each a function a front-end can call for a `starnet` subcommand:
//! [`config`], [`budget`], [`checkpoint`], [`detector`] and [`trained`] (a model at a budget, loaded from a
//! checkpoint or an export), [`train`] (the loop, its checkpoints and curves), [`evaluate`]
//! (every way of evaluating, in one place), [`stream`] and [`temporal`] (the papers' streaming
//! and temporal detection), [`detect`] (raw sweeps from files), [`export`], [`render`] (plots,
//! bird's-eye views, 3D recordings), [`report`], [`inspect`], [`realism`], [`synth`] and
//! [`distributed`]. The binary's `commands/` is one thin file per subcommand over these. The
//! library never prints: it reports through [`starnet_data::events`].

#![warn(missing_docs)]

pub mod budget;
pub mod checkpoint;
pub mod config;
pub mod detect;
pub mod detector;
pub mod distributed;
pub mod error;
pub mod evaluate;
pub mod export;
pub mod inspect;
pub mod json;
pub mod realism;
pub mod render;
pub mod report;
pub mod stream;
pub mod synth;
pub mod temporal;
pub mod train;
pub mod trained;

pub use error::{Result, TrainError};

// The README's code blocks compile as doctests: its library examples are the API as it stands.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
struct ReadmeDoctests;
