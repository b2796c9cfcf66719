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
    /// An output folder that already holds files, where a command writes a whole new folder.
    #[error("{path} is not empty: the output goes into a new or empty folder (delete this one to write it again)")]
    Occupied {
        /// The folder.
        path: PathBuf,
    },
    /// A point beyond the config's limit, with `pipeline.wild_points.action = "refuse"`.
    #[error(
        "{path}: point {index} at {point:?} lies beyond {limit} m (pipeline.wild_points.limit); set pipeline.wild_points.action = \"drop\" to drop such points"
    )]
    WildPoint {
        /// The file.
        path: PathBuf,
        /// 0-based index of the point.
        index: usize,
        /// Its x, y, z.
        point: [f32; 3],
        /// The limit, metres.
        limit: f32,
    },
    /// A read-only root without a paste database, and no cache folder to build one in.
    #[error(
        "{root} is read-only and holds no paste database, and no cache folder is known to build one in: set STARNET_CACHE_DIR (or HOME)"
    )]
    NoCacheDir {
        /// The dataset root.
        root: PathBuf,
    },
    /// A point with a NaN or infinite coordinate.
    #[error("{path}: point {index} has a non-finite {field} ({value})")]
    NonFinitePoint {
        /// The file.
        path: PathBuf,
        /// 0-based index of the point.
        index: usize,
        /// `x`, `y`, `z`, `reflectance` (KITTI) or `intensity` (other point clouds).
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
    /// A point-cloud path whose extension is none of `crate::cloud::CLOUD_EXTENSIONS`: the
    /// extension is what picks the reader.
    #[error("{path}: not a point-cloud file name: the extension must be one of .bin, .pcd, .ply, .npy")]
    UnknownCloudExtension {
        /// The file.
        path: PathBuf,
    },
    /// A cloud written under an extension of another format, which [`crate::cloud::read_cloud`]
    /// would then misread.
    #[error("{path}: a {format} cloud must be written to a `.{extension}` file")]
    WrongCloudExtension {
        /// The file.
        path: PathBuf,
        /// The format asked for, e.g. `PCD (binary)`.
        format: String,
        /// The extension that format takes.
        extension: &'static str,
    },
    /// A point-cloud header (PCD, PLY, `.npy`) that is malformed, inconsistent or describes a
    /// cloud this crate does not read (e.g. no `x` field, an integer dtype).
    #[error("{path}: {message}")]
    CloudHeader {
        /// The file.
        path: PathBuf,
        /// What is wrong, what was found and what is accepted.
        message: String,
    },
    /// A point-cloud header that declares more data than the file holds.
    #[error(
        "{path}: the header declares {needed} {unit} of point data but the file has {available}; it is truncated or its header is wrong"
    )]
    CloudTruncated {
        /// The file.
        path: PathBuf,
        /// What the header declares.
        needed: u64,
        /// What the file holds.
        available: u64,
        /// `bytes` (binary encodings) or `lines` (text encodings).
        unit: &'static str,
    },
    /// Point-cloud data (after a valid header) that does not parse.
    #[error("{path}: {message}")]
    CloudData {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the point's index where known.
        message: String,
    },
    /// A cloud without an intensity channel written as a KITTI `.bin`, which has no way to say
    /// so: the zeros would be read back as measured reflectance.
    #[error(
        "{path}: the cloud has no intensity channel and a KITTI .bin cannot say so (its zeros would read as measured reflectance); write .npy, .pcd or .ply instead"
    )]
    NoIntensityChannel {
        /// The file.
        path: PathBuf,
    },
    /// A frame listed in a split (or asked for) whose file is absent.
    #[error("frame {frame}: {path} does not exist")]
    MissingFile {
        /// The frame id.
        frame: String,
        /// The expected file.
        path: PathBuf,
    },
    /// A point cloud without an intensity channel where the reflectance is read (a model whose
    /// `pipeline.gather.reflectance` is `measured`, or a conversion to KITTI's `.bin`).
    #[error(
        "{path}: the cloud has no intensity channel, and this model reads the reflectance: use a geometry-only model (pipeline.gather.reflectance = \"ignored\", as the quickstart's) or a cloud with intensity"
    )]
    MissingIntensity {
        /// The file.
        path: PathBuf,
    },
    /// Camera labels asked of a dataset in the custom layout, whose labels are LiDAR-frame boxes
    /// all around the sensor.
    #[error(
        "{root}: a dataset in the custom layout (points/, labels/) has all-around labels only: set data.labels = \"label_360\""
    )]
    CustomLayoutLabels {
        /// The dataset root.
        root: PathBuf,
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
