//! Evaluating a model streamed over a split at one slice count: Waymo-style AP/APH and AP per
//! subtended angle for each NMS mode, peak compute and latency ([`StreamReport`]).

use super::ground_truth::StreamGroundTruth;
use crate::Result;
use crate::stream::{NmsMode, StreamModel, stream_sweep};
use serde::{Deserialize, Serialize};
use starnet_data::events::Task;
use starnet_data::kitti::{KittiDataset, LabelSource};
use starnet_data::sampling::{CenterTarget, CenterViews};
use starnet_data::seed::sub_seed;
use starnet_data::summary::{mean, quantile};
use starnet_eval::metrics::{AngleAp, WaymoClassAp, WaymoDetection, WaymoFrame, ap_by_angle, waymo_ap};
use starnet_eval::{EvalReport, Scores, to_kitti};
use starnet_model::flops::forward_gflop;

/// The results of one NMS mode.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ModeReport {
    /// The mode.
    pub mode: NmsMode,
    /// Waymo-style AP/APH per class.
    pub waymo: Vec<WaymoClassAp>,
    /// LEVEL_1 AP of the first class per subtended angle.
    pub by_angle: Vec<AngleAp>,
}

/// A model streamed over a split at one slice count.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StreamReport {
    /// Slices per sweep n.
    pub slices: usize,
    /// Sweeps evaluated.
    pub frames: usize,
    /// Whether the model has the LSTM.
    pub lstm: bool,
    /// Centers per sweep (spread over the slices).
    pub num_centers: usize,
    /// Centers per slice: a step's capacity (its peak compute).
    pub centers_per_slice: usize,
    /// Mean steps per sweep: n, and more where a spaced last slice needs further steps (absent
    /// from reports written before it existed).
    #[serde(default)]
    pub steps_per_sweep: f64,
    /// Points per center.
    pub num_points: usize,
    /// Which centers saw their neighbourhood in the mirror (absent from older reports: `as_seen`).
    #[serde(default)]
    pub views: CenterViews,
    /// Forward GFLOP of one slice: the peak compute.
    pub gflop_per_slice: f64,
    /// Peak compute as a fraction of the whole sweep's in one forward.
    pub peak_fraction: f64,
    /// Median per-slice latency, ms (see [`crate::stream::StreamedSweep::slice_ms`]).
    pub slice_ms_median: f64,
    /// Mean per-slice latency, ms.
    pub slice_ms_mean: f64,
    /// 95th percentile of the per-slice latency, ms.
    pub slice_ms_p95: f64,
    /// Mean total over a sweep's slices, ms.
    pub sweep_ms_mean: f64,
    /// 95th percentile of that total, ms (absent from reports written before it existed).
    #[serde(default)]
    pub sweep_ms_p95: f64,
    /// Per NMS mode.
    pub modes: ModeReports,
}

/// The results of each NMS mode (in JSON, a list in [`NmsMode::ALL`] order).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "Vec<ModeReport>", into = "Vec<ModeReport>")]
pub struct ModeReports {
    /// Per-slice NMS.
    pub localized: ModeReport,
    /// Stateful NMS.
    pub stateful: ModeReport,
    /// Global NMS.
    pub global: ModeReport,
}

impl ModeReports {
    /// The results of `mode`.
    pub fn get(&self, mode: NmsMode) -> &ModeReport {
        match mode {
            NmsMode::Localized => &self.localized,
            NmsMode::Stateful => &self.stateful,
            NmsMode::Global => &self.global,
        }
    }

    /// Every mode's results, in [`NmsMode::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = &ModeReport> {
        NmsMode::ALL.into_iter().map(|m| self.get(m))
    }
}

impl TryFrom<Vec<ModeReport>> for ModeReports {
    type Error = String;

    fn try_from(list: Vec<ModeReport>) -> std::result::Result<Self, String> {
        let take = |mode: NmsMode| {
            list.iter()
                .find(|m| m.mode == mode)
                .cloned()
                .ok_or_else(|| format!("no `{}` results in `modes`", mode.name()))
        };
        Ok(Self {
            localized: take(NmsMode::Localized)?,
            stateful: take(NmsMode::Stateful)?,
            global: take(NmsMode::Global)?,
        })
    }
}

impl From<ModeReports> for Vec<ModeReport> {
    fn from(m: ModeReports) -> Self {
        vec![m.localized, m.stateful, m.global]
    }
}

impl StreamReport {
    /// The results of `mode`.
    pub fn mode(&self, mode: NmsMode) -> &ModeReport {
        self.modes.get(mode)
    }

    /// LEVEL_1 AP of class `k` in `mode`.
    pub fn ap(&self, mode: NmsMode, k: usize) -> f64 {
        self.mode(mode).waymo.get(k).map_or(0.0, |w| w.levels[0].ap)
    }

    /// `mode` as an [`EvalReport`] (per sweep: compute and latency summed over the slices), for
    /// the trainer's evaluations.
    pub fn eval_report(&self, mode: NmsMode) -> EvalReport {
        EvalReport {
            num_centers: self.num_centers,
            num_points: self.num_points,
            target: CenterTarget::All,
            views: self.views,
            gflop_per_frame: self.gflop_per_slice * self.slices as f64,
            latency_ms_mean: self.sweep_ms_mean,
            latency_ms_p95: self.sweep_ms_p95,
            scores: Scores {
                frames: self.frames,
                classes: Vec::new(),
                waymo: self.mode(mode).waymo.clone(),
                by_range: Vec::new(),
            },
        }
    }
}

impl std::fmt::Display for StreamReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "n = {} ({} sweeps, {:.2} steps each, {} x {} points per step, {:.3} GFLOP = {:.3} of a sweep; step {:.1} ms median, sweep {:.1} ms):",
            self.slices,
            self.frames,
            self.steps_per_sweep,
            self.centers_per_slice,
            self.num_points,
            self.gflop_per_slice,
            self.peak_fraction,
            self.slice_ms_median,
            self.sweep_ms_mean
        )?;
        for m in self.modes.iter() {
            write!(f, " {}", m.mode.name())?;
            for w in &m.waymo {
                write!(f, " {} {:.2}", w.class, w.levels[0].ap)?;
            }
            write!(f, ";")?;
        }
        Ok(())
    }
}

/// Streams every sweep of `gt` through `m` at `n` slices and scores each NMS mode
/// (Waymo-style; with camera-view labels only detections inside image 2 count). Sweep `i`
/// samples from `sub_seed(m.seed, 23, i)`.
pub fn evaluate_stream(
    m: &StreamModel,
    dataset: &KittiDataset,
    gt: &StreamGroundTruth,
    n: usize,
) -> Result<StreamReport> {
    let classes = &m.detector.classes;
    let camera_view = dataset.labels() == LabelSource::Camera;
    let mut frames: [Vec<WaymoFrame>; 3] = Default::default();
    let mut slice_ms = Vec::new();
    let mut sweep_ms = Vec::new();
    let mut steps = Vec::new();
    let task = Task::begin(&format!("stream {n} slices"), gt.frames.len() as u64);
    for (i, (id, objects)) in gt.frames.iter().enumerate() {
        task.inc(1);
        let frame = dataset.load(id)?;
        let streamed = stream_sweep(m, &frame.points, n, sub_seed(m.seed, 23, i as u64));
        sweep_ms.push(streamed.slice_ms.iter().sum::<f64>());
        steps.push(streamed.slice_ms.len() as f64);
        slice_ms.extend_from_slice(&streamed.slice_ms);
        for (k, mode) in NmsMode::ALL.iter().enumerate() {
            let detections = streamed
                .detections(*mode)
                .iter()
                .filter(|d| d.b.x.hypot(d.b.y) <= m.stream.eval_range)
                .filter(|d| !camera_view || to_kitti(d, &frame.calib, frame.image_size).is_some())
                .map(|d| WaymoDetection {
                    class: d.class,
                    b: d.b,
                    score: d.score,
                })
                .collect();
            frames[k].push(WaymoFrame {
                objects: objects.clone(),
                detections,
            });
        }
    }
    drop(task);
    let budget = m.detector.budget();
    let per = m.stream.slicing.step_capacity(budget.num_centers, n);
    let gflop = forward_gflop(&m.detector.network, per, budget.num_points);
    let full = forward_gflop(&m.detector.network, budget.num_centers, budget.num_points);
    Ok(StreamReport {
        slices: n,
        frames: gt.frames.len(),
        lstm: m.detector.model.has_lstm(),
        num_centers: budget.num_centers,
        centers_per_slice: per,
        steps_per_sweep: mean(&steps),
        num_points: budget.num_points,
        views: m.detector.views,
        gflop_per_slice: gflop,
        peak_fraction: gflop / full,
        slice_ms_median: quantile(&slice_ms, 0.5).unwrap_or(0.0),
        slice_ms_mean: mean(&slice_ms),
        slice_ms_p95: quantile(&slice_ms, 0.95).unwrap_or(0.0),
        sweep_ms_mean: mean(&sweep_ms),
        sweep_ms_p95: quantile(&sweep_ms, 0.95).unwrap_or(0.0),
        modes: {
            let [localized, stateful, global] = frames.map(|f| (waymo_ap(&f, classes), ap_by_angle(&f, classes[0])));
            let report = |mode, (waymo, by_angle)| ModeReport { mode, waymo, by_angle };
            ModeReports {
                localized: report(NmsMode::Localized, localized),
                stateful: report(NmsMode::Stateful, stateful),
                global: report(NmsMode::Global, global),
            }
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_reports_are_a_list_in_json_and_need_every_mode() {
        let report = |mode| ModeReport {
            mode,
            waymo: Vec::new(),
            by_angle: Vec::new(),
        };
        let modes = ModeReports {
            localized: report(NmsMode::Localized),
            stateful: report(NmsMode::Stateful),
            global: report(NmsMode::Global),
        };
        let json = serde_json::to_value(&modes).unwrap();
        let names: Vec<_> = json.as_array().unwrap().iter().map(|m| m["mode"].clone()).collect();
        assert_eq!(names, ["localized", "stateful", "global"]);
        let back: ModeReports = serde_json::from_value(json.clone()).unwrap();
        assert!(NmsMode::ALL.iter().all(|&m| back.get(m).mode == m));
        let mut missing = json;
        missing.as_array_mut().unwrap().remove(1);
        let err = serde_json::from_value::<ModeReports>(missing).unwrap_err().to_string();
        assert!(err.contains("stateful"), "{err}");
    }
}
