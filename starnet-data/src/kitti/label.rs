//! `label_2` files: one object per line, 15 space-separated fields for ground truth
//! (`type truncated occluded alpha left top right bottom h w l x y z rotation_y`) and a 16th,
//! `score`, for detection results. Box fields are in the camera-rect frame; see
//! [`super::Calib::label_to_box`] for the LiDAR box.

use crate::class::ObjectClass;
use crate::io::{atomic_write, read_text};
use crate::{DataError, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// A box as a label file stores it, in the camera-rect frame: `(x, y, z)` is the **bottom**
/// centre, `(h, w, l)` the extents, `ry` the rotation about camera y (0 = length along +x).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub struct CameraBox {
    pub h: f32,
    pub w: f32,
    pub l: f32,
    pub x: f32,
    pub y: f32,
    pub z: f32,
    pub ry: f32,
}

/// KITTI difficulty of a ground-truth object, and the devkit's thresholds that define it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum Difficulty {
    Easy,
    Moderate,
    Hard,
}

impl Difficulty {
    /// Easy, moderate, hard: the devkit's order (its `difficulty` index 0, 1, 2).
    pub const ALL: [Difficulty; 3] = [Difficulty::Easy, Difficulty::Moderate, Difficulty::Hard];

    /// The least 2D box height, pixels (`MIN_HEIGHT`).
    pub fn min_height(self) -> f32 {
        [40.0, 25.0, 25.0][self as usize]
    }

    /// The most occlusion level (`MAX_OCCLUSION`).
    pub fn max_occlusion(self) -> i32 {
        [0, 1, 2][self as usize]
    }

    /// The most truncation (`MAX_TRUNCATION`).
    pub fn max_truncation(self) -> f32 {
        [0.15, 0.3, 0.5][self as usize]
    }
}

/// The alpha of a line that gives none (DontCare regions; a result file whose detector has no
/// orientation): the devkit computes AOS only when the first detection's alpha differs.
pub const NO_ALPHA: f32 = -10.0;

/// One line of a label or result file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KittiObject {
    /// Object type.
    pub class: ObjectClass,
    /// Fraction of the object outside the image, [0, 1] (−1 for DontCare and results).
    pub truncated: f32,
    /// 0 fully visible, 1 partly, 2 largely occluded, 3 unknown (−1 for DontCare and results).
    pub occluded: i32,
    /// Observation angle `ry − atan2(x, z)`, [−π, π].
    pub alpha: f32,
    /// 2D box in image 2, pixels: `[left, top, right, bottom]`.
    pub bbox: [f32; 4],
    /// The 3D box in the camera-rect frame.
    pub cam: CameraBox,
    /// Detection score; `Some` for result files (16 fields).
    pub score: Option<f32>,
}

impl KittiObject {
    /// A DontCare region: a 2D box with KITTI's sentinel values in every other field.
    pub fn dont_care(bbox: [f32; 4]) -> Self {
        Self {
            class: ObjectClass::DontCare,
            truncated: -1.0,
            occluded: -1,
            alpha: NO_ALPHA,
            bbox,
            cam: CameraBox {
                h: -1.0,
                w: -1.0,
                l: -1.0,
                x: -1000.0,
                y: -1000.0,
                z: -1000.0,
                ry: -10.0,
            },
            score: None,
        }
    }

    /// Height of the 2D box in pixels.
    pub fn bbox_height(&self) -> f32 {
        self.bbox[3] - self.bbox[1]
    }

    /// The easiest difficulty whose thresholds the object meets (OpenPCDet's
    /// `get_kitti_obj_level`, height ≥ the minimum): easy (height ≥ 40 px, truncation ≤ 0.15,
    /// occlusion 0), moderate (≥ 25, ≤ 0.30, ≤ 1), hard (≥ 25, ≤ 0.50, ≤ 2); `None` for none.
    pub fn difficulty(&self) -> Option<Difficulty> {
        let (h, t, o) = (self.bbox_height(), self.truncated, self.occluded);
        Difficulty::ALL
            .into_iter()
            .find(|d| h >= d.min_height() && t <= d.max_truncation() && o <= d.max_occlusion())
    }

    /// Parses one line; `path` and `line` (1-based) locate errors.
    pub fn parse_line(text: &str, path: &Path, line: usize) -> Result<Self> {
        const NAMES: [&str; 16] = [
            "type",
            "truncated",
            "occluded",
            "alpha",
            "left",
            "top",
            "right",
            "bottom",
            "h",
            "w",
            "l",
            "x",
            "y",
            "z",
            "rotation_y",
            "score",
        ];
        let fields: Vec<&str> = text.split_ascii_whitespace().collect();
        if fields.len() != 15 && fields.len() != 16 {
            return Err(DataError::parse(
                path,
                line,
                "fields",
                format!(
                    "expected 15 (ground truth) or 16 (with score) fields, found {}",
                    fields.len()
                ),
            ));
        }
        let class = ObjectClass::from_name(fields[0]).ok_or_else(|| {
            let known: Vec<_> = ObjectClass::ALL.iter().map(|c| c.as_str()).collect();
            DataError::parse(
                path,
                line,
                "type",
                format!("unknown class `{}` (expected one of {})", fields[0], known.join(", ")),
            )
        })?;
        let num = |i: usize| -> Result<f32> {
            fields[i].parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                DataError::parse(path, line, NAMES[i], format!("`{}` is not a finite number", fields[i]))
            })
        };
        let occluded = fields[2]
            .parse::<i32>()
            .map_err(|_| DataError::parse(path, line, "occluded", format!("`{}` is not an integer", fields[2])))?;
        Ok(Self {
            class,
            truncated: num(1)?,
            occluded,
            alpha: num(3)?,
            bbox: [num(4)?, num(5)?, num(6)?, num(7)?],
            cam: CameraBox {
                h: num(8)?,
                w: num(9)?,
                l: num(10)?,
                x: num(11)?,
                y: num(12)?,
                z: num(13)?,
                ry: num(14)?,
            },
            score: if fields.len() == 16 { Some(num(15)?) } else { None },
        })
    }

    /// The ground-truth line as KITTI writes it: `%.2f` floats, integer occlusion, and the
    /// fixed sentinel fields of DontCare regions. A score, if any, follows as `%.2f`.
    pub fn to_label_line(&self) -> String {
        let mut s = String::with_capacity(96);
        let [l, t, r, b] = self.bbox;
        if self.class == ObjectClass::DontCare {
            let _ = write!(
                s,
                "DontCare -1 -1 -10 {l:.2} {t:.2} {r:.2} {b:.2} -1 -1 -1 -1000 -1000 -1000 -10"
            );
        } else {
            let c = &self.cam;
            let _ = write!(
                s,
                "{} {:.2} {} {:.2} {l:.2} {t:.2} {r:.2} {b:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
                self.class, self.truncated, self.occluded, self.alpha, c.h, c.w, c.l, c.x, c.y, c.z, c.ry
            );
        }
        if let Some(score) = self.score {
            let _ = write!(s, " {score:.2}");
        }
        s
    }

    /// The detection-result line as OpenPCDet writes it for the KITTI server:
    /// `type -1 -1 alpha bbox(4) h w l x y z ry score`, all `%.4f`.
    pub fn to_result_line(&self) -> String {
        let c = &self.cam;
        let [l, t, r, b] = self.bbox;
        format!(
            "{} -1 -1 {:.4} {l:.4} {t:.4} {r:.4} {b:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4} {:.4}",
            self.class,
            self.alpha,
            c.h,
            c.w,
            c.l,
            c.x,
            c.y,
            c.z,
            c.ry,
            self.score.unwrap_or(0.0)
        )
    }
}

/// Parses a whole label (or result) file held in memory. Blank lines are rejected: KITTI has
/// none, and a blank line usually means a damaged file.
pub fn parse_labels(text: &str, path: &Path) -> Result<Vec<KittiObject>> {
    let body = text.strip_suffix('\n').unwrap_or(text);
    if body.is_empty() {
        return Ok(Vec::new());
    }
    body.split('\n')
        .enumerate()
        .map(|(i, l)| KittiObject::parse_line(l.strip_suffix('\r').unwrap_or(l), path, i + 1))
        .collect()
}

/// Reads a `label_2` or result file.
pub fn read_labels(path: &Path) -> Result<Vec<KittiObject>> {
    parse_labels(&read_text(path)?, path)
}

/// Formats ground truth exactly as KITTI does, one `\n`-terminated line per object. Put
/// DontCare regions last (OpenPCDet assumes it); [`write_labels`] does.
pub fn format_labels(objects: &[KittiObject]) -> String {
    objects.iter().map(|o| o.to_label_line() + "\n").collect()
}

/// Writes ground truth atomically, DontCare regions moved last (stable otherwise).
pub fn write_labels(path: &Path, objects: &[KittiObject]) -> Result<()> {
    let mut sorted = objects.to_vec();
    sorted.sort_by_key(|o| o.class == ObjectClass::DontCare);
    atomic_write(path, format_labels(&sorted).as_bytes())
}

/// Writes a detection-result file atomically in the submission format (an empty file for a
/// frame with no detections, as the devkit expects).
pub fn write_results(path: &Path, detections: &[KittiObject]) -> Result<()> {
    let text: String = detections.iter().map(|o| o.to_result_line() + "\n").collect();
    atomic_write(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    const CAR: &str = "Car 0.00 0 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57";
    const DONT: &str = "DontCare -1 -1 -10 503.89 169.71 590.61 190.13 -1 -1 -1 -1000 -1000 -1000 -10";

    #[test]
    fn parses_fields_into_place() {
        let o = KittiObject::parse_line(CAR, Path::new("l.txt"), 1).unwrap();
        assert_eq!(o.class, ObjectClass::Car);
        assert_eq!(o.occluded, 0);
        assert_eq!(o.bbox, [387.63, 181.54, 423.81, 203.12]);
        assert_eq!((o.cam.h, o.cam.w, o.cam.l), (1.67, 1.87, 3.69));
        assert_eq!((o.cam.x, o.cam.y, o.cam.z, o.cam.ry), (-16.53, 2.39, 58.49, 1.57));
        assert_eq!(o.score, None);
    }

    #[test]
    fn dont_care_constructor_writes_kittis_line() {
        let o = KittiObject::dont_care([503.89, 169.71, 590.61, 190.13]);
        assert_eq!(o.to_label_line(), DONT);
        assert_eq!(KittiObject::parse_line(DONT, Path::new("l.txt"), 1).unwrap(), o);
    }

    #[test]
    fn lines_round_trip_exactly() {
        for line in [
            CAR,
            DONT,
            "Pedestrian 0.00 0 -0.20 712.40 143.00 810.73 307.92 1.89 0.48 1.20 1.84 1.47 8.41 0.01",
        ] {
            let o = KittiObject::parse_line(line, Path::new("l.txt"), 1).unwrap();
            assert_eq!(o.to_label_line(), line);
        }
    }

    #[test]
    fn result_line_has_score_and_four_decimals() {
        let mut o = KittiObject::parse_line(CAR, Path::new("l.txt"), 1).unwrap();
        o.score = Some(0.87654);
        let line = o.to_result_line();
        assert!(line.starts_with("Car -1 -1 1.8500 387.6300 "), "{line}");
        assert!(line.ends_with(" 1.5700 0.8765"), "{line}");
        let back = KittiObject::parse_line(&line, Path::new("r.txt"), 1).unwrap();
        assert_eq!(back.score, Some(0.8765));
        assert_eq!(back.cam, o.cam);
    }

    #[test]
    fn wrong_field_count_names_file_and_line() {
        let text = format!("{CAR}\nCar 0.00 0 1.85\n");
        let err = parse_labels(&text, Path::new("label_2/000003.txt")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("label_2/000003.txt:2: fields:"), "{msg}");
        assert!(msg.contains("found 4"), "{msg}");
    }

    #[test]
    fn unknown_class_is_rejected() {
        let err = parse_labels(&CAR.replace("Car", "Bus"), Path::new("a.txt")).unwrap_err();
        assert!(
            matches!(&err, DataError::Parse { line: 1, field, .. } if field == "type"),
            "{err:?}"
        );
        assert!(err.to_string().contains("`Bus`"));
    }

    #[test]
    fn bad_number_names_the_field() {
        let err = parse_labels(&CAR.replace("58.49", "5x.49"), Path::new("a.txt")).unwrap_err();
        assert!(
            matches!(&err, DataError::Parse { field, .. } if field == "z"),
            "{err:?}"
        );
        let err = parse_labels(&CAR.replace("58.49", "nan"), Path::new("a.txt")).unwrap_err();
        assert!(
            matches!(&err, DataError::Parse { field, .. } if field == "z"),
            "{err:?}"
        );
    }

    #[test]
    fn blank_line_is_an_error_not_a_skip() {
        let err = parse_labels(&format!("{CAR}\n\n{CAR}\n"), Path::new("a.txt")).unwrap_err();
        assert!(matches!(err, DataError::Parse { line: 2, .. }), "{err:?}");
    }

    #[test]
    fn writer_puts_dontcare_last() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("000000.txt");
        let objs = parse_labels(&format!("{DONT}\n{CAR}\n"), Path::new("a")).unwrap();
        write_labels(&p, &objs).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), format!("{CAR}\n{DONT}\n"));
    }

    #[test]
    fn difficulty_thresholds() {
        let mut o = KittiObject::parse_line(CAR, Path::new("a"), 1).unwrap();
        o.bbox = [0.0, 0.0, 10.0, 40.0];
        assert_eq!(o.difficulty(), Some(Difficulty::Easy));
        o.occluded = 1;
        assert_eq!(o.difficulty(), Some(Difficulty::Moderate));
        o.truncated = 0.4;
        assert_eq!(o.difficulty(), Some(Difficulty::Hard));
        o.bbox[3] = 24.0;
        assert_eq!(o.difficulty(), None);
    }
}
