//! StarNet training, evaluation, export and visualisation: the library behind the `starnet`
//! binary, so other front-ends and tests can call every command as a function.
//! Frames, box layout and shape letters are those of [`starnet_data`]'s crate docs.

#![warn(missing_docs)]

pub mod budget;
pub mod config;
pub mod coverage;
pub mod curves;
pub mod detect;
pub mod detector;
pub mod distributed;
pub mod error;
pub mod eval;
pub mod export;
pub mod inspect;
pub mod prepare;
pub mod realism;
pub mod render;
pub mod stream;
pub mod synth;
pub mod table;
pub mod temporal;
pub mod train;
pub mod trained;

pub use error::{Result, TrainError};

// The README's code blocks compile as doctests: its library examples are the API as it stands.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
struct ReadmeDoctests;
