//! The one error type of the data crate. Every variant names the file, and for text formats
//! the line (1-based) and field, so a user can open the file and fix it.

use std::path::PathBuf;

/// Errors from reading, parsing or writing data files.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A velodyne `.bin` whose size is not a whole number of 16-byte points.
    #[error(
        "{path}: {len} bytes is not a multiple of 16 (x, y, z, reflectance as f32); the file is truncated or not a KITTI velodyne scan"
    )]
    TruncatedPoints {
        /// The file.
        path: PathBuf,
        /// Its size in bytes.
        len: u64,
    },
    /// A point with a NaN or infinite coordinate.
    #[error("{path}: point {index} has a non-finite {field} ({value})")]
    NonFinitePoint {
        /// The file.
        path: PathBuf,
        /// 0-based index of the point.
        index: usize,
        /// `x`, `y`, `z` or `reflectance`.
        field: &'static str,
        /// The offending value.
        value: f32,
    },
    /// A text file (label, calib, split, result) that does not parse.
    #[error("{path}:{line}: {field}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The field (or key) that is wrong.
        field: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A calib file without one of the keys every conversion needs.
    #[error("{path}: missing required calibration key `{key}`")]
    MissingCalibKey {
        /// The file.
        path: PathBuf,
        /// The missing key, e.g. `Tr_velo_to_cam`.
        key: &'static str,
    },
    /// A data-loader job panicked (a bug); the message is the panic's.
    #[error("data loader: preparing item {index} failed unexpectedly: {message}")]
    WorkerPanic {
        /// The item being prepared.
        index: usize,
        /// The panic message.
        message: String,
    },
    /// A frame listed in a split (or asked for) whose file is absent.
    #[error("frame {frame}: {path} does not exist")]
    MissingFile {
        /// The frame id.
        frame: String,
        /// The expected file.
        path: PathBuf,
    },
}

/// Result with [`DataError`].
pub type Result<T> = std::result::Result<T, DataError>;

impl DataError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A parse error at `path:line` in `field`.
    pub fn parse(path: impl Into<PathBuf>, line: usize, field: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Parse {
            path: path.into(),
            line,
            field: field.into(),
            message: message.into(),
        }
    }
}
