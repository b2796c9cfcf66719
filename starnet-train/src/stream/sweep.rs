//! One sweep streamed through a model slice by slice, as the sensor delivers it: each slice's
//! boxes after per-slice, stateful and (once the sweep is complete) global NMS, and its latency.

use super::model::StreamModel;
use serde::{Deserialize, Serialize};
use starnet_data::sampling::{AnchorGrid, SliceConfig, SliceContext, SweepSlicer, slice_rng};
use starnet_data::{Box3d, Point};
use starnet_model::nms::{DeferredNms, Detection, Emission, StatefulNms, nms};
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
    /// Per step (the n slices, then any further steps of a spaced last slice), its boxes after
    /// NMS within the step (what it emits before stateful NMS).
    pub per_slice: Vec<Vec<Detection>>,
    /// Per step, ms from its delivered points to its final boxes: center sampling, gathering,
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
/// them: each slice is prepared by a [`SweepSlicer`] from what has been delivered (as
/// `stream.slicing.context` allows), run through the model with the LSTM state of the
/// sweep's earlier slices (fresh at the sweep's start), decoded and passed through stateful
/// NMS; the detector's centers are spread over the slices. Slice `s` draws from
/// [`slice_rng`]`(seed, s)`, so nothing of a later slice reaches it.
pub fn stream_sweep(m: &StreamModel, points: &[Point], n: usize, seed: u64) -> StreamedSweep {
    let (detector, stream) = (&m.detector, &m.stream);
    // What the sensor delivers; cutting is the sensor's work, not the detector's, so untimed.
    let mut slicer = SweepSlicer::new(points, n, &stream.slicing, &detector.pipeline);
    let mut stateful = StatefulNms::new(stream.nms_memory, stream.nms_precedence);
    let mut deferred = DeferredNms::new();
    let lag = settling_lag(&detector.anchors, detector.pipeline.gather.radius, &stream.slicing);
    let mut state = None;
    let mut out = StreamedSweep {
        localized: Vec::new(),
        stateful: Vec::new(),
        global: Vec::new(),
        per_slice: Vec::with_capacity(n),
        slice_ms: Vec::with_capacity(n),
    };
    let mut raw_all = Vec::new();
    for s in 0.. {
        let start = Instant::now();
        let Some(prepared) = slicer.next_slice("", (&[], &[]), detector.pipeline.num_centers, &mut slice_rng(seed, s))
        else {
            break;
        };
        // A step after the n slices belongs to the last (the sweep is complete); while further
        // steps follow, nothing of the last slice is settled, for their centers lie anywhere in it.
        let (s, last, more) = (s.min(n - 1), slicer.is_finished(), s + 1 >= n);
        let slice = detector.detect_slice(&prepared, state);
        state = slice.state;
        let settled = |d: &Detection| !more && reaches_no_later_slice(&d.b, s, n, &stream.slicing, lag);
        out.stateful.extend(match stream.nms_emission {
            Emission::Deferred if last => deferred.finish(&slice.raw, &detector.nms),
            Emission::Deferred => deferred.step(&slice.raw, &detector.nms, &settled),
            _ if last => stateful.step_last(&slice.raw, &detector.nms),
            Emission::Immediate => stateful.step(&slice.raw, &detector.nms),
            Emission::Settled => stateful.step_holding(&slice.raw, &detector.nms, &settled),
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

/// How far from what is still to come a box (grown by half its length) must lie before no
/// later box can overlap it: for centers that lag the laser ([`SliceConfig::lag`]), that lag
/// plus the farthest anchor offset (where a center's boxes start), diagonally; else nothing.
fn settling_lag(anchors: &AnchorGrid, radius: f32, slicing: &SliceConfig) -> f32 {
    match slicing.context {
        SliceContext::Arrived => slicing.lag(radius) + anchors.extent * std::f32::consts::SQRT_2,
        SliceContext::Own | SliceContext::Previous => 0.0,
    }
}

/// Whether no box of a step after slice `s` (of `n`) can overlap `b`: its footprint grown by
/// half its length (how far a later box reaches back across the border) lies in slices up to
/// `s`, and at least `lag` (how far centers wait behind the laser) from what is still to come.
/// Past the sweep's start (slice 0 seen from the last slices) counts as to come.
fn reaches_no_later_slice(b: &Box3d, s: usize, n: usize, slicing: &SliceConfig, lag: f32) -> bool {
    b.grown(b.dx.max(b.dy) / 2.0).corners_bev().iter().all(|c| {
        let d = slicing.distance_to_undelivered(c[0], c[1], s, n);
        d > 0.0 && d >= lag
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::Budget;
    use crate::config::ExperimentConfig;
    use starnet_data::sampling::{CenterPoolConfig, CenterTarget, SliceCenters};

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
    fn a_box_is_settled_when_no_later_slice_reaches_it() {
        // Four slices, counter-clockwise from azimuth 0: slice 0 is the first quadrant.
        let slicing = SliceConfig {
            start_azimuth_deg: 0.0,
            clockwise: false,
            ..SliceConfig::default()
        };
        let car = |x: f32, y: f32| Box3d::new(x, y, -1.0, 4.0, 1.6, 1.5, 0.0);
        // At 45° and 20 m, grown by 2 m: inside slice 0.
        assert!(reaches_no_later_slice(&car(14.0, 14.0), 0, 4, &slicing, 0.0));
        // Centers that wait behind the laser: the grown footprint (x 10–18, y 11.2–16.8) lies
        // 10 m from the nearest ray of what is to come (the +y axis).
        assert!(reaches_no_later_slice(&car(14.0, 14.0), 0, 4, &slicing, 9.9));
        assert!(!reaches_no_later_slice(&car(14.0, 14.0), 0, 4, &slicing, 10.1));
        // Near the border with slice 1 (the +y axis): it waits, until slice 1 is done.
        assert!(!reaches_no_later_slice(&car(2.0, 20.0), 0, 4, &slicing, 0.0));
        assert!(reaches_no_later_slice(&car(2.0, 20.0), 1, 4, &slicing, 0.0));
        // Just past the sweep's start (slice 0 near the +x axis, reaching back below it): the
        // last slice lies behind the start, so it is not settled before then.
        assert!(!reaches_no_later_slice(&car(20.0, 1.0), 0, 4, &slicing, 0.0));
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
        for context in [SliceContext::Own, SliceContext::Previous, SliceContext::Arrived] {
            let mut cfg = cfg.clone();
            cfg.stream.slicing = SliceConfig {
                context,
                centers: SliceCenters::Continued,
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
