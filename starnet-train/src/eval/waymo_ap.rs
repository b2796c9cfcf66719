//! Waymo-style 3D detection metrics: AP and APH (heading-weighted AP) at LEVEL_1 and LEVEL_2,
//! overall and per range (0–30, 30–50, 50+ m), computed as the Waymo Open Dataset's metrics
//! library does on LiDAR boxes.
//!
//! - Difficulty from the LiDAR returns inside a box: more than 5 is LEVEL_1, 1–5 is LEVEL_2
//!   (the Waymo rule: "≤ 5 points" is LEVEL_2), none is not evaluated. At LEVEL_1 the LEVEL_2
//!   objects are ignored; at LEVEL_2 every object with a point counts.
//! - Ignored ground truth (that level, no points, or the neighbour class: Van for Car,
//!   Person_sitting for Pedestrian) takes part in the matching, but a prediction matched to it
//!   is neither a true nor a false positive.
//! - Matching per frame and class is the Hungarian maximum-IoU assignment over pairs with 3D IoU
//!   ≥ the class threshold (Car 0.7, Pedestrian and Cyclist 0.5), redone at each of the 101
//!   score cutoffs 0, 0.01, …, 1 (the configuration OpenPCDet passes to the official tool).
//! - A true positive's heading accuracy is `1 − |Δθ| / π` (Δθ wrapped to [−π, π]); APH uses it
//!   in place of 1 for the true positives.
//! - AP is the area under the precision envelope (the best precision at that recall or higher)
//!   over the recall steps of the cutoffs, from recall 0.
//! - Range shards filter ground truth and predictions by their own bird's-eye-view distance
//!   from the sensor.

use super::hungarian::max_weight_matching;
use super::kitti_ap::official_min_overlap;
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::{iou_3d, wrap_angle};
use starnet_data::kitti::ObjectClass;

/// A ground-truth object.
#[derive(Debug, Clone, PartialEq)]
pub struct WaymoObject {
    /// Class.
    pub class: ObjectClass,
    /// Box, LiDAR frame.
    pub b: Box3d,
    /// LiDAR returns inside the box.
    pub num_points: u32,
}

/// A prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct WaymoDetection {
    /// Class.
    pub class: ObjectClass,
    /// Box, LiDAR frame.
    pub b: Box3d,
    /// Confidence in [0, 1].
    pub score: f32,
}

/// Ground truth and predictions of one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WaymoFrame {
    /// Ground truth.
    pub objects: Vec<WaymoObject>,
    /// Predictions.
    pub detections: Vec<WaymoDetection>,
}

/// AP and APH, in percent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ApAph {
    /// Average precision.
    pub ap: f64,
    /// Heading-weighted average precision.
    pub aph: f64,
}

/// The range shards, metres: `[lo, hi)`.
pub const RANGE_SHARDS: [(f32, f32); 3] = [(0.0, 30.0), (30.0, 50.0), (50.0, f32::INFINITY)];

/// The results of one class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WaymoClassAp {
    /// The class.
    pub class: ObjectClass,
    /// 3D IoU threshold used.
    pub iou: f32,
    /// `[LEVEL_1, LEVEL_2]`, every range.
    pub levels: [ApAph; 2],
    /// `[LEVEL_1, LEVEL_2]` × [`RANGE_SHARDS`].
    pub ranges: [[ApAph; 3]; 2],
    /// Ground-truth objects counted at `[LEVEL_1, LEVEL_2]`.
    pub num_objects: [usize; 2],
    /// `[LEVEL_1, LEVEL_2]` recall and precision of every prediction (the lowest cutoff), in
    /// percent: how many objects some box finds, and how many boxes find one (absent from
    /// reports written before they existed).
    #[serde(default)]
    pub all_boxes: [RecallPrecision; 2],
}

/// Recall and precision at one cutoff, in percent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RecallPrecision {
    /// True positives over the counted objects.
    pub recall: f64,
    /// True positives over the predictions that are not matched to ignored objects.
    pub precision: f64,
}

/// The box's Waymo difficulty: 1, 2, or `None` without points.
pub fn waymo_level(num_points: u32) -> Option<usize> {
    match num_points {
        0 => None,
        1..=5 => Some(2),
        _ => Some(1),
    }
}

/// The class whose objects are ignored (not false negatives, not false positives) for `class`.
fn neighbour(class: ObjectClass) -> Option<ObjectClass> {
    match class {
        ObjectClass::Car => Some(ObjectClass::Van),
        ObjectClass::Pedestrian => Some(ObjectClass::PersonSitting),
        _ => None,
    }
}

fn bev_range(b: &Box3d) -> f32 {
    b.x.hypot(b.y)
}

/// Counts at one score cutoff.
#[derive(Debug, Clone, Copy, Default)]
struct Counts {
    tp: f64,
    tp_heading: f64,
    fp: f64,
    fn_: f64,
}

/// One frame of one class in one range shard, prepared for the cutoffs: predictions sorted by
/// score, the IoU matrix `[objects × predictions]` and each object's level (`None`: never
/// counted — the neighbour class or no points). The matching does not depend on the level, so
/// one case serves both.
struct FrameCase {
    scores: Vec<f32>,
    weights: Vec<f64>,
    heading_acc: Vec<f64>,
    levels: Vec<Option<usize>>,
}

impl FrameCase {
    /// Whether object `i` counts at `level` (1 or 2).
    fn counted(&self, i: usize, level: usize) -> bool {
        self.levels[i].is_some_and(|l| l <= level)
    }
}

fn frame_case(frame: &WaymoFrame, class: ObjectClass, shard: (f32, f32), iou: f32) -> FrameCase {
    let in_shard = |b: &Box3d| (shard.0..shard.1).contains(&bev_range(b));
    let gts: Vec<&WaymoObject> = frame
        .objects
        .iter()
        .filter(|o| (o.class == class || Some(o.class) == neighbour(class)) && in_shard(&o.b))
        .collect();
    let mut dets: Vec<&WaymoDetection> = frame
        .detections
        .iter()
        .filter(|d| d.class == class && in_shard(&d.b))
        .collect();
    dets.sort_by(|a, b| b.score.total_cmp(&a.score));
    let n = dets.len();
    let mut weights = vec![0.0; gts.len() * n];
    let mut heading_acc = vec![0.0; gts.len() * n];
    for (i, g) in gts.iter().enumerate() {
        for (j, d) in dets.iter().enumerate() {
            let v = iou_3d(&g.b, &d.b);
            if v >= iou {
                weights[i * n + j] = f64::from(v);
                heading_acc[i * n + j] =
                    1.0 - f64::from(wrap_angle(d.b.heading - g.b.heading).abs()) / std::f64::consts::PI;
            }
        }
    }
    FrameCase {
        scores: dets.iter().map(|d| d.score).collect(),
        weights,
        heading_acc,
        levels: gts
            .iter()
            .map(|o| (o.class == class).then(|| waymo_level(o.num_points)).flatten())
            .collect(),
    }
}

/// Matches the `k` highest-scoring predictions of a frame: the counts at `[LEVEL_1, LEVEL_2]`.
fn counts_at(case: &FrameCase, k: usize) -> [Counts; 2] {
    let (n, n_gt) = (case.scores.len(), case.levels.len());
    let sub: Vec<f64> = (0..n_gt)
        .flat_map(|i| case.weights[i * n..i * n + k].iter().copied())
        .collect();
    let pairs = max_weight_matching(&sub, n_gt, k);
    let mut gt_matched = vec![false; n_gt];
    for &(i, _) in &pairs {
        gt_matched[i] = true;
    }
    [1, 2].map(|level| {
        let mut c = Counts::default();
        for &(i, j) in pairs.iter().filter(|p| case.counted(p.0, level)) {
            c.tp += 1.0;
            c.tp_heading += case.heading_acc[i * n + j];
        }
        c.fp = (k - pairs.len()) as f64;
        c.fn_ = (0..n_gt).filter(|&i| case.counted(i, level) && !gt_matched[i]).count() as f64;
        c
    })
}

/// Area under the precision envelope of `(recall, precision)` points.
fn envelope_ap(mut pr: Vec<(f64, f64)>) -> f64 {
    pr.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
    let mut best = 0.0f64;
    let mut env: Vec<(f64, f64)> = pr
        .iter()
        .rev()
        .map(|&(r, p)| {
            best = best.max(p);
            (r, best)
        })
        .collect();
    env.reverse();
    let mut prev = 0.0;
    let mut ap = 0.0;
    for (r, p) in env {
        ap += (r - prev).max(0.0) * p;
        prev = prev.max(r);
    }
    ap
}

/// Per `[LEVEL_1, LEVEL_2]`: AP and APH, the objects counted, and every prediction's recall and
/// precision.
type LevelResults = ([ApAph; 2], [usize; 2], [RecallPrecision; 2]);

/// The [`LevelResults`] of one class and range shard.
fn ap_aph(frames: &[WaymoFrame], class: ObjectClass, shard: (f32, f32)) -> LevelResults {
    let iou = official_min_overlap(class);
    let cases: Vec<FrameCase> = frames.iter().map(|f| frame_case(f, class, shard, iou)).collect();
    // The matching depends on the cutoff only through how many predictions pass it: compute
    // each prefix once.
    let per_frame: Vec<Vec<[Counts; 2]>> = cases
        .iter()
        .map(|c| (0..=c.scores.len()).map(|k| counts_at(c, k)).collect())
        .collect();
    let level = |l: usize| {
        let num_objects = cases
            .iter()
            .map(|c| (0..c.levels.len()).filter(|&i| c.counted(i, l + 1)).count())
            .sum();
        let (mut pr, mut prh) = (Vec::new(), Vec::new());
        let mut all_boxes = RecallPrecision::default();
        for t in 0..=100 {
            let cutoff = t as f32 / 100.0;
            let mut total = Counts::default();
            for (case, counts) in cases.iter().zip(&per_frame) {
                let k = case.scores.iter().take_while(|&&s| s >= cutoff).count();
                let c = counts[k][l];
                total.tp += c.tp;
                total.tp_heading += c.tp_heading;
                total.fp += c.fp;
                total.fn_ += c.fn_;
            }
            if total.tp + total.fp > 0.0 && total.tp + total.fn_ > 0.0 {
                let (pos, gt) = (total.tp + total.fp, total.tp + total.fn_);
                if t == 0 {
                    all_boxes = RecallPrecision {
                        recall: 100.0 * total.tp / gt,
                        precision: 100.0 * total.tp / pos,
                    };
                }
                pr.push((total.tp / gt, total.tp / pos));
                prh.push((total.tp_heading / gt, total.tp_heading / pos));
            }
        }
        let result = ApAph {
            ap: envelope_ap(pr) * 100.0,
            aph: envelope_ap(prh) * 100.0,
        };
        (result, num_objects, all_boxes)
    };
    let ((l1, n1, b1), (l2, n2, b2)) = (level(0), level(1));
    ([l1, l2], [n1, n2], [b1, b2])
}

/// Waymo-style AP and APH for each of `classes`.
pub fn waymo_ap(frames: &[WaymoFrame], classes: &[ObjectClass]) -> Vec<WaymoClassAp> {
    classes
        .iter()
        .map(|&class| {
            let (levels, num_objects, all_boxes) = ap_aph(frames, class, (0.0, f32::INFINITY));
            let shards = RANGE_SHARDS.map(|s| ap_aph(frames, class, s).0);
            WaymoClassAp {
                class,
                iou: official_min_overlap(class),
                levels,
                ranges: [shards.map(|s| s[0]), shards.map(|s| s[1])],
                num_objects,
                all_boxes,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn car(x: f32, num_points: u32) -> WaymoObject {
        WaymoObject {
            class: ObjectClass::Car,
            b: Box3d::new(x, 2.0, -1.0, 4.0, 1.8, 1.5, 0.3),
            num_points,
        }
    }

    fn det(x: f32, score: f32, heading: f32) -> WaymoDetection {
        WaymoDetection {
            class: ObjectClass::Car,
            b: Box3d::new(x, 2.0, -1.0, 4.0, 1.8, 1.5, heading),
            score,
        }
    }

    fn first(frames: &[WaymoFrame]) -> WaymoClassAp {
        waymo_ap(frames, &[ObjectClass::Car]).remove(0)
    }

    #[test]
    fn levels_follow_the_point_counts() {
        assert_eq!(waymo_level(0), None);
        assert_eq!(waymo_level(1), Some(2));
        assert_eq!(waymo_level(5), Some(2));
        assert_eq!(waymo_level(6), Some(1));
    }

    #[test]
    fn perfect_detections_score_100_and_a_flipped_heading_costs_only_aph() {
        let frames = vec![WaymoFrame {
            objects: vec![car(10.0, 100), car(40.0, 50), car(70.0, 20)],
            detections: vec![det(10.0, 0.9, 0.3), det(40.0, 0.8, 0.3), det(70.0, 0.7, 0.3 + PI)],
        }];
        let r = first(&frames);
        assert!((r.levels[0].ap - 100.0).abs() < 1e-9);
        // Heading accuracies 1, 1, 0 → APH: precision and recall both 2/3 at the lowest cutoff;
        // at cutoffs above 0.7 the two correct ones give recall 2/3 with precision 1.
        assert!((r.levels[0].aph - 200.0 / 3.0).abs() < 1e-6, "{}", r.levels[0].aph);
        assert_eq!(r.num_objects, [3, 3]);
        for shard in r.ranges[0] {
            assert!((shard.ap - 100.0).abs() < 1e-9);
        }
    }

    #[test]
    fn level_2_objects_are_ignored_at_level_1() {
        // One LEVEL_2 car (3 points), detected; one LEVEL_1 car, missed.
        let frames = vec![WaymoFrame {
            objects: vec![car(10.0, 3), car(30.0, 40)],
            detections: vec![det(10.0, 0.9, 0.3)],
        }];
        let r = first(&frames);
        // LEVEL_1: the detection hits an ignored object, the counted one is missed: recall 0.
        assert_eq!(r.levels[0].ap, 0.0);
        // LEVEL_2: one of two found at precision 1.
        assert!((r.levels[1].ap - 50.0).abs() < 1e-9);
        assert_eq!(r.num_objects, [1, 2]);
        // The box on the ignored LEVEL_2 car is no false positive at LEVEL_1: no precision
        // point there at all, and 1 of 2 at precision 1 at LEVEL_2.
        assert_eq!(r.all_boxes[0], RecallPrecision::default());
        assert_eq!(
            r.all_boxes[1],
            RecallPrecision {
                recall: 50.0,
                precision: 100.0
            }
        );
    }

    #[test]
    fn a_high_scoring_false_positive_costs_the_first_half_of_the_curve() {
        let frames = vec![WaymoFrame {
            objects: vec![car(10.0, 100), car(40.0, 100)],
            detections: vec![det(25.0, 0.95, 0.3), det(10.0, 0.9, 0.3), det(40.0, 0.8, 0.3)],
        }];
        // Cutoffs ≤ 0.8: recall 1, precision 2/3; 0.8 < t ≤ 0.9: recall 1/2, precision 1/2;
        // then only the false positive. The envelope is 2/3 up to recall 1: AP = 66.7.
        let r = first(&frames);
        assert!((r.levels[0].ap - 200.0 / 3.0).abs() < 1e-6, "{}", r.levels[0].ap);
        assert!((r.all_boxes[0].recall - 100.0).abs() < 1e-9);
        assert!((r.all_boxes[0].precision - 200.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn vans_and_pointless_boxes_neither_count_nor_punish() {
        let mut van = car(10.0, 100);
        van.class = ObjectClass::Van;
        let frames = vec![WaymoFrame {
            objects: vec![van, car(30.0, 0), car(50.0, 100)],
            detections: vec![det(10.0, 0.9, 0.3), det(30.0, 0.9, 0.3), det(50.0, 0.5, 0.3)],
        }];
        let r = first(&frames);
        assert!((r.levels[1].ap - 100.0).abs() < 1e-9);
        assert_eq!(r.num_objects, [1, 1]);
    }

    #[test]
    fn the_envelope_integrates_from_recall_zero() {
        // Precision 1 to recall 0.5, then 0.5 to recall 1: 0.5 + 0.25.
        assert!((envelope_ap(vec![(0.5, 1.0), (1.0, 0.5)]) - 0.75).abs() < 1e-12);
        // A later, higher precision lifts the earlier recall levels.
        assert!((envelope_ap(vec![(0.2, 0.4), (0.6, 0.9)]) - 0.54).abs() < 1e-12);
        assert_eq!(envelope_ap(Vec::new()), 0.0);
    }
}
