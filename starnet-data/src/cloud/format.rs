//! Which format a point-cloud file is in. The extension gives the family ([`CloudKind`]); a
//! reader takes the encoding (ascii, binary, ...) from the file's own header, so only a writer
//! has to be told it ([`CloudFormat`]).

use crate::{DataError, Result};
use std::fmt;
use std::path::Path;

/// The extensions [`super::read_cloud`] reads, without the dot: KITTI velodyne `.bin`, PCD,
/// PLY and NumPy `.npy`. Case-sensitive, as the dataset listings are.
pub const CLOUD_EXTENSIONS: [&str; 4] = ["bin", "pcd", "ply", "npy"];

/// A point-cloud file family, as its extension names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CloudKind {
    /// KITTI velodyne scan: little-endian f32 `x y z reflectance`, no header (`.bin`).
    KittiBin,
    /// PCL's Point Cloud Data (`.pcd`).
    Pcd,
    /// Polygon File Format, its `vertex` element (`.ply`).
    Ply,
    /// A NumPy array of shape (N, 3) or (N, 4) (`.npy`).
    Npy,
}

/// A PCD payload encoding (the header's `DATA` line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PcdEncoding {
    /// One text line per point.
    Ascii,
    /// Little-endian records, one after another.
    Binary,
    /// LZF-compressed columns (PCL's `binary_compressed`).
    BinaryCompressed,
}

/// A PLY payload encoding (the header's `format` line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlyEncoding {
    /// One text line per vertex.
    Ascii,
    /// Little-endian records.
    BinaryLittleEndian,
    /// Big-endian records.
    BinaryBigEndian,
}

/// A format and encoding to write a cloud in ([`super::write_cloud`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CloudFormat {
    /// KITTI velodyne `.bin`; needs a measured intensity (the format cannot say "none").
    KittiBin,
    /// PCD with `x y z [intensity]` as F32.
    Pcd(PcdEncoding),
    /// PLY with `x y z [intensity]` as float.
    Ply(PlyEncoding),
    /// `.npy` of `<f4`, shape (N, 4), or (N, 3) without intensity.
    Npy,
}

impl CloudKind {
    /// The family of `path` by its extension; any other extension is
    /// [`DataError::UnknownCloudExtension`].
    pub fn from_path(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("bin") => Ok(Self::KittiBin),
            Some("pcd") => Ok(Self::Pcd),
            Some("ply") => Ok(Self::Ply),
            Some("npy") => Ok(Self::Npy),
            _ => Err(DataError::UnknownCloudExtension { path: path.into() }),
        }
    }

    /// The extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Self::KittiBin => CLOUD_EXTENSIONS[0],
            Self::Pcd => CLOUD_EXTENSIONS[1],
            Self::Ply => CLOUD_EXTENSIONS[2],
            Self::Npy => CLOUD_EXTENSIONS[3],
        }
    }

    /// The format a writer uses for this family when not told an encoding: the binary one
    /// (exact and compact; PLY little-endian, as nearly every tool writes it).
    pub fn default_format(self) -> CloudFormat {
        match self {
            Self::KittiBin => CloudFormat::KittiBin,
            Self::Pcd => CloudFormat::Pcd(PcdEncoding::Binary),
            Self::Ply => CloudFormat::Ply(PlyEncoding::BinaryLittleEndian),
            Self::Npy => CloudFormat::Npy,
        }
    }
}

impl CloudFormat {
    /// Every format and encoding a cloud can be written in.
    pub const ALL: [CloudFormat; 8] = [
        Self::KittiBin,
        Self::Pcd(PcdEncoding::Ascii),
        Self::Pcd(PcdEncoding::Binary),
        Self::Pcd(PcdEncoding::BinaryCompressed),
        Self::Ply(PlyEncoding::Ascii),
        Self::Ply(PlyEncoding::BinaryLittleEndian),
        Self::Ply(PlyEncoding::BinaryBigEndian),
        Self::Npy,
    ];

    /// The default format ([`CloudKind::default_format`]) of `path`'s extension.
    pub fn from_path(path: &Path) -> Result<Self> {
        CloudKind::from_path(path).map(CloudKind::default_format)
    }

    /// The family, which fixes the extension.
    pub fn kind(self) -> CloudKind {
        match self {
            Self::KittiBin => CloudKind::KittiBin,
            Self::Pcd(_) => CloudKind::Pcd,
            Self::Ply(_) => CloudKind::Ply,
            Self::Npy => CloudKind::Npy,
        }
    }
}

/// As the format's own files name it, e.g. `PCD (binary_compressed)`.
impl fmt::Display for CloudFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::KittiBin => f.write_str("KITTI .bin"),
            Self::Pcd(PcdEncoding::Ascii) => f.write_str("PCD (ascii)"),
            Self::Pcd(PcdEncoding::Binary) => f.write_str("PCD (binary)"),
            Self::Pcd(PcdEncoding::BinaryCompressed) => f.write_str("PCD (binary_compressed)"),
            Self::Ply(PlyEncoding::Ascii) => f.write_str("PLY (ascii)"),
            Self::Ply(PlyEncoding::BinaryLittleEndian) => f.write_str("PLY (binary_little_endian)"),
            Self::Ply(PlyEncoding::BinaryBigEndian) => f.write_str("PLY (binary_big_endian)"),
            Self::Npy => f.write_str("NumPy .npy"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_extension_names_its_kind_and_back() {
        for (ext, kind) in
            CLOUD_EXTENSIONS
                .iter()
                .zip([CloudKind::KittiBin, CloudKind::Pcd, CloudKind::Ply, CloudKind::Npy])
        {
            let path = format!("dir.v2/scan.{ext}");
            assert_eq!(CloudKind::from_path(Path::new(&path)).unwrap(), kind, "{path}");
            assert_eq!(kind.extension(), *ext);
            assert_eq!(kind.default_format().kind(), kind);
        }
        assert_eq!(
            CloudFormat::from_path(Path::new("a.pcd")).unwrap(),
            CloudFormat::Pcd(PcdEncoding::Binary)
        );
    }

    #[test]
    fn unknown_extension_names_the_file_and_the_accepted_ones() {
        for name in ["scans/0001.las", "scans/0001", "scans/0001.PCD", "scans.pcd/0001.txt"] {
            let err = CloudKind::from_path(Path::new(name)).unwrap_err();
            assert!(matches!(err, DataError::UnknownCloudExtension { .. }), "{err:?}");
            let msg = err.to_string();
            assert!(msg.contains(name) && msg.contains(".bin, .pcd, .ply, .npy"), "{msg}");
        }
    }

    #[test]
    fn all_lists_every_encoding_once_with_distinct_names() {
        let names: std::collections::HashSet<String> = CloudFormat::ALL.iter().map(|f| f.to_string()).collect();
        assert_eq!(names.len(), CloudFormat::ALL.len());
        let kinds: std::collections::HashSet<CloudKind> = CloudFormat::ALL.iter().map(|f| f.kind()).collect();
        assert_eq!(kinds.len(), 4);
    }
}
