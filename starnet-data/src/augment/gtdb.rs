//! The ground-truth database for copy-paste augmentation: every labelled object of the train
//! split with the LiDAR points inside its box grown by [`GTDB_CAPTURE_MARGIN`], at their original
//! positions (lingvo pastes objects at their original pose), written to one versioned binary
//! file. The paste step keeps those within the configured object margin
//! ([`GtEntry::points_within`]), so the file does not depend on that setting.
//!
//! File layout (little-endian): the 8-byte magic `STNGTDB\0`, a `u32` format version (2), a
//! `u32` entry count, then per entry: `u8` class (index in [`ObjectClass::ALL`]), `i8`
//! difficulty (0 easy, 1 moderate, 2 hard, −1 none), `u16` frame-id length and the id's bytes,
//! 7 × `f32` box `[x y z dx dy dz heading]`, `u32` point count N and N × 4 × `f32` points.

use crate::io::{atomic_write, read};
use crate::kitti::{Difficulty, KittiDataset, LabelSource, ObjectClass};
use crate::par::parallel_for;
use crate::{Box3d, DataError, Point, Result};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

const MAGIC: &[u8; 8] = b"STNGTDB\0";
/// Format version written and accepted.
pub const GTDB_VERSION: u32 = 2;
/// How far beyond its box (sides and top, [`Box3d::grown`]) an entry's points are captured: the
/// largest object margin the paste step can use.
pub const GTDB_CAPTURE_MARGIN: f32 = 0.25;

/// One object of the database.
#[derive(Debug, Clone, PartialEq)]
pub struct GtEntry {
    /// Frame it came from.
    pub frame: String,
    /// Object class.
    pub class: ObjectClass,
    /// KITTI difficulty.
    pub difficulty: Option<Difficulty>,
    /// Box, LiDAR frame.
    pub b: Box3d,
    /// Points inside the box grown by [`GTDB_CAPTURE_MARGIN`], absolute LiDAR coordinates of
    /// the source frame.
    pub points: Vec<Point>,
}

impl GtEntry {
    /// The entry's points inside its box grown by `margin` (at most [`GTDB_CAPTURE_MARGIN`]).
    pub fn points_within(&self, margin: f32) -> impl Iterator<Item = &Point> {
        let inside = self.b.grown(margin.min(GTDB_CAPTURE_MARGIN)).containment();
        self.points.iter().filter(move |p| inside([p[0], p[1], p[2]]))
    }
}

/// All entries.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GtDatabase {
    /// Entries in frame order, then label order.
    pub entries: Vec<GtEntry>,
}

impl GtDatabase {
    /// Builds the database from every frame of `dataset` (use the train split), in parallel.
    pub fn build(dataset: &KittiDataset, progress: &(dyn Fn() + Sync)) -> Result<Self> {
        let per_frame: Vec<Mutex<Vec<GtEntry>>> = dataset.ids().iter().map(|_| Mutex::new(Vec::new())).collect();
        parallel_for(dataset.ids().len(), |i| {
            let id = &dataset.ids()[i];
            let frame = dataset.load(id)?;
            let entries = frame
                .labelled_boxes()
                .into_iter()
                .map(|(o, b)| GtEntry {
                    frame: id.clone(),
                    class: o.class,
                    difficulty: o.difficulty(),
                    b,
                    points: b
                        .grown(GTDB_CAPTURE_MARGIN)
                        .points_inside(&frame.points)
                        .into_iter()
                        .map(|k| frame.points[k])
                        .collect(),
                })
                .collect();
            *per_frame[i].lock().expect("no panics while holding it") = entries;
            progress();
            Ok(())
        })?;
        Ok(Self {
            entries: per_frame
                .into_iter()
                .flat_map(|m| m.into_inner().expect("no panics while holding it"))
                .collect(),
        })
    }

    /// The file bytes.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&GTDB_VERSION.to_le_bytes());
        out.extend_from_slice(&(self.entries.len() as u32).to_le_bytes());
        for e in &self.entries {
            out.push(
                ObjectClass::ALL
                    .iter()
                    .position(|c| *c == e.class)
                    .expect("every class is in ALL") as u8,
            );
            out.push(match e.difficulty {
                Some(Difficulty::Easy) => 0,
                Some(Difficulty::Moderate) => 1,
                Some(Difficulty::Hard) => 2,
                None => -1i8 as u8,
            });
            out.extend_from_slice(&(e.frame.len() as u16).to_le_bytes());
            out.extend_from_slice(e.frame.as_bytes());
            e.b.to_array()
                .iter()
                .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            out.extend_from_slice(&(e.points.len() as u32).to_le_bytes());
            e.points
                .iter()
                .flatten()
                .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        }
        out
    }

    /// Parses file bytes; `path` names the file in errors.
    pub fn decode(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = Reader { bytes, at: 0, path };
        if r.take(8, "magic")? != MAGIC {
            return Err(r.error(
                "magic",
                "not a starnet ground-truth database (run `starnet prepare`)".into(),
            ));
        }
        let version = r.u32("version")?;
        if version != GTDB_VERSION {
            return Err(r.error(
                "version",
                format!("format version {version}, this build reads {GTDB_VERSION}; run `starnet prepare` again"),
            ));
        }
        let count = r.u32("entry count")? as usize;
        let mut entries = Vec::with_capacity(count.min(1 << 20));
        for _ in 0..count {
            let class_code = r.take(1, "class")?[0] as usize;
            let class = *ObjectClass::ALL
                .get(class_code)
                .ok_or_else(|| r.error("class", format!("unknown class code {class_code}")))?;
            let difficulty = match r.take(1, "difficulty")?[0] as i8 {
                0 => Some(Difficulty::Easy),
                1 => Some(Difficulty::Moderate),
                2 => Some(Difficulty::Hard),
                -1 => None,
                d => return Err(r.error("difficulty", format!("invalid difficulty {d}"))),
            };
            let id_len = u16::from_le_bytes(r.take(2, "frame id length")?.try_into().expect("2 bytes")) as usize;
            let frame = String::from_utf8(r.take(id_len, "frame id")?.to_vec())
                .map_err(|_| r.error("frame id", "not UTF-8".into()))?;
            let mut b = [0f32; 7];
            for v in &mut b {
                *v = r.f32("box")?;
            }
            let n = r.u32("point count")? as usize;
            let raw = r.take(n * 16, "points")?;
            let points = crate::kitti::decode_points(raw, path)?;
            entries.push(GtEntry {
                frame,
                class,
                difficulty,
                b: Box3d::from_array(b),
                points,
            });
        }
        if r.at != bytes.len() {
            return Err(r.error("end", format!("{} bytes after the last entry", bytes.len() - r.at)));
        }
        Ok(Self { entries })
    }

    /// Writes the database atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        atomic_write(path, &self.encode())
    }

    /// Whether `path` holds a database of this build's format version (a database written by an
    /// older build is rebuilt rather than read).
    pub fn is_current(path: &Path) -> bool {
        let mut head = [0u8; 12];
        std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
            && head[..8] == *MAGIC
            && head[8..12] == GTDB_VERSION.to_le_bytes()
    }

    /// Reads a database file.
    pub fn read(path: &Path) -> Result<Self> {
        Self::decode(&read(path)?, path)
    }
}

/// A cursor that names the field and byte offset of any truncation.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    fn error(&self, field: &str, message: String) -> DataError {
        DataError::parse(self.path, 0, format!("{field} at byte {}", self.at), message)
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8]> {
        let end = self.at.checked_add(n).filter(|e| *e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.error(field, format!("file ends after {} bytes (truncated)", self.bytes.len())));
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self, field: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, field)?.try_into().expect("4 bytes")))
    }

    fn f32(&mut self, field: &str) -> Result<f32> {
        let v = f32::from_le_bytes(self.take(4, field)?.try_into().expect("4 bytes"));
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(field, format!("non-finite value {v}")))
        }
    }
}

/// Where `starnet prepare` writes the database of a KITTI root's `split` from `labels`:
/// `gt_database.bin` from the camera-view labels of `train`, `gt_database_360.bin` from the
/// simulator's all-around ones (whose objects lie all around the sensor, so that an all-around
/// model is pasted objects behind it as well as in front); another split's name goes before the
/// extension (`gt_database.fewshot_train.bin`). One file per split: a run on a split must never
/// paste the objects of frames it does not train on.
pub fn database_path(root: &Path, labels: LabelSource, split: &str) -> PathBuf {
    let stem = match labels {
        LabelSource::Camera => "gt_database",
        LabelSource::AllAround => "gt_database_360",
    };
    root.join(if split == "train" {
        format!("{stem}.bin")
    } else {
        format!("{stem}.{split}.bin")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_db() -> GtDatabase {
        GtDatabase {
            entries: vec![
                GtEntry {
                    frame: "000001".into(),
                    class: ObjectClass::Car,
                    difficulty: Some(Difficulty::Moderate),
                    b: Box3d::new(10.0, 1.0, -1.0, 4.0, 1.6, 1.5, 0.2),
                    points: vec![[10.0, 1.0, -1.0, 0.3]; 3],
                },
                GtEntry {
                    frame: "000007".into(),
                    class: ObjectClass::PersonSitting,
                    difficulty: None,
                    b: Box3d::new(5.0, -2.0, -1.0, 0.8, 0.6, 1.2, -1.0),
                    points: vec![],
                },
            ],
        }
    }

    #[test]
    fn round_trip() {
        let db = sample_db();
        let bytes = db.encode();
        assert_eq!(&bytes[..8], MAGIC);
        assert_eq!(GtDatabase::decode(&bytes, Path::new("db")).unwrap(), db);
    }

    #[test]
    fn only_this_versions_files_are_current() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gt_database.bin");
        assert!(!GtDatabase::is_current(&path));
        sample_db().write(&path).unwrap();
        assert!(GtDatabase::is_current(&path));
        let mut old = sample_db().encode();
        old[8..12].copy_from_slice(&1u32.to_le_bytes());
        std::fs::write(&path, old).unwrap();
        assert!(!GtDatabase::is_current(&path));
    }

    #[test]
    fn corrupt_files_are_named_not_panicked() {
        let bytes = sample_db().encode();
        for cut in [3, 12, 20, bytes.len() - 1] {
            let err = GtDatabase::decode(&bytes[..cut], Path::new("gt_database.bin"))
                .unwrap_err()
                .to_string();
            assert!(
                err.starts_with("gt_database.bin:") && err.contains("truncated"),
                "{cut}: {err}"
            );
        }
        let mut wrong = bytes.clone();
        wrong[8] = 9;
        assert!(
            GtDatabase::decode(&wrong, Path::new("db"))
                .unwrap_err()
                .to_string()
                .contains("format version 9")
        );
        let mut extra = bytes.clone();
        extra.push(0);
        assert!(
            GtDatabase::decode(&extra, Path::new("db"))
                .unwrap_err()
                .to_string()
                .contains("after the last entry")
        );
        assert!(
            GtDatabase::decode(b"not a database at all", Path::new("db"))
                .unwrap_err()
                .to_string()
                .contains("magic")
        );
    }
}
