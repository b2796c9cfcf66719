//! Errors of the evaluation crate; each names the file, folder or argument at fault.

use std::path::PathBuf;

/// Errors from scoring and reading results.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// Reading or parsing labels, calibrations, scans or result files failed.
    #[error(transparent)]
    Data(#[from] starnet_data::DataError),
    /// A folder without the inputs a command reads.
    #[error("{dir} holds no {what}")]
    NoInput {
        /// The folder.
        dir: PathBuf,
        /// What was looked for, and where it would come from.
        what: String,
    },
    /// An argument that does not fit the data, e.g. a result format the labels cannot score.
    #[error("{name}: {message}")]
    InvalidArgument {
        /// The argument, or the folder it names.
        name: String,
        /// What is wrong and what is expected.
        message: String,
    },
}

/// Result with [`EvalError`].
pub type Result<T> = std::result::Result<T, EvalError>;
