//! The 360° sidecar: `label_360/%06d.txt` beside `label_2`, one line per simulated object, for
//! Waymo-style and streaming evaluation (KITTI's own labels cover the camera view only).
//!
//! Each line has 12 space-separated fields, LiDAR frame, floats `%.4f`:
//!
//! ```text
//! class track_id x y z dx dy dz heading num_points occluded in_camera
//! Car 3 12.3456 -3.2100 -0.9500 3.9000 1.6300 1.5200 0.0100 245 1 1
//! ```
//!
//! `class` is a KITTI class name; `track_id` is stable across the frames of a sequence;
//! `[x y z dx dy dz heading]` is the box in this workspace's layout (crate docs);
//! `num_points` the LiDAR returns on the object; `occluded` KITTI's level 0–3 from the ray
//! casting; `in_camera` 1 if the object has a `label_2` line (as itself or as DontCare).

use super::ObjectClass;
use crate::io::{atomic_write, read_text};
use crate::{Box3d, DataError, Result};
use std::path::Path;

/// One simulated object as the sidecar records it.
#[derive(Debug, Clone, PartialEq)]
pub struct SimObject {
    /// Object class.
    pub class: ObjectClass,
    /// Track id, stable across a sequence.
    pub track_id: u32,
    /// Tight box, LiDAR frame.
    pub b: Box3d,
    /// LiDAR returns on the object.
    pub num_points: u32,
    /// Rays whose line of sight crosses the object (not written to the sidecar).
    pub rays_toward: u32,
    /// Rays whose first return is on the object (not written to the sidecar).
    pub rays_hit: u32,
    /// KITTI occlusion level, 0–3.
    pub occlusion: i32,
    /// Whether `label_2` has a line for it.
    pub in_camera: bool,
}

impl SimObject {
    /// The sidecar line.
    pub fn to_line(&self) -> String {
        // A tiny negative prints as -0.0000 (as C's printf does) and parses back to −0.0, which
        // prints the same again: lines round-trip exactly.
        let b = &self.b;
        format!(
            "{} {} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {} {} {} {}",
            self.class,
            self.track_id,
            b.x,
            b.y,
            b.z,
            b.dx,
            b.dy,
            b.dz,
            heading_text(b.heading),
            self.num_points,
            self.occlusion,
            self.in_camera as u8
        )
    }

    /// Parses a sidecar line (ray counts are not stored and come back as 0).
    pub fn parse_line(text: &str, path: &Path, line: usize) -> Result<Self> {
        const NAMES: [&str; 12] = [
            "class",
            "track_id",
            "x",
            "y",
            "z",
            "dx",
            "dy",
            "dz",
            "heading",
            "num_points",
            "occluded",
            "in_camera",
        ];
        let f: Vec<&str> = text.split_ascii_whitespace().collect();
        if f.len() != 12 {
            return Err(DataError::parse(
                path,
                line,
                "fields",
                format!("expected 12 fields, found {}", f.len()),
            ));
        }
        let class = ObjectClass::from_name(f[0])
            .ok_or_else(|| DataError::parse(path, line, "class", format!("unknown class `{}`", f[0])))?;
        let bad = |i: usize| DataError::parse(path, line, NAMES[i], format!("`{}` is not valid", f[i]));
        let num = |i: usize| f[i].parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| bad(i));
        let int = |i: usize| f[i].parse::<u32>().map_err(|_| bad(i));
        let in_camera = match f[11] {
            "0" => false,
            "1" => true,
            _ => return Err(bad(11)),
        };
        Ok(Self {
            class,
            track_id: int(1)?,
            b: Box3d::new(num(2)?, num(3)?, num(4)?, num(5)?, num(6)?, num(7)?, num(8)?),
            num_points: int(9)?,
            rays_toward: 0,
            rays_hit: 0,
            occlusion: f[10]
                .parse::<i32>()
                .ok()
                .filter(|o| (0..=3).contains(o))
                .ok_or_else(|| bad(10))?,
            in_camera,
        })
    }
}

/// A heading at the line's 4 decimals, so that parsing the text (which wraps to [−π, π)) and
/// printing again gives the same text. ±π rounds to ±3.1416, outside [−π, π) on both sides:
/// −3.1416 parses to the same angle as 3.1416 (they differ by 2π − 6.2832, under 1e-5 rad) and
/// stands for both.
fn heading_text(heading: f32) -> String {
    let text = format!("{heading:.4}");
    if text.trim_start_matches('-') == "3.1416" {
        "-3.1416".to_string()
    } else {
        text
    }
}

/// Reads a sidecar file.
pub fn read_sidecar(path: &Path) -> Result<Vec<SimObject>> {
    parse_sidecar(&read_text(path)?, path)
}

/// Parses the text of a sidecar file; errors name `path` and the line.
pub fn parse_sidecar(text: &str, path: &Path) -> Result<Vec<SimObject>> {
    text.lines()
        .enumerate()
        .map(|(i, l)| SimObject::parse_line(l, path, i + 1))
        .collect()
}

/// Writes a sidecar file atomically.
pub fn write_sidecar(path: &Path, objects: &[SimObject]) -> Result<()> {
    let text: String = objects.iter().map(|o| o.to_line() + "\n").collect();
    atomic_write(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_round_trip_and_errors() {
        let line = "Cyclist 7 12.3456 -3.2100 -0.9500 1.7500 0.6800 1.7400 -3.1000 245 1 0";
        let o = SimObject::parse_line(line, Path::new("s.txt"), 1).unwrap();
        assert_eq!(o.class, ObjectClass::Cyclist);
        assert_eq!((o.track_id, o.num_points, o.occlusion, o.in_camera), (7, 245, 1, false));
        assert_eq!(o.to_line(), line);
        let err = SimObject::parse_line(&line.replace(" 1 0", " 5 0"), Path::new("s.txt"), 4).unwrap_err();
        assert!(err.to_string().starts_with("s.txt:4: occluded:"), "{err}");
    }

    #[test]
    fn headings_near_pi_round_trip() {
        use std::f32::consts::PI;
        let base = "Car 1 10.0000 2.0000 -1.0000 4.0000 1.6000 1.5000";
        for h in [
            -PI,
            -PI + 1e-5,
            -PI + 4e-5,
            PI - 1e-5,
            PI - 4e-5,
            PI - 9e-5,
            9e-5 - PI,
            0.0,
        ] {
            let first = SimObject::parse_line(&format!("{base} {h:.6} 10 0 1"), Path::new("s.txt"), 1).unwrap();
            let line = first.to_line();
            let again = SimObject::parse_line(&line, Path::new("s.txt"), 1).unwrap();
            assert_eq!(again.to_line(), line, "heading {h}");
            // The same angle, to the line's precision.
            assert!(
                crate::wrap_angle(again.b.heading - h).abs() < 1e-4,
                "{h} -> {}",
                again.b.heading
            );
        }
    }
}
