//! StarNet training, streaming and temporal evaluation, export and visualisation: the library
//! behind the `starnet` binary, so other front-ends and tests can call every command as a
//! function. Frames, box layout and shape letters are those of [`starnet_data`]'s crate docs;
//! the metrics and result scoring are [`starnet_eval`]'s.
//!
//! Two layers: the concepts ([`config`], [`budget`], [`detector`], [`trained`], [`evaluate`],
//! [`train`], [`stream`], [`temporal`], [`export`], [`render`], [`distributed`]) and, above
//! them, [`commands`]: the CLI subcommands that have code of their own, one file each. The
//! library never prints: it reports through [`starnet_data::events`].

#![warn(missing_docs)]

pub mod budget;
pub mod commands;
pub mod config;
pub mod detector;
pub mod distributed;
pub mod error;
pub mod evaluate;
pub mod export;
pub mod json;
pub mod render;
pub mod stream;
pub mod temporal;
pub mod train;
pub mod trained;

pub use error::{Result, TrainError};

// The README's code blocks compile as doctests: its library examples are the API as it stands.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
struct ReadmeDoctests;
