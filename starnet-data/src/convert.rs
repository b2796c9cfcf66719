//! Converting a dataset between the KITTI layout and the custom layout ([`crate::custom`]),
//! `starnet convert`. The points pass unchanged (f32 bits), and so does the text of the box
//! fields between a `label_360` sidecar and a custom label file: a heading printed as ±3.1416
//! lies outside [−π, π) and parses to the other end of the range, so printing the parsed value
//! again would change it. So:
//!
//! - custom → KITTI → custom gives the same bytes (points and labels);
//! - the simulator's KITTI data → custom → KITTI gives the same `velodyne/` bytes, the same
//!   `ImageSets/` and the same `label_360` boxes and classes; what the custom format has no
//!   field for (track ids, occlusion, `label_2`) is not carried.
//!
//! KITTI → custom takes a frame's `label_360/` when it has one, else its `label_2/` through its
//! calibration (then only the objects in the camera's view; DontCare is dropped). Custom → KITTI
//! writes `training/velodyne/`, `training/label_360/` (track id 0, the points inside each box
//! counted, occlusion 0) and `training/calib/` (KITTI's frame 000000 as a stand-in); such a
//! dataset is read with `data.labels = "label_360"`.

use crate::cloud::{CloudFormat, Intensity, PointCloud, read_cloud, write_cloud};
use crate::custom::{CustomObject, labels_path, parse_custom_labels, points_path};
use crate::events::Task;
use crate::io::{atomic_write, read, read_text};
use crate::kitti::{Calib, KittiDataset, ObjectClass, parse_sidecar, read_labels, read_points};
use crate::staging::{Claim, Staging};
use crate::{DataError, Result};
use std::path::Path;

/// What a conversion wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Converted {
    /// Frames converted.
    pub frames: usize,
    /// The `ImageSets/*.txt` split files copied, by name.
    pub splits: Vec<String>,
}

/// Runs `write` into the staging folder of `dst` ([`Staging`]: `dst` appears only when the
/// conversion is complete; an interrupted one of the same job is redone into the same folder).
fn staged(src: &Path, dst: &Path, layout: &str, write: impl FnOnce(&Path) -> Result<Converted>) -> Result<Converted> {
    let job = serde_json::json!({ "convert": layout, "from": src.display().to_string() });
    match Staging::claim(dst, &job)? {
        Claim::Exists => Err(DataError::Occupied {
            path: dst.to_path_buf(),
        }),
        Claim::Write(staging) => {
            let done = write(staging.path())?;
            staging.finish()?;
            Ok(done)
        }
    }
}

/// Writes the KITTI dataset at `src` (its `training/` frames) in the custom layout at `dst`,
/// which must be absent or empty.
pub fn kitti_to_custom(src: &Path, dst: &Path) -> Result<Converted> {
    staged(src, dst, "custom", |dst| write_custom(src, dst))
}

fn write_custom(src: &Path, dst: &Path) -> Result<Converted> {
    let ds = KittiDataset::open(src, None)?;
    let task = Task::begin("convert", ds.ids().len() as u64);
    for id in ds.ids() {
        let points = read_points(&ds.path("velodyne", id, "bin"))?;
        let cloud = PointCloud {
            points,
            intensity: Intensity::Measured,
        };
        write_cloud(&points_path(dst, id), &cloud, CloudFormat::Npy)?;
        let lines: String = kitti_objects(&ds, id)?.into_iter().map(|l| l + "\n").collect();
        atomic_write(&labels_path(dst, id), lines.as_bytes())?;
        task.inc(1);
    }
    Ok(Converted {
        frames: ds.ids().len(),
        splits: copy_splits(src, dst)?,
    })
}

/// A KITTI frame's objects as custom label lines: from `label_360/` when present (its text),
/// else `label_2/` through the frame's calibration (DontCare dropped).
fn kitti_objects(ds: &KittiDataset, id: &str) -> Result<Vec<String>> {
    let sidecar = ds.path("label_360", id, "txt");
    if sidecar.is_file() {
        let text = read_text(&sidecar)?;
        parse_sidecar(&text, &sidecar)?;
        // class track x y z dx dy dz heading ... → x y z dx dy dz heading class
        return Ok(text
            .lines()
            .map(|l| {
                let f: Vec<&str> = l.split_ascii_whitespace().collect();
                format!("{} {}", f[2..9].join(" "), f[0])
            })
            .collect());
    }
    let calib = Calib::read(&ds.path("calib", id, "txt"))?;
    let labels = read_labels(&ds.path("label_2", id, "txt"))?;
    Ok(labels
        .iter()
        .filter(|o| o.class != ObjectClass::DontCare)
        .map(|o| {
            let b = calib.label_to_box(&o.cam);
            CustomObject { b, class: o.class }.to_line()
        })
        .collect())
}

/// Writes the custom dataset at `src` in the KITTI layout at `dst` (see the module docs), which
/// must be absent or empty.
pub fn custom_to_kitti(src: &Path, dst: &Path) -> Result<Converted> {
    staged(src, dst, "kitti", |dst| write_kitti(src, dst))
}

fn write_kitti(src: &Path, dst: &Path) -> Result<Converted> {
    let ds = KittiDataset::open(src, None)?;
    let task = Task::begin("convert", ds.ids().len() as u64);
    let calib = Calib::kitti_000000();
    let training = dst.join("training");
    for id in ds.ids() {
        // A cloud without intensity is refused: KITTI's `.bin` has no way to say so.
        let cloud = read_cloud(&points_path(src, id))?;
        write_cloud(
            &training.join("velodyne").join(format!("{id}.bin")),
            &cloud,
            CloudFormat::KittiBin,
        )?;
        let lines = sidecar_lines(&labels_path(src, id), &cloud.points)?;
        atomic_write(&training.join("label_360").join(format!("{id}.txt")), lines.as_bytes())?;
        calib.write(&training.join("calib").join(format!("{id}.txt")))?;
        task.inc(1);
    }
    Ok(Converted {
        frames: ds.ids().len(),
        splits: copy_splits(src, dst)?,
    })
}

/// A custom label file as sidecar lines, the box fields as written: track 0, the points inside
/// each box counted, fully visible, outside the (absent) camera's labels.
fn sidecar_lines(labels: &Path, points: &[crate::Point]) -> Result<String> {
    let text = read_text(labels)?;
    let objects = parse_custom_labels(&text, labels)?;
    let rows = text.lines().filter(|l| !l.trim().is_empty());
    Ok(rows
        .zip(&objects)
        .map(|(l, o)| {
            let f: Vec<&str> = l.split_ascii_whitespace().collect();
            let inside = o.b.count_points_inside(points);
            format!("{} 0 {} {inside} 0 0\n", o.class, f[..7].join(" "))
        })
        .collect())
}

/// Copies `src/ImageSets/*.txt` to `dst/ImageSets/`; returns the split names.
fn copy_splits(src: &Path, dst: &Path) -> Result<Vec<String>> {
    let dir = src.join("ImageSets");
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let entries = std::fs::read_dir(&dir).map_err(|e| DataError::io(&dir, e))?;
    let mut names = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| DataError::io(&dir, e))?.path();
        if let (Some(stem), true) = (path.file_stem(), path.extension().is_some_and(|e| e == "txt")) {
            atomic_write(
                &dst.join("ImageSets").join(path.file_name().expect("a file")),
                &read(&path)?,
            )?;
            names.push(stem.to_string_lossy().into_owned());
        }
    }
    names.sort();
    Ok(names)
}
