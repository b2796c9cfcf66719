//! Evaluating a model on a split: detections for every frame, written as KITTI result files,
//! and KITTI AP against the labels, with per-frame latency.

use crate::Result;
use crate::config::ExperimentConfig;
use crate::eval::{ClassAp, kitti_ap};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use starnet_data::kitti::{Calib, ImageSize, KittiDataset, KittiObject, ObjectClass, observation_angle, write_results};
use starnet_data::sampling::{GatherConfig, PipelineConfig, prepare_frame};
use starnet_data::sim::sub_seed;
use starnet_model::batch::{decode_frame, make_input};
use starnet_model::flops::forward_gflop;
use starnet_model::nms::Detection;
use starnet_model::nn::StarNet;
use std::path::Path;
use std::time::Instant;

/// What an evaluation found.
#[derive(Debug, Clone, Serialize)]
pub struct EvalReport {
    /// Frames evaluated.
    pub frames: usize,
    /// Centers per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Forward GFLOP per frame at this budget.
    pub gflop_per_frame: f64,
    /// Mean wall time per frame (preparation, forward, decoding), ms.
    pub latency_ms_mean: f64,
    /// 95th percentile of the per-frame time, ms.
    pub latency_ms_p95: f64,
    /// KITTI AP per class.
    pub classes: Vec<ClassAp>,
}

impl EvalReport {
    /// The headline: 3D AP (R40) at moderate difficulty of the first class.
    pub fn headline(&self) -> f64 {
        self.classes.first().map_or(0.0, |c| c.three_d[1].r40)
    }
}

impl std::fmt::Display for EvalReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} frames, {} centers x {} points ({:.2} GFLOP/frame), latency {:.1} ms mean, {:.1} ms p95",
            self.frames,
            self.num_centers,
            self.num_points,
            self.gflop_per_frame,
            self.latency_ms_mean,
            self.latency_ms_p95
        )?;
        writeln!(
            f,
            "| class | IoU | metric | easy R40 | moderate R40 | hard R40 | easy R11 | moderate R11 | hard R11 |"
        )?;
        writeln!(f, "|---|---|---|---|---|---|---|---|---|")?;
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

/// Evaluates `model` (in validation mode, on a plain device) on `dataset` at a center and point
/// budget; writes `{id}.txt` result files to `results` when given.
pub fn evaluate(
    model: &StarNet,
    cfg: &ExperimentConfig,
    dataset: &KittiDataset,
    num_centers: usize,
    num_points: usize,
    results: Option<&Path>,
) -> Result<EvalReport> {
    let device = starnet_model::backend::default_device();
    let pipeline = PipelineConfig {
        num_centers,
        gather: GatherConfig {
            num_points,
            radius: cfg.pipeline.gather.radius,
        },
        ..cfg.pipeline.clone()
    };
    let nms = cfg.nms_config();
    let anchors = &cfg.model.anchors;
    let mut frames = Vec::new();
    let mut times = Vec::new();
    for (chunk_i, ids) in dataset.ids().chunks(cfg.eval.batch_size).enumerate() {
        let start = Instant::now();
        let loaded: Vec<_> = ids
            .iter()
            .map(|id| dataset.load(id))
            .collect::<std::result::Result<_, _>>()?;
        let prepared: Vec<_> = loaded
            .iter()
            .enumerate()
            .map(|(k, f)| {
                prepare_frame(
                    f,
                    &pipeline,
                    None,
                    &[],
                    &mut ChaCha8Rng::seed_from_u64(sub_seed(cfg.seed, 21, (chunk_i * cfg.eval.batch_size + k) as u64)),
                )
            })
            .collect();
        let out = model.forward(make_input(&prepared.iter().collect::<Vec<_>>(), &device));
        for (k, (frame, p)) in loaded.into_iter().zip(&prepared).enumerate() {
            let dets: Vec<KittiObject> = decode_frame(&out, k, p, anchors, &nms)
                .iter()
                .filter_map(|d| to_kitti(d, &cfg.data.classes, &frame.calib, frame.image_size))
                .collect();
            if let Some(dir) = results {
                write_results(&dir.join(format!("{}.txt", frame.id)), &dets)?;
            }
            frames.push((frame.objects, dets));
        }
        let per_frame = start.elapsed().as_secs_f64() * 1e3 / ids.len() as f64;
        times.extend(std::iter::repeat_n(per_frame, ids.len()));
    }
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    let p95 = sorted
        .get(((sorted.len() as f64 * 0.95) as usize).min(sorted.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    Ok(EvalReport {
        frames: frames.len(),
        num_centers,
        num_points,
        gflop_per_frame: forward_gflop(&cfg.model_config(), num_centers, num_points),
        latency_ms_mean: times.iter().sum::<f64>() / times.len().max(1) as f64,
        latency_ms_p95: p95,
        classes: kitti_ap(&frames, &cfg.data.classes),
    })
}
