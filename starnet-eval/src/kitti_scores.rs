//! KITTI AP alone, as the devkit computes it from label and result files: each frame's labels
//! and calibration are read, never its scan, and no other metric is computed. The figures are
//! those of [`crate::Scores::classes`] for the same results.

use crate::Result;
use crate::metrics::{ClassAp, KittiFrame, kitti_ap};
use crate::results::{FrameResults, ResultFormat, camera_only, detections_of, in_folder, read_folder, scored_classes};
use crate::scorer::{of_classes, written_results};
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use std::path::Path;

/// KITTI AP of the result files in `dir` (as [`crate::score_results`] reads them) against
/// `dataset`'s camera-view labels.
pub fn kitti_results(
    dataset: &KittiDataset,
    dir: &Path,
    format: Option<ResultFormat>,
    classes: Option<&[ObjectClass]>,
) -> Result<Vec<ClassAp>> {
    let results = read_folder(dataset, dir, format)?;
    kitti_frames(dataset, results, classes).map_err(|e| in_folder(e, dir))
}

/// KITTI AP of `results`, one per frame of `dataset`'s split in its order (as
/// [`crate::score_frames`] takes them), against its camera-view labels.
pub fn kitti_frames(
    dataset: &KittiDataset,
    results: Vec<FrameResults>,
    classes: Option<&[ObjectClass]>,
) -> Result<Vec<ClassAp>> {
    if dataset.labels() != LabelSource::Camera {
        return Err(camera_only(dataset.root().display().to_string()));
    }
    let classes = scored_classes(dataset, &results, classes)?;
    let frames = dataset
        .ids()
        .iter()
        .zip(results)
        .map(|(id, result)| {
            let a = dataset.load_annotations(id)?;
            let detections = match result {
                FrameResults::Kitti(objects) => of_classes(&objects, &classes),
                FrameResults::Detect(sweep) => {
                    written_results(&detections_of(&sweep, &classes), &a.calib, a.image_size)?
                }
            };
            Ok(KittiFrame {
                labels: a.objects,
                detections,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(kitti_ap(&frames, &classes))
}
