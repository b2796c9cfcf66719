//! Evaluating a model on a split at a center/point budget: detections for every frame, written
//! as KITTI result files; KITTI AP, Waymo-style AP/APH and AP per 10 m against the labels; the
//! per-frame latency.

use crate::Result;
use crate::config::ExperimentConfig;
use crate::detector::Detector;
use crate::eval::{
    ClassAp, RangeAp, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, ap_by_range, kitti_ap, waymo_ap,
};
use crate::synth::progress_bar;
use crate::table::Table;
use serde::{Deserialize, Serialize};
use starnet_data::kitti::{
    Calib, Frame, ImageSize, KittiDataset, KittiObject, LabelSource, ObjectClass, observation_angle, write_results,
};
use starnet_data::sampling::CenterTarget;
use starnet_data::sim::sub_seed;
use starnet_data::summary::{mean, quantile};
use starnet_model::nms::Detection;
use std::path::Path;
use std::time::Instant;

/// Distance bins of [`EvalReport::by_range`] reach this far, metres.
pub const RANGE_BINS_MAX_M: f32 = 80.0;

/// What an evaluation found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvalReport {
    /// Frames evaluated.
    pub frames: usize,
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Which sampled centers the model saw.
    pub target: CenterTarget,
    /// Forward GFLOP per frame at this budget.
    pub gflop_per_frame: f64,
    /// Mean wall time per frame (preparation, forward, decoding), ms.
    pub latency_ms_mean: f64,
    /// 95th percentile of the per-frame time, ms.
    pub latency_ms_p95: f64,
    /// KITTI AP per class.
    pub classes: Vec<ClassAp>,
    /// Waymo-style AP/APH per class (the labelled objects, LiDAR point counts from the scan).
    pub waymo: Vec<WaymoClassAp>,
    /// KITTI AP (moderate) of the first class per 10 m of distance.
    pub by_range: Vec<RangeAp>,
}

impl EvalReport {
    /// The headline: 3D AP (R40) at moderate difficulty of the first class, or with 360° labels
    /// (no KITTI metrics) its Waymo-style LEVEL_1 AP.
    pub fn headline(&self) -> f64 {
        self.classes
            .first()
            .map(|c| c.three_d[1].r40)
            .or_else(|| self.waymo.first().map(|w| w.levels[0].ap))
            .unwrap_or(0.0)
    }
}

impl EvalReport {
    /// KITTI AP per class and metric (3D, BEV, 2D, AOS), R40 and R11 at each difficulty.
    fn kitti_table(&self) -> Table {
        let mut t = Table::new([
            "class",
            "IoU",
            "metric",
            "easy R40",
            "moderate R40",
            "hard R40",
            "easy R11",
            "moderate R11",
            "hard R11",
        ]);
        for c in &self.classes {
            let mut rows = vec![("3D", c.three_d), ("BEV", c.bev), ("2D", c.bbox)];
            if let Some(a) = c.aos {
                rows.push(("AOS", a));
            }
            for (name, ap) in rows {
                let head = [c.class.to_string(), format!("{:.1}", c.min_overlap), name.into()];
                let r40 = ap.iter().map(|d| format!("{:.2}", d.r40));
                let r11 = ap.iter().map(|d| format!("{:.2}", d.r11));
                t.row(head.into_iter().chain(r40).chain(r11));
            }
        }
        t
    }

    /// Waymo-style AP / APH per class and level, overall and per distance band.
    fn waymo_table(&self) -> Table {
        let mut t = Table::new([
            "class", "IoU", "level", "objects", "AP", "APH", "0-30 m", "30-50 m", "50+ m",
        ]);
        for c in &self.waymo {
            for l in 0..2 {
                let head = [
                    c.class.to_string(),
                    format!("{:.1}", c.iou),
                    format!("LEVEL_{}", l + 1),
                    c.num_objects[l].to_string(),
                    format!("{:.2}", c.levels[l].ap),
                    format!("{:.2}", c.levels[l].aph),
                ];
                let bands = c.ranges[l].iter().map(|r| format!("{:.2} / {:.2}", r.ap, r.aph));
                t.row(head.into_iter().chain(bands));
            }
        }
        t
    }
}

impl std::fmt::Display for EvalReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let target = match self.target {
            CenterTarget::All => String::new(),
            t => format!(" (target {t})"),
        };
        writeln!(
            f,
            "{} frames, {} centers{target} x {} points ({:.2} GFLOP/frame), latency {:.1} ms mean, {:.1} ms p95",
            self.frames,
            self.num_centers,
            self.num_points,
            self.gflop_per_frame,
            self.latency_ms_mean,
            self.latency_ms_p95
        )?;
        if !self.classes.is_empty() {
            write!(f, "{}", self.kitti_table())?;
        }
        writeln!(f, "\nWaymo-style 3D AP / APH (LEVEL_1 > 5 points, LEVEL_2 ≥ 1):")?;
        write!(f, "{}", self.waymo_table())?;
        if let (Some(c), false) = (self.classes.first(), self.by_range.is_empty()) {
            write!(f, "\n{} 3D AP R40 moderate by distance:", c.class)?;
            for b in self.by_range.iter().filter(|b| b.num_objects > 0) {
                write!(f, " {}-{} m {:.1} ({});", b.lo, b.hi, b.three_d.r40, b.num_objects)?;
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

/// A detection as a KITTI result line; `None` when its box does not project into image 2
/// (the KITTI evaluation needs the 2D box).
pub fn to_kitti(d: &Detection, classes: &[ObjectClass], calib: &Calib, image: ImageSize) -> Option<KittiObject> {
    let cam = calib.box_to_label(&d.b);
    let bbox = calib.image_bbox(&cam, image)?;
    Some(KittiObject {
        class: classes[d.class],
        truncated: -1.0,
        occluded: -1,
        alpha: observation_angle(&cam),
        bbox,
        cam,
        score: Some(d.score),
    })
}

/// How [`evaluate`] batches and seeds the frames of a split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EvalOptions {
    /// Frames per forward.
    pub batch_size: usize,
    /// The experiment seed: frame `i` samples its centers from [`frame_seed`]`(seed, i)`.
    pub seed: u64,
}

impl EvalOptions {
    /// The config's evaluation batch size and seed.
    pub fn of(cfg: &ExperimentConfig) -> Self {
        Self {
            batch_size: cfg.eval.batch_size,
            seed: cfg.seed,
        }
    }
}

/// Evaluates `detector` on `dataset` at its budget; writes `{id}.txt` result files to
/// `results` when given.
pub fn evaluate(
    detector: &Detector,
    dataset: &KittiDataset,
    opts: EvalOptions,
    results: Option<&Path>,
) -> Result<EvalReport> {
    let mut scorer = Scorer::new(&detector.classes, dataset.labels(), results);
    let batch = opts.batch_size.max(1);
    let budget = detector.budget();
    let bar = progress_bar(
        dataset.ids().len() as u64,
        &format!("eval {} x {}", budget.num_centers, budget.num_points),
    );
    for (chunk_i, ids) in dataset.ids().chunks(batch).enumerate() {
        let loaded: Vec<_> = ids
            .iter()
            .map(|id| dataset.load(id))
            .collect::<std::result::Result<_, _>>()?;
        let seeds: Vec<u64> = (0..ids.len())
            .map(|k| frame_seed(opts.seed, chunk_i * batch + k))
            .collect();
        // Latency: from the loaded scan to the final boxes (reading files and scoring excluded).
        let start = Instant::now();
        let decoded = detector.detect_batch(&loaded.iter().collect::<Vec<_>>(), &seeds);
        let per_frame = start.elapsed().as_secs_f64() * 1e3 / ids.len() as f64;
        for (frame, decoded) in loaded.into_iter().zip(decoded) {
            scorer.add(frame, &decoded, per_frame)?;
        }
        bar.inc(ids.len() as u64);
    }
    bar.finish_and_clear();
    Ok(scorer.finish(detector))
}

/// The seed of the `i`-th evaluated frame's sampling RNG, for experiment seed `seed`.
pub fn frame_seed(seed: u64, i: usize) -> u64 {
    sub_seed(seed, 21, i as u64)
}

/// Collects frames and their detections and scores them: KITTI AP (camera-view labels),
/// Waymo-style AP/APH and AP per 10 m, with the per-frame latencies given. Frames are reduced
/// to what scoring needs as they arrive, so a split never sits in memory.
pub struct Scorer<'a> {
    classes: &'a [ObjectClass],
    camera_view: bool,
    results: Option<&'a Path>,
    frames: Vec<(Vec<KittiObject>, Vec<KittiObject>)>,
    calibs: Vec<Calib>,
    waymo_frames: Vec<WaymoFrame>,
    times: Vec<f64>,
}

impl<'a> Scorer<'a> {
    /// Scores against `labels`; writes `{id}.txt` result files to `results` when given.
    /// `classes` names the class indices of the detections.
    pub fn new(classes: &'a [ObjectClass], labels: LabelSource, results: Option<&'a Path>) -> Self {
        Self {
            classes,
            // KITTI's metrics need the camera-view labels; 360° labels get the Waymo-style ones only.
            camera_view: labels == LabelSource::Camera,
            results,
            frames: Vec::new(),
            calibs: Vec::new(),
            waymo_frames: Vec::new(),
            times: Vec::new(),
        }
    }

    /// Adds a frame, its final detections and the time they took (ms).
    pub fn add(&mut self, frame: Frame, detections: &[Detection], ms: f64) -> Result<()> {
        let classes = self.classes;
        let projected: Vec<Option<KittiObject>> = detections
            .iter()
            .map(|d| to_kitti(d, classes, &frame.calib, frame.image_size))
            .collect();
        // Camera-view labels: a detection counts when it projects into the image.
        let lidar = detections
            .iter()
            .zip(&projected)
            .filter(|(_, kitti)| !self.camera_view || kitti.is_some())
            .map(|(d, _)| WaymoDetection {
                class: classes[d.class],
                b: d.b,
                score: d.score,
            })
            .collect();
        let dets: Vec<KittiObject> = projected.into_iter().flatten().collect();
        if let Some(dir) = self.results {
            write_results(&dir.join(format!("{}.txt", frame.id)), &dets)?;
        }
        self.waymo_frames.push(WaymoFrame {
            objects: waymo_objects(&frame),
            detections: lidar,
        });
        self.calibs.push(frame.calib.clone());
        self.frames.push((frame.objects, dets));
        self.times.push(ms);
        Ok(())
    }

    /// The report of the frames `detector` saw (at its budget).
    pub fn finish(self, detector: &Detector) -> EvalReport {
        let budget = detector.budget();
        let classes = self.classes;
        EvalReport {
            frames: self.frames.len(),
            num_centers: budget.num_centers,
            num_points: budget.num_points,
            target: budget.target,
            gflop_per_frame: detector.gflop_per_frame(),
            latency_ms_mean: mean(&self.times),
            latency_ms_p95: quantile(&self.times, 0.95).unwrap_or(0.0),
            classes: if self.camera_view {
                kitti_ap(&self.frames, classes)
            } else {
                Vec::new()
            },
            waymo: waymo_ap(&self.waymo_frames, classes),
            by_range: if self.camera_view {
                ap_by_range(&self.frames, &self.calibs, classes[0], RANGE_BINS_MAX_M)
            } else {
                Vec::new()
            },
        }
    }
}

/// A frame's labelled objects (DontCare aside) as Waymo ground truth, with the LiDAR returns
/// inside each box counted from the scan.
pub fn waymo_objects(frame: &Frame) -> Vec<WaymoObject> {
    frame
        .labelled_boxes()
        .into_iter()
        .map(|(o, b)| WaymoObject {
            class: o.class,
            num_points: b.count_points_inside(&frame.points) as u32,
            b,
        })
        .collect()
}
