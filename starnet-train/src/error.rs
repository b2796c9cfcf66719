//! Errors of the train crate; each names the file or setting at fault.

use std::path::PathBuf;

/// Errors from the commands of this crate.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// Reading or parsing data failed.
    #[error(transparent)]
    Data(#[from] starnet_data::DataError),
    /// Encoding an image failed.
    #[error("{path}: cannot encode PNG: {message}")]
    Image {
        /// The image being written.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// A config file (or `--set` override) with an unknown key, a wrong type or a bad value.
    #[error("{file}: {key}: {message}")]
    Config {
        /// The file (or `--set`).
        file: PathBuf,
        /// The dotted key, e.g. `train.learning_rate`.
        key: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A checkpoint that cannot be read or written.
    #[error("{path}: {message}")]
    Checkpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// Training stopped on a non-finite loss.
    #[error("step {step}: the loss is {value}; stopping (the last good checkpoint is kept)")]
    NonFiniteLoss {
        /// The step at which it happened.
        step: u64,
        /// The loss value.
        value: f32,
    },
    /// Training stopped on a non-finite gradient (the loss itself finite, as when the backward
    /// pass overflows).
    #[error("step {step}: the gradient norm is {norm}; stopping (the last good checkpoint is kept)")]
    NonFiniteGradient {
        /// The step at which it happened.
        step: u64,
        /// The global gradient norm.
        norm: f32,
    },
    /// A training log line that is not a log record.
    #[error("{path}: line {line}: {message}")]
    Log {
        /// The log file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// A run folder that already holds checkpoints, trained into without resuming.
    #[error("{dir} already holds checkpoints: resume the run, or choose another run folder")]
    RunExists {
        /// The run folder.
        dir: PathBuf,
    },
    /// An output folder that already holds what would be written into it.
    #[error("{dir} already holds generated data; choose an empty folder")]
    NotEmpty {
        /// The folder.
        dir: PathBuf,
    },
    /// A folder without the inputs a command reads.
    #[error("{dir} holds no {what}")]
    NoInput {
        /// The folder.
        dir: PathBuf,
        /// What was looked for, and where it would come from.
        what: String,
    },
    /// Drawing a chart or a bird's-eye view failed (`plotters`' message).
    #[error("drawing failed: {0}")]
    Draw(String),
    /// The training step's compute threads could not be started.
    #[error("cannot start the training step's {threads} compute threads: {source}")]
    Threads {
        /// How many were asked for.
        threads: usize,
        /// Why not.
        source: rayon::ThreadPoolBuildError,
    },
    /// A command-line or config value out of range.
    #[error("{name}: {message}")]
    InvalidArgument {
        /// The argument or key.
        name: String,
        /// What is wrong and what is expected.
        message: String,
    },
}

/// Result with [`TrainError`].
pub type Result<T> = std::result::Result<T, TrainError>;
