//! Evaluating a model on a split at a center/point budget: detections for every frame, written
//! as KITTI result files; KITTI AP, Waymo-style AP/APH and AP per 10 m against the labels; the
//! per-frame latency.

use crate::Result;
use crate::config::ExperimentConfig;
use crate::eval::{
    ClassAp, RangeAp, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, ap_by_range, kitti_ap, waymo_ap,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use starnet_data::kitti::{
    Calib, Frame, ImageSize, KittiDataset, KittiObject, LabelSource, ObjectClass, observation_angle, write_results,
};
use starnet_data::sampling::{CenterTarget, GatherConfig, PipelineConfig, prepare_frame};
use starnet_data::sim::sub_seed;
use starnet_model::batch::{decode_frame, make_input};
use starnet_model::flops::forward_gflop;
use starnet_model::nms::Detection;
use starnet_model::nn::StarNet;
use std::path::Path;
use std::time::Instant;

/// How much compute a frame gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Budget {
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Which sampled centers the model sees.
    pub target: CenterTarget,
}

impl Budget {
    /// The config's evaluation budget.
    pub fn of(cfg: &ExperimentConfig) -> Self {
        Self {
            num_centers: cfg.eval.num_centers,
            num_points: cfg.eval.num_points,
            target: CenterTarget::All,
        }
    }

    /// Centers the model sees.
    pub fn model_centers(&self) -> usize {
        self.target.count(self.num_centers)
    }

    /// `base` (the pool, sampler, center z, radius and metric) at this budget.
    pub fn pipeline(&self, base: &PipelineConfig) -> PipelineConfig {
        PipelineConfig {
            num_centers: self.num_centers,
            target: self.target,
            gather: GatherConfig {
                num_points: self.num_points,
                ..base.gather
            },
            ..base.clone()
        }
    }
}

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
            writeln!(
                f,
                "| class | IoU | metric | easy R40 | moderate R40 | hard R40 | easy R11 | moderate R11 | hard R11 |"
            )?;
            writeln!(f, "|---|---|---|---|---|---|---|---|---|")?;
        }
        for c in &self.classes {
            let mut rows = vec![("3D", c.three_d), ("BEV", c.bev), ("2D", c.bbox)];
            if let Some(a) = c.aos {
                rows.push(("AOS", a));
            }
            for (name, ap) in rows {
                writeln!(
                    f,
                    "| {} | {:.1} | {name} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
                    c.class, c.min_overlap, ap[0].r40, ap[1].r40, ap[2].r40, ap[0].r11, ap[1].r11, ap[2].r11
                )?;
            }
        }
        writeln!(f, "\nWaymo-style 3D AP / APH (LEVEL_1 > 5 points, LEVEL_2 ≥ 1):")?;
        writeln!(
            f,
            "| class | IoU | level | objects | AP | APH | 0-30 m | 30-50 m | 50+ m |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|---|---|")?;
        for c in &self.waymo {
            for l in 0..2 {
                let r = &c.ranges[l];
                writeln!(
                    f,
                    "| {} | {:.1} | LEVEL_{} | {} | {:.2} | {:.2} | {:.2} / {:.2} | {:.2} / {:.2} | {:.2} / {:.2} |",
                    c.class,
                    c.iou,
                    l + 1,
                    c.num_objects[l],
                    c.levels[l].ap,
                    c.levels[l].aph,
                    r[0].ap,
                    r[0].aph,
                    r[1].ap,
                    r[1].aph,
                    r[2].ap,
                    r[2].aph
                )?;
            }
        }
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

/// Evaluates `model` (in validation mode, on a plain device) on `dataset` at `budget`; writes
/// `{id}.txt` result files to `results` when given.
pub fn evaluate(
    model: &StarNet,
    cfg: &ExperimentConfig,
    dataset: &KittiDataset,
    budget: Budget,
    results: Option<&Path>,
) -> Result<EvalReport> {
    let device = starnet_model::backend::default_device();
    let pipeline = budget.pipeline(&cfg.pipeline);
    let nms = cfg.nms_config();
    let anchors = &cfg.model.anchors;
    let mut scorer = Scorer::new(cfg, dataset.labels(), results);
    for (chunk_i, ids) in dataset.ids().chunks(cfg.eval.batch_size).enumerate() {
        let loaded: Vec<_> = ids
            .iter()
            .map(|id| dataset.load(id))
            .collect::<std::result::Result<_, _>>()?;
        // Latency: from the loaded scan to the final boxes (reading files and scoring excluded).
        let start = Instant::now();
        let prepared: Vec<_> = loaded
            .iter()
            .enumerate()
            .map(|(k, f)| {
                prepare_frame(
                    f,
                    &pipeline,
                    None,
                    &[],
                    &mut ChaCha8Rng::seed_from_u64(frame_seed(cfg, chunk_i * cfg.eval.batch_size + k)),
                )
            })
            .collect();
        let out = model.forward(make_input(&prepared.iter().collect::<Vec<_>>(), &device));
        let decoded: Vec<_> = prepared
            .iter()
            .enumerate()
            .map(|(k, p)| decode_frame(&out, k, p, anchors, &nms))
            .collect();
        let per_frame = start.elapsed().as_secs_f64() * 1e3 / ids.len() as f64;
        for (frame, decoded) in loaded.into_iter().zip(decoded) {
            scorer.add(frame, &decoded, per_frame)?;
        }
    }
    Ok(scorer.finish(budget))
}

/// The seed of the `i`-th evaluated frame's sampling RNG.
pub fn frame_seed(cfg: &ExperimentConfig, i: usize) -> u64 {
    sub_seed(cfg.seed, 21, i as u64)
}

/// Collects frames and their detections and scores them: KITTI AP (camera-view labels),
/// Waymo-style AP/APH and AP per 10 m, with the per-frame latencies given. Frames are reduced
/// to what scoring needs as they arrive, so a split never sits in memory.
pub struct Scorer<'a> {
    cfg: &'a ExperimentConfig,
    camera_view: bool,
    results: Option<&'a Path>,
    frames: Vec<(Vec<KittiObject>, Vec<KittiObject>)>,
    calibs: Vec<Calib>,
    waymo_frames: Vec<WaymoFrame>,
    times: Vec<f64>,
}

impl<'a> Scorer<'a> {
    /// Scores against `labels`; writes `{id}.txt` result files to `results` when given.
    pub fn new(cfg: &'a ExperimentConfig, labels: LabelSource, results: Option<&'a Path>) -> Self {
        Self {
            cfg,
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
        let cfg = self.cfg;
        let projected: Vec<Option<KittiObject>> = detections
            .iter()
            .map(|d| to_kitti(d, &cfg.data.classes, &frame.calib, frame.image_size))
            .collect();
        // Camera-view labels: a detection counts when it projects into the image.
        let lidar = detections
            .iter()
            .zip(&projected)
            .filter(|(_, kitti)| !self.camera_view || kitti.is_some())
            .map(|(d, _)| WaymoDetection {
                class: cfg.data.classes[d.class],
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

    /// The report, for frames evaluated at `budget`.
    pub fn finish(self, budget: Budget) -> EvalReport {
        let cfg = self.cfg;
        EvalReport {
            frames: self.frames.len(),
            num_centers: budget.num_centers,
            num_points: budget.num_points,
            target: budget.target,
            gflop_per_frame: forward_gflop(&cfg.model_config(), budget.model_centers(), budget.num_points),
            latency_ms_mean: mean(&self.times),
            latency_ms_p95: quantile(&self.times, 0.95),
            classes: if self.camera_view {
                kitti_ap(&self.frames, &cfg.data.classes)
            } else {
                Vec::new()
            },
            waymo: waymo_ap(&self.waymo_frames, &cfg.data.classes),
            by_range: if self.camera_view {
                ap_by_range(&self.frames, &self.calibs, cfg.data.classes[0], RANGE_BINS_MAX_M)
            } else {
                Vec::new()
            },
        }
    }
}

/// The `q` quantile of `values` (the value at rank ⌊len · q⌋ once sorted; 0 without values).
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted
        .get(((sorted.len() as f64 * q) as usize).min(sorted.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0)
}

/// The mean of `values` (0 without values).
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
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
