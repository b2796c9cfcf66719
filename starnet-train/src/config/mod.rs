//! Experiment configuration: one TOML file per experiment.
//!
//! A file may name another with `base = "other.toml"` (relative to itself); tables merge
//! recursively, the later file winning. `--set key.path=value` overrides come last (the value is
//! read as TOML, else as a string). The result is merged over the defaults of
//! [`ExperimentConfig::default`], which documents every key. A key the defaults do not have, or
//! a value of the wrong type, is an error naming the key and the file. The resolved config is
//! written beside every run.
//!
//! Keys a release renamed are read in their old spelling too ([`RENAMED`]), so the resolved
//! configs of older runs and the configs inside older exports still load.

mod experiment;
mod load;
mod sections;
#[cfg(test)]
mod tests;
mod validate;

pub use experiment::ExperimentConfig;
pub use load::{RENAMED, RenamedKey, load_config, parse_config, to_toml};
pub use sections::{DataSection, EvalSection, ModelSection, NmsSection, StreamSection, TrainSection};
