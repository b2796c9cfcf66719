//! PCD, PCL's Point Cloud Data (header versions 0.5 to 0.7), through `pcd-rs`: `ascii`,
//! `binary` and `binary_compressed`.
//!
//! Reading: the fields may come in any order. `x`, `y`, `z` are required, F32 or F64 with
//! COUNT 1. The intensity is optional and found by name ([`INTENSITY_NAMES`]), of any numeric
//! type with COUNT 1, and converted to f32 as it is: no rescaling. KITTI's reflectance is in
//! [0, 1]; a sensor that reports 0–255 (many do) needs its own scaling before a model trained
//! on KITTI sees it. Other fields (`rgb`, `ring`, `time`, `_` padding) are skipped. An
//! organised cloud (HEIGHT > 1) is flattened row by row, and its points with a NaN coordinate
//! are dropped (see [`checked_point`]).
//!
//! The header is validated before `pcd-rs` reads the data, because `pcd-rs` trusts it: it
//! allocates the two sizes that open a `binary_compressed` body, indexes out of bounds when
//! they disagree with POINTS, and loops POINTS times. So POINTS must equal WIDTH × HEIGHT, the
//! record size may not overflow (nor a COUNT be 0, which `pcd-rs` already reads as 1, as PCL
//! does), and the body must hold the data the header declares.
//!
//! Writing: `x y z [intensity]`, each F32 COUNT 1, WIDTH = N, HEIGHT 1, in any encoding.

use super::format::PcdEncoding;
use super::point_cloud::{INTENSITY_NAMES, checked_point, count_lines, data_error, ensure_available, header_error};
use super::{Intensity, PointCloud};
use crate::{DataError, Point, Result};
use pcd_rs::{DataKind, DynReader, DynRecord, DynWriter, Field, FieldDef, PcdMeta, Schema, ValueKind, WriterInit};
use std::io::Cursor;
use std::path::Path;

/// The largest factor by which LZF expands: a 3-byte back reference yields at most 264 bytes.
const LZF_MAX_EXPANSION: u64 = 88;

/// Where the channels sit in a [`DynRecord`], whose fields omit the `_` padding fields.
struct Channels {
    xyz: [usize; 3],
    intensity: Option<usize>,
}

/// Decodes a PCD file held in memory; `path` names it in errors.
pub(super) fn decode(bytes: &[u8], path: &Path) -> Result<PointCloud> {
    let (meta, header_len) = read_meta(bytes, path)?;
    let channels = channels(&meta, path)?;
    let num_points = check_body(&meta, bytes.get(header_len..).unwrap_or_default(), path)?;
    let reader = DynReader::from_bytes(bytes).map_err(|e| header_error(path, format!("PCD header: {e}")))?;
    let mut points = Vec::with_capacity(num_points);
    for (index, record) in reader.enumerate() {
        let record = record.map_err(|e| data_error(path, format!("PCD point {index}: {e}")))?;
        if let Some(p) = channels.point(&record, index, path)? {
            points.push(p);
        }
    }
    let intensity = match channels.intensity {
        Some(_) => Intensity::Measured,
        None => Intensity::Absent,
    };
    Ok(PointCloud { points, intensity })
}

/// The header and its length in bytes (where the body starts).
fn read_meta(bytes: &[u8], path: &Path) -> Result<(PcdMeta, usize)> {
    let mut cursor = Cursor::new(bytes);
    let meta = PcdMeta::from_reader(&mut cursor).map_err(|e| header_error(path, format!("PCD header: {e}")))?;
    Ok((meta, cursor.position() as usize))
}

fn channels(meta: &PcdMeta, path: &Path) -> Result<Channels> {
    let named: Vec<&FieldDef> = meta.field_defs.iter().filter(|f| !f.is_padding()).collect();
    let mut xyz = [0; 3];
    for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
        let i = named
            .iter()
            .position(|f| f.name == axis)
            .ok_or_else(|| header_error(path, format!("PCD has no `{axis}` field (FIELDS must name x, y and z)")))?;
        if !matches!(named[i].kind, ValueKind::F32 | ValueKind::F64) || named[i].count != 1 {
            return Err(header_error(path, field_message(named[i], "F 4 or F 8 with COUNT 1")));
        }
        *slot = i;
    }
    let intensity = INTENSITY_NAMES
        .iter()
        .find_map(|name| named.iter().position(|f| f.name == *name));
    if let Some(i) = intensity.filter(|&i| named[i].count != 1) {
        return Err(header_error(
            path,
            field_message(named[i], "one number per point (COUNT 1)"),
        ));
    }
    Ok(Channels { xyz, intensity })
}

fn field_message(field: &FieldDef, accepted: &str) -> String {
    format!(
        "PCD field `{}` is {:?} with COUNT {}; accepted: {accepted}",
        field.name, field.kind, field.count
    )
}

/// Checks the body against the header; returns the number of points.
fn check_body(meta: &PcdMeta, body: &[u8], path: &Path) -> Result<usize> {
    let record_size = record_size(meta, path)?;
    let grid = meta.width.checked_mul(meta.height);
    if grid != Some(meta.num_points) {
        let message = format!(
            "PCD header: POINTS {} is not WIDTH {} × HEIGHT {}",
            meta.num_points, meta.width, meta.height
        );
        return Err(header_error(path, message));
    }
    let too_big = || header_error(path, format!("PCD header: POINTS {} is too large", meta.num_points));
    let data_len = meta.num_points.checked_mul(record_size).ok_or_else(too_big)?;
    match meta.data {
        DataKind::Ascii => ensure_available(meta.num_points, count_lines(body), "lines", path)?,
        DataKind::Binary => ensure_available(data_len, body.len() as u64, "bytes", path)?,
        DataKind::BinaryCompressed => check_compressed(data_len, body, path)?,
    }
    usize::try_from(meta.num_points).map_err(|_| too_big())
}

/// Bytes per point, padding included.
fn record_size(meta: &PcdMeta, path: &Path) -> Result<u64> {
    let mut size = 0u64;
    for field in meta.field_defs.iter() {
        if field.count == 0 {
            return Err(header_error(path, field_message(field, "COUNT of at least 1")));
        }
        size = (field.kind.byte_size() as u64)
            .checked_mul(field.count)
            .and_then(|bytes| size.checked_add(bytes))
            .ok_or_else(|| header_error(path, field_message(field, "a record size that fits in 64 bits")))?;
    }
    Ok(size)
}

/// A `binary_compressed` body opens with two little-endian u32: the compressed and the
/// uncompressed sizes. Both must agree with the header and the file before `pcd-rs` allocates
/// them.
fn check_compressed(data_len: u64, body: &[u8], path: &Path) -> Result<()> {
    let Some((sizes, data)) = body.split_first_chunk::<8>() else {
        return ensure_available(8, body.len() as u64, "bytes", path);
    };
    let word = |k: usize| u64::from(u32::from_le_bytes([sizes[k], sizes[k + 1], sizes[k + 2], sizes[k + 3]]));
    let (compressed, uncompressed) = (word(0), word(4));
    ensure_available(compressed, data.len() as u64, "bytes", path)?;
    if uncompressed != data_len {
        let message = format!(
            "PCD binary_compressed: the data decompresses to {uncompressed} bytes but POINTS × record size is {data_len}"
        );
        return Err(header_error(path, message));
    }
    if uncompressed > compressed * LZF_MAX_EXPANSION {
        let message = format!(
            "PCD binary_compressed: {compressed} compressed bytes cannot hold {uncompressed} (LZF expands at most {LZF_MAX_EXPANSION}×)"
        );
        return Err(header_error(path, message));
    }
    Ok(())
}

impl Channels {
    fn point(&self, record: &DynRecord, index: usize, path: &Path) -> Result<Option<Point>> {
        let value = |i: usize| {
            let v = record.0.get(i).and_then(field_f32);
            v.ok_or_else(|| data_error(path, format!("PCD point {index}: field {i} has no value")))
        };
        let xyz = [value(self.xyz[0])?, value(self.xyz[1])?, value(self.xyz[2])?];
        let intensity = self.intensity.map(value).transpose()?;
        checked_point(xyz, intensity, index, path)
    }
}

/// The first value of a field, as f32 (the nearest for wider types).
fn field_f32(field: &Field) -> Option<f32> {
    Some(match field {
        Field::I8(v) => *v.first()? as f32,
        Field::I16(v) => *v.first()? as f32,
        Field::I32(v) => *v.first()? as f32,
        Field::I64(v) => *v.first()? as f32,
        Field::U8(v) => *v.first()? as f32,
        Field::U16(v) => *v.first()? as f32,
        Field::U32(v) => *v.first()? as f32,
        Field::U64(v) => *v.first()? as f32,
        Field::F32(v) => *v.first()?,
        Field::F64(v) => *v.first()? as f32,
    })
}

/// Encodes `cloud` as PCD; `path` names the destination in errors.
pub(super) fn encode(cloud: &PointCloud, encoding: PcdEncoding, path: &Path) -> Result<Vec<u8>> {
    let channels = match cloud.intensity {
        Intensity::Measured => 4,
        Intensity::Absent => 3,
    };
    let names = ["x", "y", "z", "intensity"];
    let schema: Schema = names[..channels].iter().map(|&n| (n, ValueKind::F32, 1)).collect();
    let init = WriterInit {
        width: cloud.points.len() as u64,
        height: 1,
        viewpoint: Default::default(),
        data_kind: match encoding {
            PcdEncoding::Ascii => DataKind::Ascii,
            PcdEncoding::Binary => DataKind::Binary,
            PcdEncoding::BinaryCompressed => DataKind::BinaryCompressed,
        },
        schema: Some(schema),
        version: None,
    };
    let mut out = Cursor::new(Vec::new());
    let write_error = |e: pcd_rs::Error| DataError::io(path, std::io::Error::other(e.to_string()));
    let mut writer: DynWriter<_> = init.build_from_writer(&mut out).map_err(write_error)?;
    let pushed = cloud
        .points
        .iter()
        .try_for_each(|p| writer.push(&DynRecord(p[..channels].iter().map(|&v| Field::F32(vec![v])).collect())));
    // Finished even after a failed push: pcd-rs's writer panics when dropped unfinished.
    let finished = writer.finish();
    pushed.and(finished).map_err(write_error)?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{Expected, assert_bits_eq, awkward_cloud, largest_allocation_during};
    use super::*;

    const ENCODINGS: [PcdEncoding; 3] = [PcdEncoding::Ascii, PcdEncoding::Binary, PcdEncoding::BinaryCompressed];

    fn decode_text(text: &str) -> Result<PointCloud> {
        decode(text.as_bytes(), Path::new("scans/frame7.pcd"))
    }

    fn header(fields: &str, size: &str, ty: &str, count: &str, width: u64, height: u64, data: &str) -> String {
        format!(
            "# .PCD v.7\nVERSION .7\nFIELDS {fields}\nSIZE {size}\nTYPE {ty}\nCOUNT {count}\nWIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {data}\n",
            width * height
        )
    }

    fn xyzi_binary(points: &[Point]) -> Vec<u8> {
        let mut bytes = header(
            "x y z intensity",
            "4 4 4 4",
            "F F F F",
            "1 1 1 1",
            points.len() as u64,
            1,
            "binary",
        )
        .into_bytes();
        bytes.extend(points.iter().flatten().flat_map(|v| v.to_le_bytes()));
        bytes
    }

    #[test]
    fn every_encoding_round_trips_bit_exact_with_and_without_intensity() {
        for intensity in [Intensity::Measured, Intensity::Absent] {
            let cloud = awkward_cloud(intensity);
            for encoding in ENCODINGS {
                let bytes = encode(&cloud, encoding, Path::new("out.pcd")).unwrap();
                let back = decode(&bytes, Path::new("out.pcd")).unwrap();
                assert_eq!(back.intensity, intensity, "{encoding:?}");
                assert_bits_eq(&back.points, &cloud.points);
            }
        }
    }

    #[test]
    fn empty_cloud_round_trips() {
        let cloud = PointCloud {
            points: vec![],
            intensity: Intensity::Measured,
        };
        for encoding in ENCODINGS {
            let bytes = encode(&cloud, encoding, Path::new("e.pcd")).unwrap();
            assert_eq!(decode(&bytes, Path::new("e.pcd")).unwrap(), cloud, "{encoding:?}");
        }
    }

    #[test]
    fn fields_in_any_order_of_any_type_with_padding_and_extras() {
        let text = header(
            "intensity _ z y x ring",
            "1 4 8 4 4 2",
            "U F F F F U",
            "1 2 1 1 1 1",
            2,
            1,
            "ascii",
        ) + "200 9 9 -1.5 2.25 0.5 7\n3 9 9 1e-3 -0 10 8\n";
        let cloud = decode_text(&text).unwrap();
        assert_eq!(cloud.intensity, Intensity::Measured);
        // Intensity 200 is kept as is (no rescaling to [0, 1]).
        assert_bits_eq(&cloud.points, &[[0.5, 2.25, -1.5, 200.0], [10.0, -0.0, 1e-3, 3.0]]);
    }

    #[test]
    fn intensity_aliases_in_order_of_preference() {
        let text = header(
            "x y z i reflectance",
            "4 4 4 4 4",
            "F F F F F",
            "1 1 1 1 1",
            1,
            1,
            "ascii",
        ) + "1 2 3 0.25 0.75\n";
        assert_eq!(decode_text(&text).unwrap().points, [[1.0, 2.0, 3.0, 0.75]]);
        let text = header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n";
        let cloud = decode_text(&text).unwrap();
        assert_eq!(
            (cloud.points, cloud.intensity),
            (vec![[1.0, 2.0, 3.0, 0.0]], Intensity::Absent)
        );
    }

    #[test]
    fn organised_cloud_is_flattened_and_its_no_return_points_dropped() {
        let text = header("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 1", 2, 2, "ascii")
            + "1 1 1 0.1\nnan nan nan nan\n3 3 3 0.3\n4 nan 4 0.4\n";
        assert_eq!(
            decode_text(&text).unwrap().points,
            [[1.0, 1.0, 1.0, 0.1], [3.0, 3.0, 3.0, 0.3]]
        );
    }

    #[test]
    fn non_finite_intensity_or_infinite_coordinate_is_an_error() {
        let text = header("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 1", 2, 1, "ascii") + "1 1 1 0.1\n2 2 2 nan\n";
        let err = decode_text(&text).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::NonFinitePoint {
                    index: 1,
                    field: "intensity",
                    ..
                }
            ),
            "{err:?}"
        );
        let text = header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii") + "inf 2 2\n";
        assert!(matches!(
            decode_text(&text).unwrap_err(),
            DataError::NonFinitePoint { field: "x", .. }
        ));
    }

    #[test]
    fn missing_or_mistyped_coordinates_are_header_errors_naming_the_file() {
        let cases = [
            header("y z intensity", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n",
            header("x y z", "4 4 4", "F I F", "1 1 1", 1, 1, "ascii") + "1 2 3\n",
            header("x y z", "4 4 4", "F F F", "1 2 1", 1, 1, "ascii") + "1 2 2 3\n",
            header("x y z intensity", "4 4 4 4", "F F F F", "1 1 1 2", 1, 1, "ascii") + "1 2 3 4 4\n",
        ];
        for (k, text) in cases.iter().enumerate() {
            let err = decode_text(text).unwrap_err();
            assert!(matches!(err, DataError::CloudHeader { .. }), "{err:?}");
            assert!(err.to_string().contains("frame7.pcd"), "{err}");
            assert!(k != 0 || err.to_string().contains("no `x` field"), "{err}");
        }
    }

    #[test]
    fn points_must_be_width_times_height() {
        let text =
            header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii").replace("POINTS 2", "POINTS 1") + "1 2 3\n";
        let err = decode_text(&text).unwrap_err();
        assert!(
            matches!(err, DataError::CloudHeader { .. }) && err.to_string().contains("WIDTH"),
            "{err}"
        );
    }

    #[test]
    fn truncated_binary_body_is_reported_with_its_size() {
        let mut bytes = xyzi_binary(&[[1.0, 2.0, 3.0, 0.5], [4.0, 5.0, 6.0, 0.5]]);
        bytes.truncate(bytes.len() - 3);
        let err = decode(&bytes, Path::new("frame7.pcd")).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::CloudTruncated {
                    needed: 32,
                    available: 29,
                    unit: "bytes",
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("frame7.pcd"), "{err}");
    }

    #[test]
    fn binary_compressed_with_lying_sizes_is_refused_before_pcd_rs_allocates() {
        let cloud = awkward_cloud(Intensity::Measured);
        let good = encode(&cloud, PcdEncoding::BinaryCompressed, Path::new("c.pcd")).unwrap();
        let at = good.windows(23).position(|w| w == b"DATA binary_compressed\n").unwrap() + 23;
        let with_sizes = |compressed: u32, uncompressed: u32| {
            let mut b = good.clone();
            b[at..at + 4].copy_from_slice(&compressed.to_le_bytes());
            b[at + 4..at + 8].copy_from_slice(&uncompressed.to_le_bytes());
            b
        };
        let real = u32::from_le_bytes(good[at..at + 4].try_into().unwrap());
        let n = cloud.points.len() as u32 * 16;
        let cases: [(Vec<u8>, Expected); 4] = [
            (with_sizes(u32::MAX, n), |e| {
                matches!(e, DataError::CloudTruncated { .. })
            }),
            (with_sizes(real, u32::MAX), |e| {
                matches!(e, DataError::CloudHeader { .. })
            }),
            (with_sizes(real, n - 4), |e| matches!(e, DataError::CloudHeader { .. })),
            (good[..at + 5].to_vec(), |e| {
                matches!(e, DataError::CloudTruncated { needed: 8, .. })
            }),
        ];
        for (bytes, expected) in cases {
            let (result, largest) = largest_allocation_during(|| decode(&bytes, Path::new("c.pcd")));
            let err = result.unwrap_err();
            assert!(expected(&err), "{err:?}");
            assert!(err.to_string().contains("c.pcd"), "{err}");
            assert!(largest < 1 << 20, "allocated {largest} bytes");
        }
    }

    #[test]
    fn compressed_size_that_lzf_cannot_expand_to_is_refused() {
        let mut text = header("x y z", "4 4 4", "F F F", "1 1 1", 100_000_000, 1, "binary_compressed").into_bytes();
        text.extend(1u32.to_le_bytes());
        text.extend(1_200_000_000u32.to_le_bytes());
        text.push(0);
        let (result, largest) = largest_allocation_during(|| decode(&text, Path::new("c.pcd")));
        assert!(matches!(result.unwrap_err(), DataError::CloudHeader { .. }));
        assert!(largest < 1 << 20, "allocated {largest} bytes");
    }

    #[test]
    fn huge_counts_on_a_tiny_file_fail_fast_without_allocating() {
        let cases = [
            header("x y z", "4 4 4", "F F F", "1 1 1", 4_000_000_000, 1, "binary"),
            header("x y z", "4 4 4", "F F F", "1 1 1", 4_000_000_000, 1, "ascii"),
            header("x y z _", "4 4 4 1", "F F F U", "1 1 1 4000000000", 1, 1, "binary"),
        ];
        for text in cases {
            let bytes = text + "1 2 3\n";
            let (result, largest) = largest_allocation_during(|| decode(bytes.as_bytes(), Path::new("big.pcd")));
            let err = result.unwrap_err();
            assert!(matches!(err, DataError::CloudTruncated { .. }), "{err:?}");
            assert!(largest < 1 << 20, "allocated {largest} bytes");
        }
    }

    #[test]
    fn record_size_or_data_size_overflow_is_a_header_error() {
        let text = header(
            "x y z _",
            "4 4 4 8",
            "F F F U",
            "1 1 1 18446744073709551615",
            1,
            1,
            "binary",
        ) + "0";
        assert!(matches!(decode_text(&text).unwrap_err(), DataError::CloudHeader { .. }));
        let text = header(
            "x y z",
            "4 4 4",
            "F F F",
            "1 1 1",
            3_000_000_000,
            3_000_000_000,
            "binary",
        ) + "0";
        let err = decode_text(&text).unwrap_err();
        assert!(matches!(err, DataError::CloudHeader { .. }), "{err:?}");
    }

    #[test]
    fn malformed_ascii_record_is_a_data_error_with_the_point() {
        let text = header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii") + "1 2 3\n1 2\n";
        let err = decode_text(&text).unwrap_err();
        assert!(matches!(err, DataError::CloudData { .. }), "{err:?}");
        assert!(err.to_string().contains("point 1"), "{err}");
    }
}
