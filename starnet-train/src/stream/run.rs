//! Streaming a sweep through a model slice by slice, and evaluating it over a split.

use crate::Result;
use crate::budget::Budget;
use crate::config::{ExperimentConfig, StreamSection};
use crate::detector::Detector;
use serde::{Deserialize, Serialize};
use starnet_data::events::Task;
use starnet_data::kitti::{KittiDataset, LabelSource};
use starnet_data::sampling::{CenterTarget, SliceConfig, centers_per_slice, prepare_slice, slice_points, slice_rng};
use starnet_data::sim::sub_seed;
use starnet_data::summary::{mean, quantile};
use starnet_data::{Box3d, Point};
use starnet_eval::EvalReport;
use starnet_eval::metrics::{AngleAp, WaymoClassAp, WaymoDetection, WaymoFrame, WaymoObject, ap_by_angle, waymo_ap};
use starnet_eval::{Scores, to_kitti, waymo_objects};
use starnet_model::flops::forward_gflop;
use starnet_model::nms::{Detection, Emission, StatefulNms, nms};
use starnet_model::nn::StarNet;
use std::time::Instant;

/// How the detections of a sweep's slices are merged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NmsMode {
    /// NMS within each slice only (the paper's "localized receptive field").
    Localized,
    /// Each slice's boxes also suppressed by the boxes kept in the previous k slices.
    Stateful,
    /// NMS over every slice's boxes once the sweep is complete (not streaming: the reference).
    Global,
}

impl NmsMode {
    /// Every mode, in the paper's order.
    pub const ALL: [NmsMode; 3] = [NmsMode::Localized, NmsMode::Stateful, NmsMode::Global];

    /// A short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            Self::Localized => "localized",
            Self::Stateful => "stateful NMS",
            Self::Global => "global NMS",
        }
    }
}

/// One sweep streamed through a model.
#[derive(Debug, Clone)]
pub struct StreamedSweep {
    /// Per-slice NMS, the slices' boxes together.
    pub localized: Vec<Detection>,
    /// Stateful NMS, as emitted slice by slice.
    pub stateful: Vec<Detection>,
    /// Global NMS over the sweep.
    pub global: Vec<Detection>,
    /// Per slice, its boxes after NMS within the slice (what it emits before stateful NMS).
    pub per_slice: Vec<Vec<Detection>>,
    /// Per slice, ms from its delivered points to its final boxes: center sampling, gathering,
    /// forward, decoding and stateful NMS.
    pub slice_ms: Vec<f64>,
}

impl StreamedSweep {
    /// The detections of `mode`.
    pub fn detections(&self, mode: NmsMode) -> &[Detection] {
        match mode {
            NmsMode::Localized => &self.localized,
            NmsMode::Stateful => &self.stateful,
            NmsMode::Global => &self.global,
        }
    }
}

/// Detects on one sweep cut into `n` slices, one slice at a time as the sensor would deliver
/// them: each slice is prepared from its own points (and the previous slice's when
/// `stream.slicing.gather_previous`), run through the model with the LSTM state of the
/// sweep's earlier slices (fresh at the sweep's start), decoded and passed through stateful
/// NMS; the detector's centers are spread over the slices. Slice `s` draws from
/// [`slice_rng`]`(seed, s)`, so nothing of a later slice reaches it.
pub fn stream_sweep(m: &StreamModel, points: &[Point], n: usize, seed: u64) -> StreamedSweep {
    let (detector, stream) = (&m.detector, &m.stream);
    let per = centers_per_slice(detector.pipeline.num_centers, n);
    // What the sensor delivers; cutting is the sensor's work, not the detector's, so untimed.
    let slices = slice_points(points, n, &stream.slicing);
    let mut stateful = StatefulNms::new(stream.nms_memory, stream.nms_precedence);
    let mut state = None;
    let mut out = StreamedSweep {
        localized: Vec::new(),
        stateful: Vec::new(),
        global: Vec::new(),
        per_slice: Vec::with_capacity(n),
        slice_ms: Vec::with_capacity(n),
    };
    let mut raw_all = Vec::new();
    for s in 0..n {
        let start = Instant::now();
        let previous = (stream.slicing.gather_previous && s > 0).then(|| slices[s - 1].as_slice());
        let prepared = prepare_slice(
            "",
            &slices[s],
            previous,
            (&[], &[]),
            &detector.pipeline,
            per,
            &mut slice_rng(seed, s),
        );
        let slice = detector.detect_slice(&prepared, state);
        state = slice.state;
        out.stateful.extend(match stream.nms_emission {
            _ if s + 1 == n => stateful.step_last(&slice.raw, &detector.nms),
            Emission::Immediate => stateful.step(&slice.raw, &detector.nms),
            Emission::Settled => {
                let settled = |d: &Detection| reaches_no_later_slice(&d.b, s, n, &stream.slicing);
                stateful.step_holding(&slice.raw, &detector.nms, &settled)
            }
        });
        out.slice_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let local = nms(&slice.raw, &detector.nms);
        out.localized.extend_from_slice(&local);
        out.per_slice.push(local);
        raw_all.extend(slice.raw);
    }
    out.global = nms(&raw_all, &detector.nms);
    out
}

/// Whether no box of a slice after `s` (of `n`) can overlap `b`: its footprint grown by half
/// its length (how far a later slice's box reaches back across the border) lies in slices up to
/// `s`. Past the sweep's start (slice 0 seen from the last slices) counts as later.
fn reaches_no_later_slice(b: &Box3d, s: usize, n: usize, slicing: &SliceConfig) -> bool {
    b.grown(b.dx.max(b.dy) / 2.0)
        .corners_bev()
        .iter()
        .all(|c| slicing.slice_of(c[0], c[1], n) <= s)
}

/// The ground truth of a streaming evaluation: per frame id, its labelled objects (with their
/// LiDAR point counts) within `stream.eval_range`. Computed once, shared by every model and n.
#[derive(Debug, Clone)]
pub struct StreamGroundTruth {
    /// `(frame id, objects)` in split order.
    pub frames: Vec<(String, Vec<WaymoObject>)>,
}

impl StreamGroundTruth {
    /// Reads the first `max_frames` frames of `dataset` (all when `None`), keeping the objects
    /// within `eval_range` metres of the sensor.
    pub fn read(eval_range: f32, dataset: &KittiDataset, max_frames: Option<usize>) -> Result<Self> {
        let ids = &dataset.ids()[..max_frames.map_or(dataset.ids().len(), |m| m.min(dataset.ids().len()))];
        let frames = ids
            .iter()
            .map(|id| {
                let frame = dataset.load(id)?;
                let objects = waymo_objects(&frame)
                    .into_iter()
                    .filter(|o| o.b.x.hypot(o.b.y) <= eval_range)
                    .collect();
                Ok((id.clone(), objects))
            })
            .collect::<Result<_>>()?;
        Ok(Self { frames })
    }
}

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
    /// Centers per slice.
    pub centers_per_slice: usize,
    /// Points per center.
    pub num_points: usize,
    /// Forward GFLOP of one slice: the peak compute.
    pub gflop_per_slice: f64,
    /// Peak compute as a fraction of the whole sweep's in one forward.
    pub peak_fraction: f64,
    /// Median per-slice latency, ms (see [`StreamedSweep::slice_ms`]).
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
            "n = {} ({} sweeps, {} x {} points per slice, {:.3} GFLOP = {:.3} of a sweep; slice {:.1} ms median, sweep {:.1} ms):",
            self.slices,
            self.frames,
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
    let task = Task::begin(&format!("stream {n} slices"), gt.frames.len() as u64);
    for (i, (id, objects)) in gt.frames.iter().enumerate() {
        task.inc(1);
        let frame = dataset.load(id)?;
        let streamed = stream_sweep(m, &frame.points, n, sub_seed(m.seed, 23, i as u64));
        sweep_ms.push(streamed.slice_ms.iter().sum::<f64>());
        slice_ms.extend_from_slice(&streamed.slice_ms);
        for (k, mode) in NmsMode::ALL.iter().enumerate() {
            let detections = streamed
                .detections(*mode)
                .iter()
                .filter(|d| d.b.x.hypot(d.b.y) <= m.stream.eval_range)
                .filter(|d| !camera_view || to_kitti(d, classes, &frame.calib, frame.image_size).is_some())
                .map(|d| WaymoDetection {
                    class: classes[d.class],
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
    let per = centers_per_slice(budget.num_centers, n);
    let gflop = forward_gflop(&m.detector.network, per, budget.num_points);
    let full = forward_gflop(&m.detector.network, budget.num_centers, budget.num_points);
    Ok(StreamReport {
        slices: n,
        frames: gt.frames.len(),
        lstm: m.detector.model.has_lstm(),
        num_centers: budget.num_centers,
        centers_per_slice: per,
        num_points: budget.num_points,
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

/// A model to stream: a name, its detector at the per-sweep budget, and its run's streaming
/// settings and seed.
#[derive(Debug, Clone)]
pub struct StreamModel {
    /// Its name in tables (e.g. the run folder).
    pub label: String,
    /// The model with its anchors, classes, NMS and per-sweep budget.
    pub detector: Detector,
    /// Slicing, stateful NMS, evaluation range and scan rate.
    pub stream: StreamSection,
    /// The experiment seed.
    pub seed: u64,
}

impl StreamModel {
    /// `model`, trained with `cfg`, at `budget` per sweep.
    pub fn new(label: String, model: StarNet, cfg: &ExperimentConfig, budget: Budget) -> Self {
        Self {
            label,
            detector: Detector::new(model, cfg).at_budget(budget),
            stream: cfg.stream.clone(),
            seed: cfg.seed,
        }
    }
}

/// Streams every model over `gt`'s sweeps at each of `slices` (n = 1, the whole-sweep
/// reference, is added first when absent), calling `on_report` after each.
pub fn stream_runs(
    models: &[StreamModel],
    dataset: &KittiDataset,
    gt: &StreamGroundTruth,
    slices: &[usize],
    on_report: &mut dyn FnMut(&str, &StreamReport),
) -> Result<Vec<super::StreamRun>> {
    let mut ns: Vec<usize> = slices.to_vec();
    ns.push(1);
    ns.sort_unstable();
    ns.dedup();
    models
        .iter()
        .map(|m| {
            let reports = ns
                .iter()
                .map(|&n| {
                    let r = evaluate_stream(m, dataset, gt, n)?;
                    on_report(&m.label, &r);
                    Ok(r)
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(super::StreamRun {
                label: m.label.clone(),
                classes: m.detector.classes.clone(),
                scan_hz: m.stream.scan_hz,
                reports,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::sampling::{CenterPoolConfig, SliceConfig};

    fn sweep(n: usize) -> Vec<Point> {
        (0..n)
            .map(|i| {
                let a = i as f32 * 2.399; // golden-angle spiral: every azimuth, ranges 3–40 m
                let r = 3.0 + 37.0 * ((i * 7919) % n) as f32 / n as f32;
                [r * a.cos(), r * a.sin(), -1.0 + (i % 5) as f32 * 0.3, 0.2]
            })
            .collect()
    }

    fn config() -> ExperimentConfig {
        let mut cfg = ExperimentConfig::default();
        cfg.model.blocks = vec![[16, 8]];
        cfg.model.d_fc0 = 8;
        cfg.model.d_offset = 8;
        cfg.model.lstm_hidden = 8;
        cfg.pipeline.pool = CenterPoolConfig::all_around(50.0);
        cfg.pipeline.gather.num_points = 8;
        // Keep every box so the comparison is not vacuous.
        cfg.nms.score = vec![0.0];
        cfg
    }

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

    #[test]
    fn a_box_is_settled_when_no_later_slice_reaches_it() {
        // Four slices, counter-clockwise from azimuth 0: slice 0 is the first quadrant.
        let slicing = SliceConfig {
            start_azimuth_deg: 0.0,
            clockwise: false,
            ..SliceConfig::default()
        };
        let car = |x: f32, y: f32| Box3d::new(x, y, -1.0, 4.0, 1.6, 1.5, 0.0);
        // At 45° and 20 m, grown by 2 m: inside slice 0.
        assert!(reaches_no_later_slice(&car(14.0, 14.0), 0, 4, &slicing));
        // Near the border with slice 1 (the +y axis): it waits, until slice 1 is done.
        assert!(!reaches_no_later_slice(&car(2.0, 20.0), 0, 4, &slicing));
        assert!(reaches_no_later_slice(&car(2.0, 20.0), 1, 4, &slicing));
        // Just past the sweep's start (slice 0 near the +x axis, reaching back below it): the
        // last slice lies behind the start, so it is not settled before then.
        assert!(!reaches_no_later_slice(&car(20.0, 1.0), 0, 4, &slicing));
    }

    #[test]
    fn no_slice_reads_a_later_slice() {
        let cfg = config();
        let model = cfg.model_config().init(&starnet_model::backend::default_device());
        let budget = Budget {
            num_centers: 24,
            num_points: 8,
            target: CenterTarget::All,
        };
        for gather_previous in [false, true] {
            let mut cfg = cfg.clone();
            cfg.stream.slicing = SliceConfig {
                gather_previous,
                ..SliceConfig::default()
            };
            let m = StreamModel::new("m".into(), model.clone(), &cfg, budget);
            let points = sweep(3000);
            let base = stream_sweep(&m, &points, 6, 5);
            assert!(base.per_slice.iter().all(|d| !d.is_empty()));
            // Change every point of slices 3–5 (and drop some): slices 0–2 must not notice,
            // LSTM state included.
            let later = |p: &Point| cfg.stream.slicing.slice_of(p[0], p[1], 6) >= 3;
            let changed: Vec<Point> = points
                .iter()
                .enumerate()
                .filter(|(i, p)| !later(p) || i % 3 != 0)
                .map(|(_, p)| {
                    if later(p) {
                        [p[0] * 1.1, p[1], p[2] + 0.5, 0.9]
                    } else {
                        *p
                    }
                })
                .collect();
            let other = stream_sweep(&m, &changed, 6, 5);
            assert_eq!(&other.per_slice[..3], &base.per_slice[..3]);
            assert_ne!(&other.per_slice[3..], &base.per_slice[3..]);
            // A sweep starts from a fresh state: streaming it again gives the same boxes.
            assert_eq!(stream_sweep(&m, &points, 6, 5).per_slice, base.per_slice);
        }
    }
}
