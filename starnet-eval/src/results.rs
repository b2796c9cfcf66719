//! Scoring a folder of result files, from this detector or any other, against a KITTI split:
//! `{id}.txt` in KITTI's result format (camera frame, as the devkit reads them), or `{id}.json`
//! as `starnet detect` writes them (LiDAR frame). As the devkit does, every frame of the split
//! needs its file (an empty one for a frame without detections).

use crate::detections::SweepDetections;
use crate::scorer::{Scorer, Scores};
use crate::{EvalError, Result};
use starnet_data::DataError;
use starnet_data::events::Task;
use starnet_data::geometry::Box3d;
use starnet_data::geometry::Detection;
use starnet_data::io::atomic_write;
use starnet_data::kitti::{KittiDataset, KittiObject, LabelSource, ObjectClass, read_labels};
use std::path::{Path, PathBuf};

/// What a result folder holds per frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResultFormat {
    /// `{id}.txt`: KITTI result lines (camera frame, with a score).
    Kitti,
    /// `{id}.json`: `starnet detect`'s [`SweepDetections`] (LiDAR frame).
    Detect,
}

impl ResultFormat {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Kitti => "txt",
            Self::Detect => "json",
        }
    }

    /// The format of `dir`: the one whose file for frame `id` exists (KITTI first).
    pub fn of_folder(dir: &Path, id: &str) -> Result<Self> {
        [Self::Kitti, Self::Detect]
            .into_iter()
            .find(|f| f.file(dir, id).is_file())
            .ok_or_else(|| EvalError::NoInput {
                dir: dir.to_path_buf(),
                what: format!("result file for frame {id} ({id}.txt or {id}.json)"),
            })
    }

    fn file(self, dir: &Path, id: &str) -> PathBuf {
        dir.join(format!("{id}.{}", self.extension()))
    }
}

impl std::str::FromStr for ResultFormat {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "kitti" => Ok(Self::Kitti),
            "detect" => Ok(Self::Detect),
            _ => Err(format!("unknown result format `{s}` (expected `kitti` or `detect`)")),
        }
    }
}

/// The detections of one frame, as a result folder holds them or as a caller built them.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameResults {
    /// KITTI result lines (camera frame), each with its score.
    Kitti(Vec<KittiObject>),
    /// `starnet detect`'s boxes (LiDAR frame).
    Detect(SweepDetections),
}

impl FrameResults {
    /// Reads frame `id`'s file of `dir` in `format`; a missing file is an error, as in the devkit.
    pub fn read(format: ResultFormat, dir: &Path, id: &str) -> Result<Self> {
        let path = format.file(dir, id);
        if !path.is_file() {
            return Err(DataError::MissingFile {
                frame: id.to_string(),
                path,
            }
            .into());
        }
        match format {
            ResultFormat::Kitti => Ok(Self::Kitti(read_scored(&path)?)),
            ResultFormat::Detect => Ok(Self::Detect(read_detect_json(&path, id)?)),
        }
    }

    fn classes(&self) -> Vec<ObjectClass> {
        match self {
            Self::Kitti(objects) => objects.iter().map(|o| o.class).collect(),
            Self::Detect(sweep) => sweep.detections.iter().map(|d| d.class).collect(),
        }
    }
}

/// A KITTI result file, every line with its score.
fn read_scored(path: &Path) -> Result<Vec<KittiObject>> {
    let objects = read_labels(path)?;
    match objects.iter().position(|o| o.score.is_none()) {
        Some(i) => Err(DataError::Parse {
            path: path.to_path_buf(),
            line: i + 1,
            field: "score".into(),
            message: "a result line needs a 16th field, the detection's score".into(),
        }
        .into()),
        None => Ok(objects),
    }
}

/// Reads `starnet detect`'s `{id}.json`; `id` is the frame it must describe.
pub fn read_detect_json(path: &Path, id: &str) -> Result<SweepDetections> {
    let text = std::fs::read_to_string(path).map_err(|e| DataError::io(path, e))?;
    let sweep: SweepDetections = serde_json::from_str(&text).map_err(|e| DataError::Parse {
        path: path.to_path_buf(),
        line: e.line(),
        field: "detections".into(),
        message: e.to_string(),
    })?;
    if sweep.id != id {
        return Err(DataError::Parse {
            path: path.to_path_buf(),
            line: 1,
            field: "id".into(),
            message: format!("the file describes frame {} but is named for frame {id}", sweep.id),
        }
        .into());
    }
    Ok(sweep)
}

/// The classes KITTI evaluates (Car, Pedestrian, Cyclist) that have a detection somewhere.
fn detected_classes(frames: &[FrameResults]) -> Vec<ObjectClass> {
    let found: Vec<ObjectClass> = frames.iter().flat_map(FrameResults::classes).collect();
    [ObjectClass::Car, ObjectClass::Pedestrian, ObjectClass::Cyclist]
        .into_iter()
        .filter(|c| found.contains(c))
        .collect()
}

/// Scores the result files in `dir` against `dataset` (each frame's labels, calibration and
/// scan): the same metrics and tables as a checkpoint's evaluation. `format` defaults to the
/// one found for the split's first frame; `classes` to the KITTI classes with a detection, in
/// the devkit's order. Detections of other classes are left out.
pub fn score_results(
    dataset: &KittiDataset,
    dir: &Path,
    format: Option<ResultFormat>,
    classes: Option<&[ObjectClass]>,
) -> Result<Scores> {
    let results = read_folder(dataset, dir, format)?;
    score_frames(dataset, results, classes).map_err(|e| in_folder(e, dir))
}

/// The result files in `dir` of every frame of `dataset`'s split, in its order.
pub(crate) fn read_folder(
    dataset: &KittiDataset,
    dir: &Path,
    format: Option<ResultFormat>,
) -> Result<Vec<FrameResults>> {
    let ids = dataset.ids();
    let first = ids.first().ok_or_else(|| EvalError::NoInput {
        dir: dataset.root().to_path_buf(),
        what: "frames in the split".into(),
    })?;
    let format = match format {
        Some(f) => f,
        None => ResultFormat::of_folder(dir, first)?,
    };
    if format == ResultFormat::Kitti && dataset.labels() != LabelSource::Camera {
        return Err(camera_only(dir.display().to_string()));
    }
    ids.iter().map(|id| FrameResults::read(format, dir, id)).collect()
}

/// `e`, a missing input named for the result folder rather than the dataset.
pub(crate) fn in_folder(e: EvalError, dir: &Path) -> EvalError {
    match e {
        EvalError::NoInput { what, .. } => EvalError::NoInput {
            dir: dir.to_path_buf(),
            what,
        },
        other => other,
    }
}

/// Scores `results`, one per frame of `dataset`'s split in its order, as [`score_results`]
/// scores a folder: for results held in memory (the Python package's arrays).
pub fn score_frames(
    dataset: &KittiDataset,
    results: Vec<FrameResults>,
    classes: Option<&[ObjectClass]>,
) -> Result<Scores> {
    let classes = scored_classes(dataset, &results, classes)?;
    let mut scorer = Scorer::new(&classes, dataset.labels(), None);
    let task = Task::begin("score", results.len() as u64);
    for (id, result) in dataset.ids().iter().zip(results) {
        let frame = dataset.load(id)?;
        match result {
            FrameResults::Kitti(objects) => scorer.add_results(frame, &objects)?,
            FrameResults::Detect(sweep) => scorer.add(frame, &detections_of(&sweep, &classes))?,
        }
        task.inc(1);
    }
    drop(task);
    Ok(scorer.finish())
}

/// The classes to score (`classes`, else those with a detection), once `results` is checked to
/// hold one entry per frame of the split and, for KITTI result lines, camera-view labels.
pub(crate) fn scored_classes(
    dataset: &KittiDataset,
    results: &[FrameResults],
    classes: Option<&[ObjectClass]>,
) -> Result<Vec<ObjectClass>> {
    let frames = dataset.ids().len();
    if results.len() != frames {
        return Err(EvalError::InvalidArgument {
            name: "results".into(),
            message: format!("{} frames of results for a split of {frames}", results.len()),
        });
    }
    let kitti = results.iter().any(|r| matches!(r, FrameResults::Kitti(_)));
    if kitti && dataset.labels() != LabelSource::Camera {
        return Err(camera_only("results".into()));
    }
    let classes = classes.map_or_else(|| detected_classes(results), <[_]>::to_vec);
    if classes.is_empty() {
        return Err(EvalError::NoInput {
            dir: dataset.root().to_path_buf(),
            what: "Car, Pedestrian or Cyclist detection (name the classes to score)".into(),
        });
    }
    Ok(classes)
}

/// KITTI result lines scored against 360° labels.
pub(crate) fn camera_only(name: String) -> EvalError {
    EvalError::InvalidArgument {
        name,
        message: "KITTI result files hold camera-view boxes only; score 360° labels from `detect` JSON files".into(),
    }
}

/// A sweep's boxes of `classes` as detections.
pub(crate) fn detections_of(sweep: &SweepDetections, classes: &[ObjectClass]) -> Vec<Detection> {
    sweep
        .detections
        .iter()
        .filter(|d| classes.contains(&d.class))
        .map(|d| Detection {
            b: Box3d::from_array(d.b),
            class: d.class,
            score: d.score,
        })
        .collect()
}

/// Writes `scores` as `dir/eval.json` (the fields a checkpoint's `eval.json` has beside its
/// budget).
pub fn write_scores(dir: &Path, scores: &Scores) -> Result<()> {
    let json = serde_json::to_string_pretty(scores).expect("scores serialise");
    Ok(atomic_write(&dir.join("eval.json"), json.as_bytes())?)
}
