//! Velodyne scans: raw little-endian f32 quadruples `x y z reflectance`, no header
//! (`training/velodyne/%06d.bin`).

use crate::io::{atomic_write, read};
use crate::{DataError, Point, Result};
use std::path::Path;

/// Decodes a scan held in memory; `path` only names the source in errors. Rejects a size
/// that is not a multiple of 16 and any non-finite value.
pub fn decode_points(bytes: &[u8], path: &Path) -> Result<Vec<Point>> {
    if !bytes.len().is_multiple_of(16) {
        return Err(DataError::TruncatedPoints {
            path: path.into(),
            len: bytes.len() as u64,
        });
    }
    const FIELDS: [&str; 4] = ["x", "y", "z", "reflectance"];
    // A loop into a sized vector rather than collecting `Result`s, which cannot reserve.
    let mut points = Vec::with_capacity(bytes.len() / 16);
    for (index, chunk) in bytes.chunks_exact(16).enumerate() {
        let p: Point =
            std::array::from_fn(|k| f32::from_le_bytes(chunk[4 * k..4 * k + 4].try_into().expect("4 bytes")));
        if let Some(k) = p.iter().position(|v| !v.is_finite()) {
            return Err(DataError::NonFinitePoint {
                path: path.into(),
                index,
                field: FIELDS[k],
                value: p[k],
            });
        }
        points.push(p);
    }
    Ok(points)
}

/// Encodes points as KITTI velodyne bytes.
pub fn encode_points(points: &[Point]) -> Vec<u8> {
    points
        .iter()
        .flat_map(|p| p.iter().flat_map(|v| v.to_le_bytes()))
        .collect()
}

/// Reads a velodyne `.bin`.
pub fn read_points(path: &Path) -> Result<Vec<Point>> {
    decode_points(&read(path)?, path)
}

/// Writes a velodyne `.bin` atomically.
pub fn write_points(path: &Path, points: &[Point]) -> Result<()> {
    atomic_write(path, &encode_points(points))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_bytes() {
        let pts = vec![[1.0, -2.5, 0.25, 0.5], [f32::MAX, -0.0, 1e-30, 1.0]];
        let bytes = encode_points(&pts);
        assert_eq!(bytes.len(), 32);
        assert_eq!(&bytes[0..4], &1.0f32.to_le_bytes());
        let back = decode_points(&bytes, Path::new("mem")).unwrap();
        assert_eq!(back, pts);
    }

    #[test]
    fn truncated_file_is_rejected_with_its_name_and_size() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("000007.bin");
        let mut bytes = encode_points(&[[1.0, 2.0, 3.0, 0.1]]);
        bytes.extend_from_slice(&[0, 0, 0]);
        std::fs::write(&p, bytes).unwrap();
        let err = read_points(&p).unwrap_err();
        assert!(matches!(err, DataError::TruncatedPoints { len: 19, .. }), "{err:?}");
        assert!(err.to_string().contains("000007.bin"), "{err}");
    }

    #[test]
    fn non_finite_value_is_rejected_with_point_and_field() {
        let bytes = encode_points(&[[1.0, 2.0, 3.0, 0.1], [1.0, 2.0, f32::NAN, 0.1]]);
        let err = decode_points(&bytes, Path::new("x.bin")).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::NonFinitePoint {
                    index: 1,
                    field: "z",
                    ..
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn write_then_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("velodyne/000000.bin");
        let pts = vec![[0.5, 0.25, -1.75, 0.0]; 3];
        write_points(&p, &pts).unwrap();
        assert_eq!(read_points(&p).unwrap(), pts);
    }
}
