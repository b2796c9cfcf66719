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
