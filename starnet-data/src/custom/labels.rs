//! The custom layout's label files: one object per line, LiDAR frame, the box first and the
//! class last, as OpenPCDet's custom dataset writes them:
//!
//! ```text
//! x y z dx dy dz heading class
//! 12.3456 -3.2100 -0.9500 3.9000 1.6300 1.5200 0.0100 Car
//! ```
//!
//! `[x y z dx dy dz heading]` is this workspace's box layout (crate docs: centre, length along the
//! heading, width, height, heading counter-clockwise about +z from +x); `class` a KITTI class
//! name. Writers print `%.4f` (0.1 mm, as the simulator's `label_360` sidecar does), so a
//! sidecar's boxes pass through this format unchanged.

use crate::class::ObjectClass;
use crate::io::{atomic_write, read_text};
use crate::{Box3d, DataError, Result};
use std::path::Path;

/// One labelled object of the custom layout.
#[derive(Debug, Clone, PartialEq)]
pub struct CustomObject {
    /// The box, LiDAR frame.
    pub b: Box3d,
    /// Its class.
    pub class: ObjectClass,
}

const FIELDS: [&str; 8] = ["x", "y", "z", "dx", "dy", "dz", "heading", "class"];

impl CustomObject {
    /// The label line (without a newline).
    pub fn to_line(&self) -> String {
        let b = &self.b;
        format!(
            "{:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {}",
            b.x, b.y, b.z, b.dx, b.dy, b.dz, b.heading, self.class
        )
    }

    /// Parses a label line; errors name `path`, the 1-based `line` and the field.
    pub fn parse_line(text: &str, path: &Path, line: usize) -> Result<Self> {
        let f: Vec<&str> = text.split_ascii_whitespace().collect();
        if f.len() != FIELDS.len() {
            return Err(DataError::parse(
                path,
                line,
                "fields",
                format!("expected 8 fields `x y z dx dy dz heading class`, found {}", f.len()),
            ));
        }
        let num = |i: usize| {
            f[i].parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| DataError::parse(path, line, FIELDS[i], format!("`{}` is not a finite number", f[i])))
        };
        let size = |i: usize| {
            num(i).and_then(|v| match v > 0.0 {
                true => Ok(v),
                false => Err(DataError::parse(
                    path,
                    line,
                    FIELDS[i],
                    format!("{v} is not a positive size"),
                )),
            })
        };
        let class = ObjectClass::from_name(f[7])
            .ok_or_else(|| DataError::parse(path, line, "class", format!("unknown class `{}`", f[7])))?;
        Ok(Self {
            b: Box3d::new(num(0)?, num(1)?, num(2)?, size(3)?, size(4)?, size(5)?, num(6)?),
            class,
        })
    }
}

/// Parses the text of a label file (blank lines are skipped); errors name `path` and the line.
pub fn parse_custom_labels(text: &str, path: &Path) -> Result<Vec<CustomObject>> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| CustomObject::parse_line(l, path, i + 1))
        .collect()
}

/// Reads a label file.
pub fn read_custom_labels(path: &Path) -> Result<Vec<CustomObject>> {
    parse_custom_labels(&read_text(path)?, path)
}

/// Writes a label file atomically.
pub fn write_custom_labels(path: &Path, objects: &[CustomObject]) -> Result<()> {
    let text: String = objects.iter().map(|o| o.to_line() + "\n").collect();
    atomic_write(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_round_trips_and_reads_as_written() {
        let line = "12.3456 -3.2100 -0.9500 3.9000 1.6300 1.5200 0.0100 Car";
        let o = CustomObject::parse_line(line, Path::new("l.txt"), 1).unwrap();
        assert_eq!(o.class, ObjectClass::Car);
        assert_eq!(o.b.to_array(), [12.3456, -3.21, -0.95, 3.9, 1.63, 1.52, 0.01]);
        assert_eq!(o.to_line(), line);
        // More digits than the writer keeps parse, and print rounded to 0.1 mm.
        let long = CustomObject::parse_line("1.23456789 0 0 4 2 1.5 -0.5 Cyclist", Path::new("l.txt"), 1).unwrap();
        assert_eq!(
            long.to_line(),
            "1.2346 0.0000 0.0000 4.0000 2.0000 1.5000 -0.5000 Cyclist"
        );
    }

    #[test]
    fn bad_lines_name_the_file_line_and_field() {
        let cases = [
            ("1 2 3 4 5 6 Car", "fields"),
            ("1 2 nan 4 5 6 0 Car", "z"),
            ("1 2 3 4 -5 6 0 Car", "dy"),
            ("1 2 3 4 5 6 0 Bus", "class"),
        ];
        for (line, field) in cases {
            let text = format!("1 2 3 4 5 6 0 Car\n\n{line}\n");
            let err = parse_custom_labels(&text, Path::new("labels/000007.txt")).unwrap_err();
            let msg = err.to_string();
            assert!(msg.starts_with(&format!("labels/000007.txt:3: {field}:")), "{msg}");
        }
    }
}
