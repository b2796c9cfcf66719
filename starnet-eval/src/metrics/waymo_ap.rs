//! Waymo-style 3D detection metrics: AP and APH (heading-weighted AP) at LEVEL_1 and LEVEL_2,
//! overall and per range (0–30, 30–50, 50+ m), computed as the Waymo Open Dataset's metrics
//! library does on LiDAR boxes.
//!
//! - Difficulty from the LiDAR returns inside a box: more than 5 is LEVEL_1, 1–5 is LEVEL_2
//!   (the Waymo rule: "≤ 5 points" is LEVEL_2). Every object of the class with a point takes part
//!   in the matching at both levels, and a prediction matched to any of them is a true positive
//!   (`IsTP` does not look at the level); only the misses depend on the level: an unmatched
//!   object is a false negative at LEVEL_1 only if it is a LEVEL_1 object (`IsDetectionFN`).
//! - No-label zones: objects of the neighbour class (Van for Car, Person_sitting for
//!   Pedestrian) and boxes without a LiDAR return are not matched; an unmatched prediction whose
//!   footprint overlaps one of them is not a false positive (`overlap_with_nlz`).
//! - Matching per frame and class is the Hungarian maximum-IoU assignment over pairs with 3D IoU
//!   ≥ the class threshold (Car 0.7, Pedestrian and Cyclist 0.5), redone at each of the 101
//!   score cutoffs 0, 0.01, …, 1 (the configuration OpenPCDet passes to the official tool).
//! - A true positive's heading accuracy is `1 − |Δθ| / π` (Δθ wrapped to [−π, π]).
//! - Per cutoff (`ToDetectionMetrics`): precision `tp / (tp + fp)`, recall `tp / (tp + fn)`;
//!   APH's precision is `Σ heading accuracy / (tp + fp)` and its recall is the plain recall; a
//!   cutoff with recall 0 has precision 1.
//! - AP (`ComputeMeanAveragePrecision`): the precision at each recall is the best at that
//!   recall or higher, gaps wider than 0.05 in recall are filled with the precision of their
//!   higher end, the point at recall 0 takes the precision of the next, and the area is
//!   integrated by trapezoids, in f32 as the library does.
//! - Range shards filter ground truth and predictions by their own bird's-eye-view distance
//!   from the sensor.

use super::hungarian::max_weight_matching;
use super::kitti_ap::official_min_overlap;
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::{iou_3d, iou_bev, wrap_angle};
use starnet_data::kitti::ObjectClass;
use std::collections::BTreeMap;

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
/// score, the IoU matrix `[objects × predictions]` of the matchable objects, each object's level
/// (1 or 2) and whether each prediction overlaps a no-label zone. The matching does not depend
/// on the level, so one case serves both.
struct FrameCase {
    scores: Vec<f32>,
    weights: Vec<f64>,
    heading_acc: Vec<f64>,
    levels: Vec<usize>,
    in_nlz: Vec<bool>,
}

fn frame_case(frame: &WaymoFrame, class: ObjectClass, shard: (f32, f32), iou: f32) -> FrameCase {
    let in_shard = |b: &Box3d| (shard.0..shard.1).contains(&bev_range(b));
    let (gts, levels): (Vec<&WaymoObject>, Vec<usize>) = frame
        .objects
        .iter()
        .filter(|o| o.class == class && in_shard(&o.b))
        .filter_map(|o| waymo_level(o.num_points).map(|l| (o, l)))
        .unzip();
    let zones: Vec<&Box3d> = frame
        .objects
        .iter()
        .filter(|o| (Some(o.class) == class.neighbour() || (o.class == class && o.num_points == 0)) && in_shard(&o.b))
        .map(|o| &o.b)
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
        levels,
        in_nlz: dets
            .iter()
            .map(|d| zones.iter().any(|z| iou_bev(z, &d.b) > 0.0))
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
    let (mut gt_matched, mut det_matched) = (vec![false; n_gt], vec![false; k]);
    for &(i, j) in &pairs {
        gt_matched[i] = true;
        det_matched[j] = true;
    }
    let tp_heading: f64 = pairs.iter().map(|&(i, j)| case.heading_acc[i * n + j]).sum();
    let fp = (0..k).filter(|&j| !det_matched[j] && !case.in_nlz[j]).count() as f64;
    [1, 2].map(|level| Counts {
        tp: pairs.len() as f64,
        tp_heading,
        fp,
        fn_: (0..n_gt).filter(|&i| !gt_matched[i] && case.levels[i] <= level).count() as f64,
    })
}

/// Precision and recall at one cutoff as `ToDetectionMetrics` computes them, in f32: AP's
/// `(precision, recall)` and APH's (heading-weighted precision, plain recall).
fn precision_recall(c: &Counts) -> [(f32, f32); 2] {
    let (pos, gt) = (c.tp + c.fp, c.tp + c.fn_);
    let recall = if gt > 0.0 { (c.tp / gt) as f32 } else { 0.0 };
    let precision = |hits: f64| {
        if recall == 0.0 {
            1.0
        } else if pos > 0.0 {
            (hits / pos) as f32
        } else {
            0.0
        }
    };
    [(precision(c.tp), recall), (precision(c.tp_heading), recall)]
}

/// The Waymo library's `ComputeMeanAveragePrecision` over `(precision, recall)` points, with
/// the recall gap `max_recall_delta` (0.05 in the library's config).
fn mean_average_precision(points: &[(f32, f32)], max_recall_delta: f32) -> f32 {
    if points.is_empty() {
        return 0.0;
    }
    // Recall → best precision, by ascending recall (recalls are ≥ 0, so their bits order them).
    let mut best: BTreeMap<u32, f32> = BTreeMap::from([(0f32.to_bits(), 1.0)]);
    for &(p, r) in points {
        let e = best.entry(r.to_bits()).or_insert(0.0);
        *e = e.max(p);
    }
    // (precision, recall) by descending recall, the envelope with the gaps filled.
    let mut curve: Vec<(f32, f32)> = Vec::new();
    let mut last_recall = 0.0f32;
    let mut max_precision = 0.0f32;
    for (&bits, &p) in best.iter().rev() {
        let r = f32::from_bits(bits);
        while last_recall - r > max_recall_delta + 1e-6 {
            last_recall -= max_recall_delta;
            curve.push((max_precision, last_recall));
        }
        max_precision = max_precision.max(p);
        curve.push((max_precision, r));
        last_recall = r;
    }
    let n = curve.len();
    if n < 2 {
        return 0.0;
    }
    curve[n - 1].0 = curve[n - 2].0;
    curve
        .windows(2)
        .map(|w| 0.5 * (w[0].1 - w[1].1) * (w[0].0 + w[1].0))
        .sum()
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
            .map(|c| c.levels.iter().filter(|&&v| v <= l + 1).count())
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
            if t == 0 && total.tp + total.fp > 0.0 && total.tp + total.fn_ > 0.0 {
                all_boxes = RecallPrecision {
                    recall: 100.0 * total.tp / (total.tp + total.fn_),
                    precision: 100.0 * total.tp / (total.tp + total.fp),
                };
            }
            let [plain, heading] = precision_recall(&total);
            pr.push(plain);
            prh.push(heading);
        }
        let result = ApAph {
            ap: f64::from(mean_average_precision(&pr, MAX_RECALL_DELTA)) * 100.0,
            aph: f64::from(mean_average_precision(&prh, MAX_RECALL_DELTA)) * 100.0,
        };
        (result, num_objects, all_boxes)
    };
    let ((l1, n1, b1), (l2, n2, b2)) = (level(0), level(1));
    ([l1, l2], [n1, n2], [b1, b2])
}

/// The recall gap above which the AP curve is filled in (the library's `desired_recall_delta`).
const MAX_RECALL_DELTA: f32 = 0.05;

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
        assert!((r.levels[0].ap - 100.0).abs() < 1e-4);
        // Heading accuracies 1, 1, 0. APH weights the precision only (Waymo's
        // `ToDetectionMetrics`): at cutoffs ≤ 0.7 recall 1 with heading-weighted precision 2/3;
        // above, recall 2/3 and 1/3 at precision 1. The curve: 2/3 from recall 1 down to the
        // gap-fill point 0.70, a trapezoid to (2/3, 1), then 1: 0.3 · 2/3 + ½ · (0.7 − 2/3) ·
        // (2/3 + 1) + 2/3 = 0.89444. (Weighting the recall too, as this file once did, gave 66.7.)
        assert!((r.levels[0].aph - 89.4444).abs() < 1e-3, "{}", r.levels[0].aph);
        assert_eq!(r.num_objects, [3, 3]);
        for shard in r.ranges[0] {
            assert!((shard.ap - 100.0).abs() < 1e-4);
        }
    }

    #[test]
    fn level_2_objects_are_matched_at_level_1_but_never_missed() {
        // One LEVEL_2 car (3 points), detected; one LEVEL_1 car, missed.
        let frames = vec![WaymoFrame {
            objects: vec![car(10.0, 3), car(30.0, 40)],
            detections: vec![det(10.0, 0.9, 0.3)],
        }];
        let r = first(&frames);
        // The library's `IsTP` does not look at the level: the box on the LEVEL_2 car is a true
        // positive at LEVEL_1 too, and only the LEVEL_1 car is a miss there. Recall 1/2 at
        // precision 1 at both levels: AP 50.
        assert!((r.levels[0].ap - 50.0).abs() < 1e-4, "{}", r.levels[0].ap);
        assert!((r.levels[1].ap - 50.0).abs() < 1e-4);
        assert_eq!(r.num_objects, [1, 2]);
        assert_eq!(
            r.all_boxes[0],
            RecallPrecision {
                recall: 50.0,
                precision: 100.0
            }
        );
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
        // then only the false positive (recall 0, so precision 1 by the library's rule). The
        // envelope is 2/3 up to recall 1: AP = 66.7.
        let r = first(&frames);
        assert!((r.levels[0].ap - 200.0 / 3.0).abs() < 1e-4, "{}", r.levels[0].ap);
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
        assert!((r.levels[1].ap - 100.0).abs() < 1e-4);
        assert_eq!(r.num_objects, [1, 1]);
        // A box beside the van (footprints apart) is a false positive again.
        let mut apart = frames.clone();
        apart[0].detections[0].b.y += 3.0;
        assert!(first(&apart).levels[1].ap < 99.0);
    }

    #[test]
    fn mean_average_precision_follows_the_library() {
        // (precision, recall): 1 at recall 0.5, 0.5 at recall 1. From recall 1 the gaps are
        // filled every 0.05 at the higher end's precision: 0.5 down to 0.55, a trapezoid to
        // (1, 0.5), then 1: 0.45 · 0.5 + ½ · 0.05 · 1.5 + 0.5 = 0.7625 (the rectangle rule gave 0.75).
        assert!((mean_average_precision(&[(1.0, 0.5), (0.5, 1.0)], 0.05) - 0.7625).abs() < 1e-6);
        // A later, higher precision lifts the earlier recall levels: 0.9 everywhere below 0.6.
        assert!((mean_average_precision(&[(0.4, 0.2), (0.9, 0.6)], 0.05) - 0.54).abs() < 1e-6);
        // The point at recall 0 takes the next one's precision, not its own 1.
        assert!((mean_average_precision(&[(0.25, 1.0), (1.0, 0.0)], 1.0) - 0.25).abs() < 1e-6);
        assert_eq!(mean_average_precision(&[], 0.05), 0.0);
        // A cutoff with recall 0 has precision 1; APH weights only the precision.
        let c = Counts {
            tp: 2.0,
            tp_heading: 1.5,
            fp: 2.0,
            fn_: 2.0,
        };
        assert_eq!(precision_recall(&c), [(0.5, 0.5), (0.375, 0.5)]);
        let none = Counts {
            fp: 3.0,
            ..Counts::default()
        };
        assert_eq!(precision_recall(&none), [(1.0, 0.0), (1.0, 0.0)]);
    }
}
