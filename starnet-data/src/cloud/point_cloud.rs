//! The in-memory cloud every reader returns, and the point rules all of them share.

use crate::{DataError, Point, Result};
use std::path::Path;

/// A point cloud read from (or to be written to) any of the formats.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud {
    /// `[x, y, z, intensity]`, LiDAR frame (metres, x forward, y left, z up). The 4th value is
    /// 0.0 when [`Self::intensity`] is [`Intensity::Absent`].
    pub points: Vec<Point>,
    /// Whether the file had an intensity channel.
    pub intensity: Intensity,
}

impl PointCloud {
    /// A cloud from rows held in memory, `width` values each: `[x, y, z]` (3, no intensity) or
    /// `[x, y, z, intensity]` (4), checked by the rule every reader applies (a NaN coordinate
    /// drops the row; any other non-finite value is an error naming `source` and the row).
    pub fn from_rows(values: &[f32], width: usize, source: &Path) -> Result<Self> {
        let intensity = match width {
            3 => Intensity::Absent,
            4 => Intensity::Measured,
            _ => {
                return Err(DataError::CloudHeader {
                    path: source.into(),
                    message: format!("rows of {width} values; a cloud has 3 (x, y, z) or 4 (x, y, z, intensity)"),
                });
            }
        };
        let mut points = Vec::with_capacity(values.len() / width);
        for (index, row) in values.chunks_exact(width).enumerate() {
            let xyz = [row[0], row[1], row[2]];
            points.extend(checked_point(xyz, row.get(3).copied(), index, source)?);
        }
        Ok(Self { points, intensity })
    }
}

/// Whether a cloud's 4th value is a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Intensity {
    /// The file has an intensity channel; the 4th value is its value, unscaled.
    Measured,
    /// The file has no intensity channel; the 4th value is 0.0 and must not be read as a
    /// reflectance (a dark surface). The caller decides: refuse the cloud, or feed a model that
    /// never reads the channel.
    Absent,
}

/// The field names read as intensity, in order of preference when a file has several:
/// `intensity` (PCL, most drivers), `reflectance` (KITTI's word), `scalar_intensity`
/// (CloudCompare's PLY export) and `i`.
pub const INTENSITY_NAMES: [&str; 4] = ["intensity", "reflectance", "scalar_intensity", "i"];

/// The rule every reader applies to a decoded point (`index` counts every point in the file):
/// a NaN coordinate is "no return" (organised clouds fill their grid with NaN; PCL's
/// `is_dense false`) and the point is dropped, `Ok(None)`. An infinite coordinate, or a
/// non-finite intensity on a point that has a return, is corrupt data and an error. A missing
/// intensity is 0.0.
pub(super) fn checked_point(xyz: [f32; 3], intensity: Option<f32>, index: usize, path: &Path) -> Result<Option<Point>> {
    if xyz.iter().any(|v| v.is_nan()) {
        return Ok(None);
    }
    let point = [xyz[0], xyz[1], xyz[2], intensity.unwrap_or(0.0)];
    match point.iter().position(|v| !v.is_finite()) {
        None => Ok(Some(point)),
        Some(k) => Err(DataError::NonFinitePoint {
            path: path.into(),
            index,
            field: ["x", "y", "z", "intensity"][k],
            value: point[k],
        }),
    }
}

/// [`DataError::CloudHeader`].
pub(super) fn header_error(path: &Path, message: impl Into<String>) -> DataError {
    DataError::CloudHeader {
        path: path.into(),
        message: message.into(),
    }
}

/// [`DataError::CloudData`].
pub(super) fn data_error(path: &Path, message: impl Into<String>) -> DataError {
    DataError::CloudData {
        path: path.into(),
        message: message.into(),
    }
}

/// [`DataError::CloudTruncated`] unless `available >= needed`. Readers call it before a crate
/// sees the data: the crates allocate and loop by the header's counts.
pub(super) fn ensure_available(needed: u64, available: u64, unit: &'static str, path: &Path) -> Result<()> {
    if available >= needed {
        return Ok(());
    }
    Err(DataError::CloudTruncated {
        path: path.into(),
        needed,
        available,
        unit,
    })
}

/// The lines a line reader finds in `text`: a last line without a newline counts.
pub(super) fn count_lines(text: &[u8]) -> u64 {
    let newlines = text.iter().filter(|&&b| b == b'\n').count() as u64;
    newlines + u64::from(text.last().is_some_and(|&b| b != b'\n'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nan_coordinate_drops_the_point_and_other_non_finite_values_are_errors() {
        let p = Path::new("scan.pcd");
        assert_eq!(checked_point([f32::NAN, 1.0, 2.0], Some(f32::NAN), 0, p).unwrap(), None);
        assert_eq!(
            checked_point([1.0, 2.0, 3.0], None, 0, p).unwrap(),
            Some([1.0, 2.0, 3.0, 0.0])
        );
        assert_eq!(
            checked_point([-0.0, 2.0, 3.0], Some(7.5), 0, p).unwrap(),
            Some([-0.0, 2.0, 3.0, 7.5])
        );
        let err = checked_point([1.0, 2.0, 3.0], Some(f32::INFINITY), 4, p).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::NonFinitePoint {
                    index: 4,
                    field: "intensity",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("scan.pcd"), "{err}");
        let err = checked_point([1.0, f32::NEG_INFINITY, 3.0], Some(0.5), 9, p).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::NonFinitePoint {
                    index: 9,
                    field: "y",
                    ..
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn lines_are_counted_as_read_line_sees_them() {
        assert_eq!(count_lines(b""), 0);
        assert_eq!(count_lines(b"1 2 3"), 1);
        assert_eq!(count_lines(b"1 2 3\n"), 1);
        assert_eq!(count_lines(b"1\n\n2"), 3);
    }

    #[test]
    fn available_data_is_checked_and_the_shortfall_reported() {
        ensure_available(10, 10, "bytes", Path::new("a.ply")).unwrap();
        let err = ensure_available(11, 10, "lines", Path::new("a.ply")).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::CloudTruncated {
                    needed: 11,
                    available: 10,
                    unit: "lines",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("a.ply"), "{err}");
    }

    #[test]
    fn rows_become_a_cloud_by_the_readers_rule() {
        let p = Path::new("array");
        let xyz = PointCloud::from_rows(&[1.0, 2.0, 3.0, f32::NAN, 0.0, 0.0, 4.0, 5.0, 6.0], 3, p).unwrap();
        assert_eq!(xyz.intensity, Intensity::Absent);
        assert_eq!(xyz.points, vec![[1.0, 2.0, 3.0, 0.0], [4.0, 5.0, 6.0, 0.0]]);
        let xyzi = PointCloud::from_rows(&[1.0, 2.0, 3.0, 0.25], 4, p).unwrap();
        assert_eq!(
            (xyzi.intensity, xyzi.points),
            (Intensity::Measured, vec![[1.0, 2.0, 3.0, 0.25]])
        );
        let err = PointCloud::from_rows(&[1.0, 2.0, 3.0, 0.5, 1.0, f32::INFINITY, 3.0, 0.5], 4, p).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::NonFinitePoint {
                    index: 1,
                    field: "y",
                    ..
                }
            ),
            "{err:?}"
        );
        let err = PointCloud::from_rows(&[0.0; 10], 5, p).unwrap_err();
        assert!(
            err.to_string().contains("array") && err.to_string().contains("5 values"),
            "{err}"
        );
    }
}
