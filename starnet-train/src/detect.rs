//! `starnet detect`: the whole pipeline on raw sweeps (KITTI velodyne `.bin`, PCD, PLY or NumPy
//! `.npy` point clouds, [`starnet_data::cloud`]): center sampling,
//! gathering, the network, decoding and NMS, at the config's evaluation budget. For each sweep
//! it writes `{id}.json` (LiDAR-frame boxes) and, when a calibration is known, `{id}.txt` in
//! KITTI's result format (boxes that project into image 2, with their 2D boxes).
//!
//! The calibration of `ROOT/…/velodyne/{id}.bin` is `--calib FILE` if given, else
//! `ROOT/…/calib/{id}.txt` when it exists. Without one the centers are sampled all around the
//! sensor (no camera frustum) and only the JSON is written. A cloud without an intensity channel
//! needs a geometry-only model (`pipeline.gather.reflectance = "ignored"`, as the quickstart's).

use crate::detector::{Detector, frame_seed};
use crate::{Result, TrainError};
use starnet_data::DataError;
use starnet_data::cloud::{CLOUD_EXTENSIONS, Intensity, Kept, PointCloud, read_cloud};
use starnet_data::io::atomic_write;
use starnet_data::kitti::{Calib, Frame, ImageSize, KittiObject, write_results};
use starnet_data::sampling::ReflectanceInput;
use starnet_eval::{DetectedBox, SweepDetections, to_kitti};
use std::path::{Path, PathBuf};

/// The point clouds of `input`: the file itself, or a folder's `.bin`, `.pcd`, `.ply` and `.npy`
/// files by name.
pub fn sweep_files(input: &Path) -> Result<Vec<PathBuf>> {
    if input.is_file() {
        return Ok(vec![input.to_path_buf()]);
    }
    let entries = std::fs::read_dir(input).map_err(|e| starnet_data::DataError::io(input, e))?;
    let is_cloud = |p: &PathBuf| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| CLOUD_EXTENSIONS.contains(&e))
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(is_cloud)
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(TrainError::NoInput {
            dir: input.to_path_buf(),
            what: format!("point cloud (.{})", CLOUD_EXTENSIONS.join(", .")),
        });
    }
    Ok(files)
}

/// The points of a sweep read from `source`, beyond-range points dropped (counted) or refused
/// as the pipeline says; a cloud without intensity only for a model that ignores it.
fn sweep_points(cloud: PointCloud, source: &Path, detector: &Detector) -> Result<Kept> {
    let reads_reflectance = detector.pipeline.gather.reflectance == ReflectanceInput::Measured;
    if cloud.intensity == Intensity::Absent && reads_reflectance {
        return Err(DataError::MissingIntensity {
            path: source.to_path_buf(),
        }
        .into());
    }
    Ok(detector.pipeline.wild_points.apply(cloud.points, source)?)
}

/// The calibration of a sweep: `given`, or the KITTI layout's `../calib/{id}.txt`.
fn calibration(bin: &Path, given: Option<&Path>) -> Result<Option<Calib>> {
    let sibling = || {
        let id = bin.file_stem()?;
        let root = bin.parent()?.parent()?;
        Some(root.join("calib").join(id).with_extension("txt")).filter(|p| p.is_file())
    };
    match given.map(Path::to_path_buf).or_else(sibling) {
        Some(p) => Ok(Some(Calib::read(&p)?)),
        None => Ok(None),
    }
}

/// One sweep detected: its boxes (LiDAR frame) and, with a calibration, its KITTI result
/// lines (the boxes that project into image 2).
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedSweep {
    /// The boxes, as `{id}.json` holds them.
    pub sweep: SweepDetections,
    /// The KITTI result lines, as `{id}.txt` holds them; `None` without a calibration.
    pub kitti: Option<Vec<KittiObject>>,
}

/// Detects the objects of one sweep, `cloud` (from `source`, which errors name) with its
/// calibration `calib`, sampling from `seed`: centers in the camera frustum with a
/// calibration, all around the sensor without. What `starnet detect` does per file.
pub fn detect_sweep(
    detector: &Detector,
    cloud: PointCloud,
    source: &Path,
    id: &str,
    calib: Option<Calib>,
    seed: u64,
) -> Result<DetectedSweep> {
    let kept = sweep_points(cloud, source, detector)?;
    let calibrated = calib.is_some();
    let frame = Frame {
        id: id.to_string(),
        points: kept.points,
        objects: Vec::new(),
        calib: calib.unwrap_or_else(Calib::kitti_000000),
        image_size: ImageSize::KITTI,
    };
    let detections = if calibrated {
        detector.detect(&frame, seed)
    } else {
        let mut all_around = detector.clone();
        all_around.pipeline.pool.camera_frustum = false;
        all_around.detect(&frame, seed)
    };
    let kitti = calibrated.then(|| {
        detections
            .iter()
            .filter_map(|d| to_kitti(d, &frame.calib, frame.image_size))
            .collect()
    });
    let boxes = detections.iter().map(|d| DetectedBox {
        class: d.class,
        score: d.score,
        b: d.b.to_array(),
    });
    let sweep = SweepDetections {
        id: id.to_string(),
        num_points: frame.points.len(),
        wild_points_dropped: kept.dropped,
        calibrated,
        detections: boxes.collect(),
    };
    Ok(DetectedSweep { sweep, kitti })
}

/// Runs `detector` on each sweep and writes the results into `out`; sweep `i` samples from
/// `frame_seed(seed, i)`, as an evaluation's frame `i` does. A sweep without a calibration gets
/// centers all around the sensor.
pub fn detect(
    detector: &Detector,
    seed: u64,
    inputs: &[PathBuf],
    calib: Option<&Path>,
    out: &Path,
) -> Result<Vec<SweepDetections>> {
    std::fs::create_dir_all(out).map_err(|e| starnet_data::DataError::io(out, e))?;
    let mut all = Vec::with_capacity(inputs.len());
    for (i, bin) in inputs.iter().enumerate() {
        let id = bin
            .file_stem()
            .map_or_else(|| format!("{i:06}"), |s| s.to_string_lossy().into_owned());
        let found = calibration(bin, calib)?;
        let detected = detect_sweep(detector, read_cloud(bin)?, bin, &id, found, frame_seed(seed, i))?;
        if let Some(lines) = &detected.kitti {
            write_results(&out.join(format!("{id}.txt")), lines)?;
        }
        let json = serde_json::to_vec_pretty(&detected.sweep).expect("detections serialise");
        atomic_write(&out.join(format!("{id}.json")), &json)?;
        all.push(detected.sweep);
    }
    Ok(all)
}
