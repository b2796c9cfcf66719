//! PLY, the `vertex` element, through `ply-rs-bw`: `ascii`, `binary_little_endian` and
//! `binary_big_endian`.
//!
//! Reading: the properties may come in any order. `x`, `y`, `z` are required, `float` or
//! `double`. The intensity is optional and found by name ([`INTENSITY_NAMES`], which include
//! CloudCompare's `scalar_intensity`), any scalar type, converted to f32 as it is (no
//! rescaling, as for PCD). Other properties and elements (`red`, `normal_x`, `face`, ...) are
//! skipped. A vertex with a NaN coordinate is dropped (see [`checked_point`]); ascii PLY cannot
//! spell NaN, so this only happens in binary files.
//!
//! Before `ply-rs-bw` reads the payload, the element counts are checked against the bytes
//! (binary) or lines (ascii) the file has: the parser loops over the declared count, and an
//! element without properties would never reach the end of the file.
//!
//! Writing: one `vertex` element with `float x y z [intensity]`.

use super::format::PlyEncoding;
use super::point_cloud::{INTENSITY_NAMES, checked_point, count_lines, data_error, ensure_available, header_error};
use super::{Intensity, PointCloud};
use crate::{DataError, Point, Result};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyDef, PropertyType,
    ScalarType,
};
use ply_rs_bw::writer::Writer;
use std::io::Cursor;
use std::path::Path;

/// One PLY element as this module reads and writes it: the coordinates and every intensity
/// alias (indexed like [`INTENSITY_NAMES`]), as f64 so that `double` coordinates round once.
#[derive(Debug, Default)]
struct Vertex {
    xyz: [f64; 3],
    intensity: [f64; INTENSITY_NAMES.len()],
}

impl Vertex {
    fn slot(&mut self, name: &str) -> Option<&mut f64> {
        match name {
            "x" => Some(&mut self.xyz[0]),
            "y" => Some(&mut self.xyz[1]),
            "z" => Some(&mut self.xyz[2]),
            _ => {
                let k = INTENSITY_NAMES.iter().position(|n| *n == name)?;
                Some(&mut self.intensity[k])
            }
        }
    }

    fn from_point(p: &Point) -> Self {
        let mut intensity = [0.0; INTENSITY_NAMES.len()];
        intensity[0] = f64::from(p[3]);
        Self {
            xyz: [p[0], p[1], p[2]].map(f64::from),
            intensity,
        }
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let value = match property {
            Property::Char(v) => f64::from(v),
            Property::UChar(v) => f64::from(v),
            Property::Short(v) => f64::from(v),
            Property::UShort(v) => f64::from(v),
            Property::Int(v) => f64::from(v),
            Property::UInt(v) => f64::from(v),
            Property::Float(v) => f64::from(v),
            Property::Double(v) => v,
            _ => return PropertyAccessResult::Ignored,
        };
        match self.slot(name) {
            Some(slot) => {
                *slot = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }

    // Exact: the values were f32 (`from_point`).
    fn get_float(&self, name: &str) -> Option<f32> {
        let value = match name {
            "x" => self.xyz[0],
            "y" => self.xyz[1],
            "z" => self.xyz[2],
            "intensity" => self.intensity[0],
            _ => return None,
        };
        Some(value as f32)
    }
}

/// Decodes a PLY file held in memory; `path` names it in errors.
pub(super) fn decode(bytes: &[u8], path: &Path) -> Result<PointCloud> {
    let parser = Parser::<Vertex>::new();
    let mut reader = Reader::new(Cursor::new(bytes));
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| header_error(path, format!("PLY header: {e}")))?;
    let intensity = vertex_channels(&header, path)?;
    let body = bytes.get(reader.get_ref().position() as usize..).unwrap_or_default();
    check_body(&header, body, path)?;
    // Elements are stored one after another: those before `vertex` are read to be skipped.
    for (name, element) in &header.elements {
        let rows = parser
            .read_payload_for_element(&mut reader, element, &header)
            .map_err(|e| data_error(path, format!("PLY element `{name}`: {e}")))?;
        if name == "vertex" {
            return to_cloud(&rows, intensity, path);
        }
    }
    Err(header_error(path, "PLY has no `element vertex`"))
}

/// Checks the vertex properties; returns which intensity alias (if any) the file uses.
fn vertex_channels(header: &Header, path: &Path) -> Result<Option<usize>> {
    let vertex = header
        .elements
        .get("vertex")
        .ok_or_else(|| header_error(path, "PLY has no `element vertex`"))?;
    for axis in ["x", "y", "z"] {
        match vertex.properties.get(axis).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(ScalarType::Float | ScalarType::Double)) => {}
            Some(other) => {
                let message = format!("PLY property `{axis}` is {other:?}; accepted: float or double");
                return Err(header_error(path, message));
            }
            None => return Err(header_error(path, format!("PLY vertex has no property `{axis}`"))),
        }
    }
    let alias = INTENSITY_NAMES.iter().position(|n| vertex.properties.contains_key(*n));
    if let Some(property) = alias.and_then(|k| vertex.properties.get(INTENSITY_NAMES[k]))
        && matches!(property.data_type, PropertyType::List(..))
    {
        let message = format!("PLY property `{}` is a list; accepted: a scalar", property.name);
        return Err(header_error(path, message));
    }
    Ok(alias)
}

/// The least every element needs: a line each (ascii) or its scalars and list lengths
/// (binary).
fn check_body(header: &Header, body: &[u8], path: &Path) -> Result<()> {
    let mut needed = 0u64;
    for (name, element) in &header.elements {
        let per_element = match header.encoding {
            Encoding::Ascii => 1,
            Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => min_binary_size(element),
        };
        if per_element == 0 && element.count > 0 {
            let message = format!("PLY element `{name}` has {} entries but no properties", element.count);
            return Err(header_error(path, message));
        }
        needed = needed.saturating_add(per_element.saturating_mul(element.count as u64));
    }
    match header.encoding {
        Encoding::Ascii => ensure_available(needed, count_lines(body), "lines", path),
        _ => ensure_available(needed, body.len() as u64, "bytes", path),
    }
}

fn min_binary_size(element: &ElementDef) -> u64 {
    let scalar_size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    let property_size = |p: &PropertyDef| match &p.data_type {
        PropertyType::Scalar(t) => scalar_size(t),
        // An empty list is just its length.
        PropertyType::List(length, _) => scalar_size(length),
    };
    element.properties.values().map(property_size).sum()
}

fn to_cloud(rows: &[Vertex], intensity: Option<usize>, path: &Path) -> Result<PointCloud> {
    let mut points = Vec::with_capacity(rows.len());
    for (index, v) in rows.iter().enumerate() {
        let xyz = v.xyz.map(|c| c as f32);
        if let Some(p) = checked_point(xyz, intensity.map(|k| v.intensity[k] as f32), index, path)? {
            points.push(p);
        }
    }
    let intensity = match intensity {
        Some(_) => Intensity::Measured,
        None => Intensity::Absent,
    };
    Ok(PointCloud { points, intensity })
}

/// Encodes `cloud` as PLY; `path` names the destination in errors.
pub(super) fn encode(cloud: &PointCloud, encoding: PlyEncoding, path: &Path) -> Result<Vec<u8>> {
    let channels = match cloud.intensity {
        Intensity::Measured => 4,
        Intensity::Absent => 3,
    };
    let mut element = ElementDef::new("vertex".into());
    element.count = cloud.points.len();
    for name in &["x", "y", "z", "intensity"][..channels] {
        element.properties.add(PropertyDef::new(
            (*name).into(),
            PropertyType::Scalar(ScalarType::Float),
        ));
    }
    let mut header = Header::new();
    header.encoding = match encoding {
        PlyEncoding::Ascii => Encoding::Ascii,
        PlyEncoding::BinaryLittleEndian => Encoding::BinaryLittleEndian,
        PlyEncoding::BinaryBigEndian => Encoding::BinaryBigEndian,
    };
    header.elements.add(element.clone());
    let rows: Vec<Vertex> = cloud.points.iter().map(Vertex::from_point).collect();
    let writer = Writer::<Vertex>::new();
    let mut out = Vec::new();
    writer
        .write_header(&mut out, &header)
        .and_then(|_| writer.write_payload_of_element(&mut out, &rows, &element, &header))
        .map_err(|e| DataError::io(path, e))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_bits_eq, awkward_cloud, largest_allocation_during};
    use super::*;

    const ENCODINGS: [PlyEncoding; 3] = [
        PlyEncoding::Ascii,
        PlyEncoding::BinaryLittleEndian,
        PlyEncoding::BinaryBigEndian,
    ];

    fn decode_bytes(bytes: &[u8]) -> Result<PointCloud> {
        decode(bytes, Path::new("scans/frame9.ply"))
    }

    #[test]
    fn every_encoding_round_trips_bit_exact_with_and_without_intensity() {
        for intensity in [Intensity::Measured, Intensity::Absent] {
            let cloud = awkward_cloud(intensity);
            for encoding in ENCODINGS {
                let bytes = encode(&cloud, encoding, Path::new("out.ply")).unwrap();
                let back = decode(&bytes, Path::new("out.ply")).unwrap();
                assert_eq!(back.intensity, intensity, "{encoding:?}");
                assert_bits_eq(&back.points, &cloud.points);
            }
        }
    }

    #[test]
    fn intensity_first_double_coordinates_and_other_elements() {
        let text = "ply\nformat ascii 1.0\ncomment from a hand\nelement camera 1\nproperty float fov\n\
                    element vertex 2\nproperty float intensity\nproperty uchar red\nproperty double z\n\
                    property double y\nproperty list uchar int ids\nproperty double x\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    1.5\n0.25 255 -1.5 2 2 7 8 0.1\n200 0 1e-3 -0 0 10\n3 0 1 1\n";
        let cloud = decode_bytes(text.as_bytes()).unwrap();
        assert_eq!(cloud.intensity, Intensity::Measured);
        // x = 0.1 is a double, rounded once to the nearest f32; the intensity 200 is kept as is.
        assert_bits_eq(&cloud.points, &[[0.1, 2.0, -1.5, 0.25], [10.0, -0.0, 1e-3, 200.0]]);
    }

    #[test]
    fn big_endian_binary_with_scalar_intensity_alias() {
        let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty ushort scalar_intensity\n\
                          property float x\nproperty float y\nproperty float z\nend_header\n"
            .to_vec();
        for (i, xyz) in [(40000u16, [1.0f32, -2.0, 0.5]), (7, [f32::NAN, 0.0, 0.0])] {
            bytes.extend(i.to_be_bytes());
            bytes.extend(xyz.iter().flat_map(|v| v.to_be_bytes()));
        }
        let cloud = decode_bytes(&bytes).unwrap();
        assert_eq!(cloud.points, [[1.0, -2.0, 0.5, 40000.0]], "the NaN vertex is dropped");
    }

    #[test]
    fn missing_or_list_coordinates_are_header_errors_naming_the_file() {
        let cases = [
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\nend_header\n1 2\n",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\nend_header\n1 1 2 3\n",
            "ply\nformat ascii 1.0\nelement face 0\nproperty float x\nend_header\n",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar float i\nend_header\n1 2 3 0\n",
        ];
        for (k, text) in cases.iter().enumerate() {
            let err = decode_bytes(text.as_bytes()).unwrap_err();
            assert!(matches!(err, DataError::CloudHeader { .. }), "case {k}: {err:?}");
            assert!(err.to_string().contains("frame9.ply"), "{err}");
        }
    }

    #[test]
    fn huge_vertex_count_on_a_tiny_file_fails_fast_without_allocating() {
        for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let text = format!(
                "ply\nformat {format} 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n"
            );
            let (result, largest) = largest_allocation_during(|| decode_bytes(text.as_bytes()));
            let err = result.unwrap_err();
            assert!(matches!(err, DataError::CloudTruncated { .. }), "{format}: {err:?}");
            assert!(err.to_string().contains("frame9.ply"), "{err}");
            assert!(largest < 1 << 20, "{format}: allocated {largest} bytes");
        }
    }

    #[test]
    fn element_without_properties_cannot_claim_entries() {
        let text = "ply\nformat binary_little_endian 1.0\nelement marker 4000000000\n\
                    element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let (result, largest) = largest_allocation_during(|| decode_bytes(text.as_bytes()));
        assert!(matches!(result.unwrap_err(), DataError::CloudHeader { .. }));
        assert!(largest < 1 << 20, "allocated {largest} bytes");
    }

    #[test]
    fn truncated_binary_payload_is_reported_with_its_size() {
        let cloud = awkward_cloud(Intensity::Measured);
        let bytes = encode(&cloud, PlyEncoding::BinaryLittleEndian, Path::new("t.ply")).unwrap();
        let err = decode_bytes(&bytes[..bytes.len() - 1]).unwrap_err();
        let needed = cloud.points.len() as u64 * 16;
        assert!(
            matches!(err, DataError::CloudTruncated { needed: n, available, unit: "bytes", .. } if n == needed && available == needed - 1),
            "{err:?}"
        );
    }

    #[test]
    fn malformed_ascii_vertex_is_a_data_error() {
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 nan 3\n";
        let err = decode_bytes(text.as_bytes()).unwrap_err();
        assert!(matches!(err, DataError::CloudData { .. }), "{err:?}");
        assert!(err.to_string().contains("frame9.ply"), "{err}");
    }
}
