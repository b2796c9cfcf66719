//! The `starnet` subcommands that have code of their own, one file each, named as the CLI names
//! them: they assemble the concepts below them and report through [`starnet_data::events`].
//! (`train`, `stream-eval`, `export`, `render`, `prepare` and `config` are one call each into
//! [`crate::train`], [`crate::stream`], [`crate::export`], [`crate::render`] and
//! [`crate::config`].)

pub mod compare_data;
pub mod coverage;
pub mod detect;
pub mod eval;
pub mod eval_run;
pub mod inspect;
pub mod plot;
pub mod synth;
