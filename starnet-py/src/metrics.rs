//! KITTI AP (as the official devkit computes it) and Waymo-style AP/APH over a KITTI split,
//! from a result folder or from arrays: the figures of `starnet eval --results`, as the dict its
//! `eval.json` holds.

use crate::cloud::f32_array;
use crate::errors::to_py;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_eval::{
    DetectedBox, FrameResults, ResultFormat, SweepDetections, kitti_frames, kitti_results, score_frames, score_results,
};
use std::collections::HashMap;
use std::path::PathBuf;

/// Scores the result folder `results` (`{id}.txt` KITTI result lines or `{id}.json` as
/// `starnet detect` writes them; `format` "kitti" or "detect", default: whichever the split's
/// first frame has) against the KITTI root `gt_root`'s `split`.
#[pyfunction]
#[pyo3(signature = (gt_root, results, *, split = "val".to_string(), classes = None, labels = "label_2".to_string(), format = None))]
pub fn score_folder<'py>(
    py: Python<'py>,
    gt_root: PathBuf,
    results: PathBuf,
    split: String,
    classes: Option<Vec<String>>,
    labels: String,
    format: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let format = parse_format(format)?;
    let classes = classes.map(|c| parse_classes(&c)).transpose()?;
    let labels = parse_labels(&labels)?;
    let scores = py
        .detach(|| {
            let dataset = KittiDataset::open(&gt_root, Some(&split))?.with_labels(labels);
            score_results(&dataset, &results, format, classes.as_deref())
        })
        .map_err(to_py)?;
    as_dict(py, &scores)
}

/// KITTI AP alone of the result folder `results` (as [`score_folder`] reads it) against the
/// camera-view labels of `gt_root`'s `split`: `score_folder(...)["classes"]`, without reading
/// the scans or computing the other metrics.
#[pyfunction]
#[pyo3(signature = (gt_root, results, *, split = "val".to_string(), classes = None, format = None))]
pub fn kitti_folder<'py>(
    py: Python<'py>,
    gt_root: PathBuf,
    results: PathBuf,
    split: String,
    classes: Option<Vec<String>>,
    format: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let format = parse_format(format)?;
    let classes = classes.map(|c| parse_classes(&c)).transpose()?;
    let aps = py
        .detach(|| {
            let dataset = KittiDataset::open(&gt_root, Some(&split))?;
            kitti_results(&dataset, &results, format, classes.as_deref())
        })
        .map_err(to_py)?;
    as_dict(py, &aps)
}

/// Scores `results`, a dict from every frame id of the split to that frame's detections (an
/// object with `boxes`, `scores` and `classes`, such as `Detector.detect`'s result), against the
/// KITTI root `gt_root`'s `split`.
#[pyfunction]
#[pyo3(signature = (gt_root, results, *, split = "val".to_string(), classes = None, labels = "label_2".to_string()))]
pub fn score_arrays<'py>(
    py: Python<'py>,
    gt_root: PathBuf,
    results: HashMap<String, Bound<'py, PyAny>>,
    split: String,
    classes: Option<Vec<String>>,
    labels: String,
) -> PyResult<Bound<'py, PyAny>> {
    let classes = classes.map(|c| parse_classes(&c)).transpose()?;
    let dataset = KittiDataset::open(&gt_root, Some(&split))
        .map_err(to_py)?
        .with_labels(parse_labels(&labels)?);
    let frames = split_results(&dataset, &results, &split)?;
    let scores = py
        .detach(|| score_frames(&dataset, frames, classes.as_deref()))
        .map_err(to_py)?;
    as_dict(py, &scores)
}

/// KITTI AP alone of `results` (as [`score_arrays`] takes them) against the camera-view labels
/// of `gt_root`'s `split`: `score_arrays(...)["classes"]`, without reading the scans.
#[pyfunction]
#[pyo3(signature = (gt_root, results, *, split = "val".to_string(), classes = None))]
pub fn kitti_arrays<'py>(
    py: Python<'py>,
    gt_root: PathBuf,
    results: HashMap<String, Bound<'py, PyAny>>,
    split: String,
    classes: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyAny>> {
    let classes = classes.map(|c| parse_classes(&c)).transpose()?;
    let dataset = KittiDataset::open(&gt_root, Some(&split)).map_err(to_py)?;
    let frames = split_results(&dataset, &results, &split)?;
    let aps = py
        .detach(|| kitti_frames(&dataset, frames, classes.as_deref()))
        .map_err(to_py)?;
    as_dict(py, &aps)
}

/// Every frame's detections of the split, in its order; a frame missing or one outside the
/// split is an error.
fn split_results(
    dataset: &KittiDataset,
    results: &HashMap<String, Bound<'_, PyAny>>,
    split: &str,
) -> PyResult<Vec<FrameResults>> {
    let ids = dataset.ids();
    let frames = ids
        .iter()
        .map(|id| frame_results(id, results.get(id)))
        .collect::<PyResult<Vec<_>>>()?;
    match results.keys().find(|k| !ids.contains(k)) {
        Some(extra) => Err(PyValueError::new_err(format!(
            "results: frame {extra:?} is not in split {split:?}"
        ))),
        None => Ok(frames),
    }
}

/// Frame `id`'s detections from `given`: `boxes` (`[M, 7]`, LiDAR frame), `scores` (`[M]`) and
/// `classes` (M names), as attributes (a `Detections`) or keys (a dict).
fn frame_results(id: &str, given: Option<&Bound<'_, PyAny>>) -> PyResult<FrameResults> {
    let given = given.ok_or_else(|| {
        PyValueError::new_err(format!(
            "results: no detections for frame {id:?}; every frame of the split needs an entry (empty arrays for none), as in the devkit"
        ))
    })?;
    let context = |e: PyErr| PyValueError::new_err(format!("results[{id:?}]: {e}"));
    let boxes = f32_array(&field(given, "boxes")?)?;
    let scores = f32_array(&field(given, "scores")?)?;
    let classes: Vec<String> = field(given, "classes")?.extract().map_err(context)?;
    let (boxes, scores) = (boxes.as_array(), scores.as_array());
    let m = classes.len();
    if boxes.shape() != [m, 7] || scores.shape() != [m] {
        return Err(PyValueError::new_err(format!(
            "results[{id:?}]: boxes {:?}, scores {:?}, {m} classes; expected [M, 7], [M] and M",
            boxes.shape(),
            scores.shape()
        )));
    }
    let detections = (0..m)
        .map(|i| {
            Ok(DetectedBox {
                class: parse_class(&classes[i])?,
                score: scores[[i]],
                b: std::array::from_fn(|k| boxes[[i, k]]),
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    Ok(FrameResults::Detect(SweepDetections {
        id: id.to_string(),
        num_points: 0,
        wild_points_dropped: 0,
        calibrated: false,
        detections,
    }))
}

/// `given[name]` for a dict, else `given.name`.
fn field<'py>(given: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    match given.cast::<PyDict>() {
        Ok(d) => d
            .get_item(name)?
            .ok_or_else(|| PyValueError::new_err(format!("no key {name:?}"))),
        Err(_) => given.getattr(name),
    }
}

fn parse_class(name: &str) -> PyResult<ObjectClass> {
    ObjectClass::from_name(name).ok_or_else(|| {
        PyValueError::new_err(format!(
            "unknown class {name:?} (KITTI's names: Car, Pedestrian, Cyclist, ...)"
        ))
    })
}

fn parse_classes(names: &[String]) -> PyResult<Vec<ObjectClass>> {
    names.iter().map(|n| parse_class(n)).collect()
}

fn parse_labels(name: &str) -> PyResult<LabelSource> {
    serde_json::from_value(serde_json::Value::String(name.into())).map_err(|_| {
        PyValueError::new_err(format!(
            "unknown labels {name:?} (expected \"label_2\" or \"label_360\")"
        ))
    })
}

fn parse_format(format: Option<String>) -> PyResult<Option<ResultFormat>> {
    format
        .map(|f| f.parse::<ResultFormat>().map_err(PyValueError::new_err))
        .transpose()
}

/// `scores` as `eval.json` holds them (Python's `json.loads` of the same text).
fn as_dict<'py>(py: Python<'py>, scores: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(scores).expect("scores serialise");
    py.import("json")?.call_method1("loads", (text,))
}
