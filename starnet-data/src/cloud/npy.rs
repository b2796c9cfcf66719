//! NumPy `.npy` (format versions 1 to 3), through `npyz`: a float array of shape (N, 4),
//! `x y z intensity`, or (N, 3), `x y z` and no intensity ([`Intensity::Absent`]). OpenPCDet's
//! custom datasets store their clouds this way.
//!
//! Reading accepts dtype `<f4` or `<f8`, or their big-endian `>f4`, `>f8`, in C order; f8 is
//! rounded once to f32. Anything else (another shape or dtype, `fortran_order`, a record dtype)
//! is an error saying what was found and what is accepted. The intensity is taken as it is (no
//! rescaling), and a row with a NaN coordinate is dropped (see [`checked_point`]).
//!
//! Before `npyz` sees the file, the header's length is checked against the file and numpy's own
//! limit (`npyz` allocates the length it reads), its nesting depth is bounded (the header is a
//! Python literal, parsed recursively), and the shape is checked against the data's length.
//!
//! Writing: `<f4`, C order, (N, 4), or (N, 3) when the intensity is absent.

use super::point_cloud::{checked_point, data_error, ensure_available, header_error};
use super::{Intensity, PointCloud};
use crate::{DataError, Result};
use npyz::{DType, Deserialize, Endianness, NpyFile, NpyHeader, Order, TypeChar, WriteOptions, WriterBuilder};
use std::path::Path;

const MAGIC: &[u8] = b"\x93NUMPY";

/// numpy's own limit on the header's length (`max_header_size`, numpy ≥ 1.24); a valid
/// (N, 4) header is under 128 bytes.
const MAX_HEADER_LEN: u64 = 10_000;

/// Far more than the two levels a valid header has (`{'shape': (N, 4)}`).
const MAX_NESTING: usize = 8;

const ACCEPTED: &str = "accepted: dtype <f4 or <f8 (or big-endian >f4, >f8), shape (N, 3) for x y z or (N, 4) for \
                        x y z intensity, C order";

/// What the header says the array is.
#[derive(Clone, Copy)]
struct Layout {
    rows: u64,
    columns: usize,
    /// 4 (f32) or 8 (f64).
    value_size: u64,
}

/// Decodes a `.npy` file held in memory; `path` names it in errors.
pub(super) fn decode(bytes: &[u8], path: &Path) -> Result<PointCloud> {
    check_preamble(bytes, path)?;
    let mut data = bytes;
    let header = NpyHeader::from_reader(&mut data).map_err(|e| header_error(path, format!(".npy header: {e}")))?;
    let layout = layout(&header, path)?;
    check_data_len(layout, data.len() as u64, path)?;
    let file = NpyFile::with_header(header, data);
    let values = match layout.value_size {
        4 => read_values::<f32>(file, path)?,
        _ => read_values::<f64>(file, path)?,
    };
    to_cloud(&values, layout.columns, path)
}

/// The magic, version and header length that precede the header text: the length must fit
/// the file and numpy's limit, and the text must not nest deeper than a valid header does.
/// A bad magic or version is left to `npyz` to report.
fn check_preamble(bytes: &[u8], path: &Path) -> Result<()> {
    let start = match (bytes.get(..6), bytes.get(6..8)) {
        (Some(MAGIC), Some([1, 0])) => 10,
        (Some(MAGIC), Some([2 | 3, 0])) => 12,
        _ => return Ok(()),
    };
    let Some(len_bytes) = bytes.get(8..start) else {
        return ensure_available(start as u64, bytes.len() as u64, "bytes", path);
    };
    let text_len = len_bytes.iter().rev().fold(0u64, |len, &b| (len << 8) | u64::from(b));
    if text_len > MAX_HEADER_LEN {
        let message = format!(".npy header is {text_len} bytes long; numpy writes and reads at most {MAX_HEADER_LEN}");
        return Err(header_error(path, message));
    }
    ensure_available(text_len, (bytes.len() - start) as u64, "bytes", path)?;
    check_nesting(&bytes[start..start + text_len as usize], path)
}

fn check_nesting(text: &[u8], path: &Path) -> Result<()> {
    let (mut depth, mut deepest) = (0usize, 0usize);
    for b in text {
        match b {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        deepest = deepest.max(depth);
    }
    if deepest > MAX_NESTING {
        let message = format!(".npy header nests {deepest} levels deep; a point-cloud header has 2");
        return Err(header_error(path, message));
    }
    Ok(())
}

fn layout(header: &NpyHeader, path: &Path) -> Result<Layout> {
    let value_size = match header.dtype() {
        DType::Plain(t)
            if t.type_char() == TypeChar::Float
                && matches!(t.endianness(), Endianness::Little | Endianness::Big)
                && matches!(t.size_field(), 4 | 8) =>
        {
            Some(t.size_field())
        }
        _ => None,
    };
    match (value_size, header.shape(), header.order()) {
        (Some(value_size), &[rows, columns @ (3 | 4)], Order::C) => Ok(Layout {
            rows,
            columns: columns as usize,
            value_size,
        }),
        _ => Err(header_error(
            path,
            format!(".npy holds {}; {ACCEPTED}", describe(header)),
        )),
    }
}

/// E.g. `dtype '<i4', shape (5, 4), C order`, as numpy would print them.
fn describe(header: &NpyHeader) -> String {
    let dims: Vec<String> = header.shape().iter().map(u64::to_string).collect();
    let comma = if dims.len() == 1 { "," } else { "" };
    let order = match header.order() {
        Order::C => "C",
        Order::Fortran => "Fortran",
    };
    format!(
        "dtype {}, shape ({}{comma}), {order} order",
        header.dtype().descr(),
        dims.join(", ")
    )
}

/// The data must be exactly the array the header describes.
fn check_data_len(layout: Layout, available: u64, path: &Path) -> Result<()> {
    let row_size = layout.columns as u64 * layout.value_size;
    let needed = layout.rows.checked_mul(row_size).ok_or_else(|| {
        header_error(
            path,
            format!(".npy header declares {} rows, more than any file holds", layout.rows),
        )
    })?;
    ensure_available(needed, available, "bytes", path)?;
    if available > needed {
        let message = format!(
            ".npy has {} bytes after the ({}, {}) array its header describes",
            available - needed,
            layout.rows,
            layout.columns
        );
        return Err(header_error(path, message));
    }
    Ok(())
}

fn read_values<T: Deserialize + Into<f64>>(file: NpyFile<&[u8]>, path: &Path) -> Result<Vec<f32>> {
    let reader = file
        .data::<T>()
        .map_err(|e| header_error(path, format!(".npy dtype: {e}")))?;
    // The length was checked against the bytes present.
    let mut values = Vec::with_capacity(reader.len() as usize);
    for value in reader {
        let value = value.map_err(|e| data_error(path, format!(".npy data: {e}")))?;
        let value: f64 = value.into();
        values.push(value as f32);
    }
    Ok(values)
}

fn to_cloud(values: &[f32], columns: usize, path: &Path) -> Result<PointCloud> {
    let mut points = Vec::with_capacity(values.len() / columns);
    for (index, row) in values.chunks_exact(columns).enumerate() {
        let intensity = row.get(3).copied();
        if let Some(p) = checked_point([row[0], row[1], row[2]], intensity, index, path)? {
            points.push(p);
        }
    }
    let intensity = match columns {
        4 => Intensity::Measured,
        _ => Intensity::Absent,
    };
    Ok(PointCloud { points, intensity })
}

/// Encodes `cloud` as `.npy` (`<f4`); `path` names the destination in errors.
pub(super) fn encode(cloud: &PointCloud, path: &Path) -> Result<Vec<u8>> {
    let columns = match cloud.intensity {
        Intensity::Measured => 4,
        Intensity::Absent => 3,
    };
    let dtype = DType::Plain("<f4".parse().expect("`<f4` is a valid type string"));
    let io_error = |e| DataError::io(path, e);
    let mut out = Vec::new();
    let mut writer = WriteOptions::<f32>::new()
        .dtype(dtype)
        .shape(&[cloud.points.len() as u64, columns as u64])
        .writer(&mut out)
        .begin_nd()
        .map_err(io_error)?;
    writer
        .extend(cloud.points.iter().flat_map(|p| p[..columns].iter().copied()))
        .map_err(io_error)?;
    writer.finish().map_err(io_error)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{Expected, assert_bits_eq, awkward_cloud, largest_allocation_during};
    use super::*;

    fn decode_bytes(bytes: &[u8]) -> Result<PointCloud> {
        decode(bytes, Path::new("points/000042.npy"))
    }

    /// A version-1 `.npy` with header `dict` and raw `data`.
    fn npy(dict: &str, data: &[u8]) -> Vec<u8> {
        let text = format!("{dict}\n");
        let mut bytes = MAGIC.to_vec();
        bytes.extend([1, 0]);
        bytes.extend((text.len() as u16).to_le_bytes());
        bytes.extend(text.as_bytes());
        bytes.extend(data);
        bytes
    }

    fn f32_le(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    #[test]
    fn round_trips_bit_exact_with_and_without_intensity() {
        for intensity in [Intensity::Measured, Intensity::Absent] {
            let cloud = awkward_cloud(intensity);
            let bytes = encode(&cloud, Path::new("o.npy")).unwrap();
            let columns = if intensity == Intensity::Measured { "4" } else { "3" };
            let head_len = bytes.iter().position(|&b| b == b'\n').unwrap();
            let head = String::from_utf8_lossy(&bytes[..head_len]).into_owned();
            assert!(
                head.contains("'<f4'") && head.contains(&format!("({}, {columns},", cloud.points.len())),
                "{head}"
            );
            let back = decode(&bytes, Path::new("o.npy")).unwrap();
            assert_eq!(back.intensity, intensity);
            assert_bits_eq(&back.points, &cloud.points);
        }
    }

    #[test]
    fn reads_f8_and_big_endian_and_drops_nan_rows() {
        let data: Vec<u8> = [1.5f64, -2.0, 0.1, 0.25, f64::NAN, 0.0, 0.0, 0.0]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let bytes = npy("{'descr': '>f8', 'fortran_order': False, 'shape': (2, 4), }", &data);
        let cloud = decode_bytes(&bytes).unwrap();
        assert_eq!(cloud.intensity, Intensity::Measured);
        assert_bits_eq(&cloud.points, &[[1.5, -2.0, 0.1, 0.25]]);
        let bytes = npy(
            "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 3), }",
            &f32_le(&[1.0, 2.0, 3.0]),
        );
        let cloud = decode_bytes(&bytes).unwrap();
        assert_eq!(
            (cloud.points, cloud.intensity),
            (vec![[1.0, 2.0, 3.0, 0.0]], Intensity::Absent)
        );
    }

    #[test]
    fn wrong_shape_dtype_or_order_says_what_was_found_and_accepted() {
        let cases = [
            ("'<f4'", "False", "(2, 5)", 40, "shape (2, 5)"),
            ("'<f4'", "False", "(8,)", 32, "shape (8,)"),
            ("'<f4'", "False", "(1, 2, 4)", 32, "shape (1, 2, 4)"),
            ("'<i4'", "False", "(2, 4)", 32, "'<i4'"),
            ("'<f2'", "False", "(2, 4)", 16, "'<f2'"),
            ("'<f4'", "True", "(2, 4)", 32, "Fortran order"),
            ("[('x', '<f4'), ('y', '<f4')]", "False", "(2, 4)", 64, "dtype ["),
        ];
        for (descr, fortran, shape, len, found) in cases {
            let bytes = npy(
                &format!("{{'descr': {descr}, 'fortran_order': {fortran}, 'shape': {shape}, }}"),
                &vec![0; len],
            );
            let err = decode_bytes(&bytes).unwrap_err();
            assert!(matches!(err, DataError::CloudHeader { .. }), "{descr} {shape}: {err:?}");
            let msg = err.to_string();
            assert!(
                msg.contains("000042.npy") && msg.contains(found) && msg.contains("accepted"),
                "{msg}"
            );
        }
    }

    #[test]
    fn data_shorter_or_longer_than_the_shape_is_refused() {
        let dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 4), }";
        let err = decode_bytes(&npy(dict, &[0; 31])).unwrap_err();
        assert!(
            matches!(
                err,
                DataError::CloudTruncated {
                    needed: 32,
                    available: 31,
                    ..
                }
            ),
            "{err:?}"
        );
        let err = decode_bytes(&npy(dict, &[0; 33])).unwrap_err();
        assert!(matches!(err, DataError::CloudHeader { .. }), "{err:?}");
    }

    #[test]
    fn lying_headers_fail_fast_without_allocating() {
        let mut huge_len = MAGIC.to_vec();
        huge_len.extend([2, 0]);
        huge_len.extend(u32::MAX.to_le_bytes());
        huge_len.extend(b"{'descr': '<f4'");
        let mut short_len = MAGIC.to_vec();
        short_len.extend([2, 0]);
        short_len.extend(5000u32.to_le_bytes());
        short_len.extend(b"{'descr': '<f4'");
        let deep = format!(
            "{{'descr': '<f4', 'fortran_order': False, 'shape': {}2{}, }}",
            "(".repeat(3000),
            ")".repeat(3000)
        );
        let cases: [(Vec<u8>, Expected); 6] = [
            (
                npy(
                    "{'descr': '<f4', 'fortran_order': False, 'shape': (4000000000, 4), }",
                    &[0; 16],
                ),
                |e| matches!(e, DataError::CloudTruncated { .. }),
            ),
            (
                npy(
                    "{'descr': '<f8', 'fortran_order': False, 'shape': (18446744073709551615, 4), }",
                    &[0; 16],
                ),
                |e| matches!(e, DataError::CloudHeader { .. }),
            ),
            (
                npy(
                    "{'descr': '<f4', 'fortran_order': False, 'shape': (4294967296, 4294967296, 4294967296), }",
                    &[],
                ),
                |e| matches!(e, DataError::CloudHeader { .. }),
            ),
            (huge_len, |e| matches!(e, DataError::CloudHeader { .. })),
            (short_len, |e| {
                matches!(e, DataError::CloudTruncated { needed: 5000, .. })
            }),
            (npy(&deep, &[]), |e| matches!(e, DataError::CloudHeader { .. })),
        ];
        for (k, (bytes, expected)) in cases.into_iter().enumerate() {
            let (result, largest) = largest_allocation_during(|| decode_bytes(&bytes));
            let err = result.unwrap_err();
            assert!(expected(&err), "case {k}: {err:?}");
            assert!(err.to_string().contains("000042.npy"), "{err}");
            assert!(largest < 1 << 20, "case {k}: allocated {largest} bytes");
        }
    }

    #[test]
    fn not_an_npy_file_is_a_header_error() {
        for bytes in [
            &b""[..],
            b"\x93NUMPY",
            b"\x93NUMPY\x09\x00\x10\x00",
            b"PK\x03\x04 a zip",
        ] {
            let err = decode_bytes(bytes).unwrap_err();
            assert!(
                matches!(err, DataError::CloudHeader { .. } | DataError::CloudTruncated { .. }),
                "{err:?}"
            );
        }
    }
}
