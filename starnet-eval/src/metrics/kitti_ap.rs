//! KITTI average precision exactly as the official devkit computes it, in the form of its
//! widely used Python port (OpenPCDet `kitti_object_eval_python/eval.py`): per class and
//! difficulty, 2D box, bird's-eye-view and 3D AP with 41-point recall sampling, reported as R11
//! (every fourth point, recall 0 included) and R40 (points 1–40), plus AOS.
//!
//! The rules: a ground-truth object counts at a difficulty when its 2D height exceeds the
//! minimum (40/25/25 px), its occlusion and truncation are within bounds; otherwise, and for
//! Van (when evaluating Car) and Person_sitting (when evaluating Pedestrian), it is "ignored":
//! a detection matched to it is neither a true nor a false positive. Detections shorter than the
//! minimum height are ignored the same way. Unmatched detections inside a DontCare region (by
//! more than the IoU threshold, measured as intersection over the detection's area) are not
//! false positives in the 2D metric. Matching needs IoU strictly above the class's threshold
//! (Car 0.7, Pedestrian and Cyclist 0.5). Score thresholds are sampled so that recall moves in
//! steps of about 1/40, which is why fewer than 40 objects cannot reach every sample.

use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::{iou_3d, iou_bev};
use starnet_data::kitti::{Difficulty, KittiObject, NO_ALPHA, ObjectClass};

/// Which overlap the AP is computed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ApMetric {
    /// 2D box in image 2.
    Bbox,
    /// Rotated bird's-eye-view box (camera x–z plane).
    Bev,
    /// 3D box.
    ThreeD,
}

const SAMPLES: usize = 41;

/// The official IoU threshold of a class (the same for the 2D, BEV and 3D metrics).
pub fn official_min_overlap(class: ObjectClass) -> f32 {
    match class {
        ObjectClass::Pedestrian | ObjectClass::Cyclist | ObjectClass::PersonSitting => 0.5,
        _ => 0.7,
    }
}

/// AP of one class, difficulty and metric, in percent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Ap {
    /// 11-point interpolation (recall 0, 0.1, …, 1 via samples 0, 4, …, 40).
    pub r11: f64,
    /// 40-point interpolation (samples 1..=40).
    pub r40: f64,
}

impl Ap {
    fn from_curve(p: &[f64; SAMPLES]) -> Self {
        Self {
            r11: (0..SAMPLES).step_by(4).map(|i| p[i]).sum::<f64>() / 11.0 * 100.0,
            r40: p[1..].iter().sum::<f64>() / 40.0 * 100.0,
        }
    }
}

/// The results of one class: `[easy, moderate, hard]` per metric.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClassAp {
    /// The class.
    pub class: ObjectClass,
    /// IoU threshold used.
    pub min_overlap: f32,
    /// 2D box AP.
    pub bbox: [Ap; 3],
    /// Bird's-eye-view AP.
    pub bev: [Ap; 3],
    /// 3D AP.
    pub three_d: [Ap; 3],
    /// Average orientation similarity (when detections carry alpha).
    pub aos: Option<[Ap; 3]>,
}

/// What an object or detection is to the evaluation of a class at a difficulty (the devkit's
/// codes 0, 1 and −1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Counts: a true positive, false positive or false negative.
    Counted,
    /// Matches are neither true nor false positives (too hard, a neighbouring class, too short).
    Ignored,
    /// Another class: not looked at.
    Other,
}

/// One frame's cleaned data for a class and difficulty (`clean_data`).
struct Cleaned {
    gt: Vec<Role>,
    dt: Vec<Role>,
    dontcare: Vec<[f32; 4]>,
}

impl Cleaned {
    /// Ground-truth objects that count.
    fn valid(&self) -> usize {
        self.gt.iter().filter(|r| **r == Role::Counted).count()
    }
}

fn clean(gt: &[KittiObject], dt: &[KittiObject], class: ObjectClass, diff: Difficulty) -> Cleaned {
    let gt_roles: Vec<Role> = gt
        .iter()
        .map(|g| {
            let neighbour = class.neighbour() == Some(g.class);
            // The devkit's height rule is strict: exactly 25 px is too small.
            let hard = g.occluded > diff.max_occlusion()
                || g.truncated > diff.max_truncation()
                || g.bbox_height() <= diff.min_height();
            if g.class == class && !hard {
                Role::Counted
            } else if neighbour || g.class == class {
                Role::Ignored
            } else {
                Role::Other
            }
        })
        .collect();
    let dontcare = gt
        .iter()
        .filter(|g| g.class == ObjectClass::DontCare)
        .map(|g| g.bbox)
        .collect();
    let dt_roles = dt
        .iter()
        .map(|d| {
            if d.bbox_height().abs() < diff.min_height() {
                Role::Ignored
            } else if d.class == class {
                Role::Counted
            } else {
                Role::Other
            }
        })
        .collect();
    Cleaned {
        gt: gt_roles,
        dt: dt_roles,
        dontcare,
    }
}

/// 2D IoU (criterion −1) or intersection over the first box's area (criterion 0).
fn box2d_overlap(a: &[f32; 4], b: &[f32; 4], over_first: bool) -> f64 {
    let iw = a[2].min(b[2]) as f64 - a[0].max(b[0]) as f64;
    let ih = a[3].min(b[3]) as f64 - a[1].max(b[1]) as f64;
    if iw <= 0.0 || ih <= 0.0 {
        return 0.0;
    }
    let area = |x: &[f32; 4]| (x[2] - x[0]) as f64 * (x[3] - x[1]) as f64;
    let ua = if over_first {
        area(a)
    } else {
        area(a) + area(b) - iw * ih
    };
    iw * ih / ua
}

/// A label's box in the camera's x–z plane: the devkit's BEV/3D geometry (`(x, z, l, w, ry)`
/// and the height span `[y − h, y]`), as a [`Box3d`] so the same IoU code applies.
fn camera_box(o: &KittiObject) -> Box3d {
    let c = &o.cam;
    Box3d::new(c.x, c.z, c.y - 0.5 * c.h, c.l, c.w, c.h, -c.ry)
}

/// Overlaps `[dt, gt]` of one frame for a metric.
fn overlaps(gt: &[KittiObject], dt: &[KittiObject], metric: ApMetric) -> Vec<Vec<f64>> {
    let (gb, db): (Vec<Box3d>, Vec<Box3d>) = (gt.iter().map(camera_box).collect(), dt.iter().map(camera_box).collect());
    (0..dt.len())
        .map(|j| {
            (0..gt.len())
                .map(|i| match metric {
                    ApMetric::Bbox => box2d_overlap(&dt[j].bbox, &gt[i].bbox, false),
                    ApMetric::Bev => iou_bev(&db[j], &gb[i]) as f64,
                    ApMetric::ThreeD => iou_3d(&db[j], &gb[i]) as f64,
                })
                .collect()
        })
        .collect()
}

/// One frame's ground truth and detections, as the devkit reads a label file and a result file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KittiFrame {
    /// The label lines, DontCare regions and neighbouring classes included.
    pub labels: Vec<KittiObject>,
    /// The detections: each with a score, a 2D box and (for AOS) alpha.
    pub detections: Vec<KittiObject>,
}

/// One frame's cleaned data and overlaps for a class, difficulty and metric.
struct FrameData<'a> {
    gt: &'a [KittiObject],
    dt: &'a [KittiObject],
    overlaps: &'a [Vec<f64>],
    roles: Cleaned,
}

/// What `compute_statistics_jit` returns for one frame at one score threshold (but its false
/// negatives: the AP needs precision only, recall being the threshold sampling's).
#[derive(Debug, Default)]
struct Statistics {
    tp: usize,
    fp: usize,
    /// Summed orientation similarity of the true positives; `None` without any box (the
    /// devkit's −1, which the curve skips).
    similarity: Option<f64>,
    /// Scores of the true positives.
    scores: Vec<f32>,
}

/// How `statistics` runs (the devkit's `compute_fp`): collecting the score of every match, or
/// at a score threshold, counting false positives and the orientation similarity.
#[derive(Debug, Clone, Copy)]
enum Pass {
    /// `compute_fp = False`: each object takes its best-scoring detection.
    Scores,
    /// `compute_fp = True` at this threshold: each object takes its best-overlapping one.
    Threshold(f32),
}

/// `compute_statistics_jit`, line for line.
fn statistics(f: &FrameData, metric: ApMetric, min_overlap: f64, pass: Pass) -> Statistics {
    let below: Vec<bool> = match pass {
        Pass::Scores => vec![false; f.dt.len()],
        Pass::Threshold(thresh) => f.dt.iter().map(|d| d.score.unwrap_or(0.0) < thresh).collect(),
    };
    let mut assigned = vec![false; f.dt.len()];
    let (mut st, deltas) = match_ground_truth(f, min_overlap, pass, &below, &mut assigned);
    if let Pass::Threshold(_) = pass {
        st.fp = false_positives(f, metric, min_overlap, &below, &mut assigned);
        st.similarity = (st.tp > 0 || st.fp > 0).then(|| deltas.iter().map(|d| (1.0 + d.cos()) / 2.0).sum());
    }
    st
}

/// The ground-truth loop of `compute_statistics_jit`: each object takes its best detection
/// (by score, or at a threshold by overlap, counted ones before ignored ones); true positives
/// and the alpha differences of the true positives (false negatives are not needed).
fn match_ground_truth(
    f: &FrameData,
    min_overlap: f64,
    pass: Pass,
    below: &[bool],
    assigned: &mut [bool],
) -> (Statistics, Vec<f64>) {
    let (gt_roles, dt_roles) = (&f.roles.gt, &f.roles.dt);
    let mut st = Statistics::default();
    let mut deltas = Vec::new();
    for (i, &gt_role) in gt_roles.iter().enumerate() {
        if gt_role == Role::Other {
            continue;
        }
        let open: Vec<usize> = (0..f.dt.len())
            .filter(|&j| !(dt_roles[j] == Role::Other || assigned[j] || below[j]))
            .collect();
        let found = match pass {
            Pass::Scores => best_by_score(f, i, min_overlap, &open),
            Pass::Threshold(_) => best_by_overlap(f, i, min_overlap, &open),
        };
        // None: a false negative when the object counts (the AP needs none).
        let Some(det) = found else { continue };
        assigned[det] = true;
        // A match with an ignored object or detection is neither a true nor a false positive.
        if gt_role == Role::Counted && dt_roles[det] == Role::Counted {
            st.tp += 1;
            st.scores.push(f.dt[det].score.unwrap_or(0.0));
            deltas.push((f.gt[i].alpha - f.dt[det].alpha) as f64);
        }
    }
    (st, deltas)
}

/// A detection and its score.
#[derive(Debug, Clone, Copy)]
struct Scored {
    det: usize,
    score: f32,
}

/// The score a detection must exceed to be matched at all in the score pass: the devkit's
/// initial `valid_detection` (`NO_DETECTION`), so a score at or below it, or NaN, never is.
const SCORE_FLOOR: f32 = -10_000_000.0;

/// The highest-scoring of the `open` detections overlapping object `i` by more than
/// `min_overlap` (the devkit's `score > valid_detection`, from [`SCORE_FLOOR`]).
fn best_by_score(f: &FrameData, i: usize, min_overlap: f64, open: &[usize]) -> Option<usize> {
    let mut best: Option<Scored> = None;
    for &j in open {
        let score = f.dt[j].score.unwrap_or(0.0);
        if f.overlaps[j][i] > min_overlap && score > best.map_or(SCORE_FLOOR, |b| b.score) {
            best = Some(Scored { det: j, score });
        }
    }
    best.map(|b| b.det)
}

/// What an object has matched so far in the threshold pass.
#[derive(Debug, Clone, Copy)]
enum Matched {
    /// A counted detection (the best overlap so far).
    Counted(usize),
    /// An ignored detection, taken only while no counted one matches.
    Ignored(usize),
}

/// The `open` detection object `i` takes at a threshold: the counted one of largest overlap
/// above `min_overlap`, else the first ignored one above it.
fn best_by_overlap(f: &FrameData, i: usize, min_overlap: f64, open: &[usize]) -> Option<usize> {
    let mut best: Option<Matched> = None;
    let mut max_overlap = 0.0f64;
    for &j in open {
        let overlap = f.overlaps[j][i];
        let took_ignored = matches!(best, Some(Matched::Ignored(_)));
        let role = f.roles.dt[j];
        if overlap > min_overlap && (overlap > max_overlap || took_ignored) && role == Role::Counted {
            max_overlap = overlap;
            best = Some(Matched::Counted(j));
        } else if overlap > min_overlap && best.is_none() && role == Role::Ignored {
            best = Some(Matched::Ignored(j));
        }
    }
    best.map(|m| match m {
        Matched::Counted(j) | Matched::Ignored(j) => j,
    })
}

/// Unassigned counted detections above the threshold; in the 2D metric, those inside a
/// DontCare region (intersection over the detection's area above the threshold) are not.
fn false_positives(f: &FrameData, metric: ApMetric, min_overlap: f64, below: &[bool], assigned: &mut [bool]) -> usize {
    let n = f.dt.len();
    let open = |j: usize, assigned: &[bool]| !(assigned[j] || f.roles.dt[j] != Role::Counted || below[j]);
    let fp = (0..n).filter(|&j| open(j, assigned)).count();
    if metric != ApMetric::Bbox {
        return fp;
    }
    let mut nstuff = 0;
    for dc in &f.roles.dontcare {
        for j in 0..n {
            if open(j, assigned) && box2d_overlap(&f.dt[j].bbox, dc, true) > min_overlap {
                assigned[j] = true;
                nstuff += 1;
            }
        }
    }
    fp - nstuff
}

/// Score thresholds giving recall steps of about 1/40 (`get_thresholds`).
fn sample_thresholds(mut scores: Vec<f32>, num_gt: usize) -> Vec<f32> {
    scores.sort_by(|a, b| b.total_cmp(a));
    let n = num_gt as f64;
    let mut current = 0.0f64;
    let mut out = Vec::new();
    for (i, &s) in scores.iter().enumerate() {
        let l = (i + 1) as f64 / n;
        let r = if i + 1 < scores.len() { (i + 2) as f64 / n } else { l };
        if (r - current) < (current - l) && i + 1 < scores.len() {
            continue;
        }
        out.push(s);
        current += 1.0 / (SAMPLES as f64 - 1.0);
    }
    out
}

/// The precision and orientation-similarity curves of one class, difficulty and metric, at
/// the sampled score thresholds (the devkit's `eval_class`).
#[derive(Debug, Clone, Copy)]
struct Curves {
    precision: [f64; SAMPLES],
    orientation: [f64; SAMPLES],
}

/// [`Curves`] of one class, difficulty and metric; `overlaps` are the metric's, per frame.
fn curves(
    frames: &[KittiFrame],
    overlaps: &[Vec<Vec<f64>>],
    class: ObjectClass,
    diff: Difficulty,
    metric: ApMetric,
    min_overlap: f64,
) -> Curves {
    let data: Vec<FrameData> = frames
        .iter()
        .zip(overlaps)
        .map(|(f, overlaps)| FrameData {
            gt: &f.labels,
            dt: &f.detections,
            overlaps,
            roles: clean(&f.labels, &f.detections, class, diff),
        })
        .collect();
    let total_valid: usize = data.iter().map(|f| f.roles.valid()).sum();
    let mut c = Curves {
        precision: [0.0; SAMPLES],
        orientation: [0.0; SAMPLES],
    };
    if total_valid == 0 {
        // The Python port divides by zero here; no object of the class means AP 0.
        return c;
    }
    let scores: Vec<f32> = data
        .iter()
        .flat_map(|f| statistics(f, metric, min_overlap, Pass::Scores).scores)
        .collect();
    let thresholds = sample_thresholds(scores, total_valid);
    for (t, &thresh) in thresholds.iter().enumerate() {
        let (mut tp, mut fp, mut sim) = (0usize, 0usize, 0.0f64);
        for f in &data {
            let st = statistics(f, metric, min_overlap, Pass::Threshold(thresh));
            tp += st.tp;
            fp += st.fp;
            sim += st.similarity.unwrap_or(0.0);
        }
        c.precision[t] = tp as f64 / (tp + fp) as f64;
        c.orientation[t] = sim / (tp + fp) as f64;
    }
    for t in (0..thresholds.len()).rev() {
        if t + 1 < SAMPLES {
            c.precision[t] = c.precision[t].max(c.precision[t + 1]);
            c.orientation[t] = c.orientation[t].max(c.orientation[t + 1]);
        }
    }
    c
}

/// KITTI AP of `classes` over `frames`. Detections need a score, a 2D box (for the height rule
/// and the 2D metric) and, for AOS, alpha (AOS is computed unless the first detection's alpha is
/// [`NO_ALPHA`], as in the devkit). Each metric's overlaps are computed once, for every class
/// and difficulty, and the three metrics run in parallel (the figures do not depend on it).
pub fn kitti_ap(frames: &[KittiFrame], classes: &[ObjectClass]) -> Vec<ClassAp> {
    let with_alpha = frames
        .iter()
        .find(|f| !f.detections.is_empty())
        .is_some_and(|f| f.detections[0].alpha != NO_ALPHA);
    let [bbox, bev, three_d] = std::thread::scope(|s| {
        let metric_curves = |metric| s.spawn(move || metric_curves(frames, classes, metric));
        [ApMetric::Bbox, ApMetric::Bev, ApMetric::ThreeD]
            .map(metric_curves)
            .map(|h| h.join().expect("the AP curves do not panic"))
    });
    let precision = |c: &[Curves; 3]| c.map(|c| Ap::from_curve(&c.precision));
    classes
        .iter()
        .enumerate()
        .map(|(k, &class)| ClassAp {
            class,
            min_overlap: official_min_overlap(class),
            bbox: precision(&bbox[k]),
            bev: precision(&bev[k]),
            three_d: precision(&three_d[k]),
            aos: with_alpha.then(|| bbox[k].map(|c| Ap::from_curve(&c.orientation))),
        })
        .collect()
}

/// The curves of one metric, per class, at `[easy, moderate, hard]`.
fn metric_curves(frames: &[KittiFrame], classes: &[ObjectClass], metric: ApMetric) -> Vec<[Curves; 3]> {
    let overlaps: Vec<Vec<Vec<f64>>> = frames
        .iter()
        .map(|f| overlaps(&f.labels, &f.detections, metric))
        .collect();
    classes
        .iter()
        .map(|&class| {
            let mo = official_min_overlap(class) as f64;
            Difficulty::ALL.map(|d| curves(frames, &overlaps, class, d, metric, mo))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::kitti::{CameraBox, read_labels};
    use std::path::Path;

    fn obj(class: ObjectClass, x: f32, h_px: f32, score: Option<f32>) -> KittiObject {
        KittiObject {
            class,
            truncated: if score.is_some() { -1.0 } else { 0.0 },
            occluded: if score.is_some() { -1 } else { 0 },
            alpha: 0.5,
            bbox: [x, 150.0, x + 80.0, 150.0 + h_px],
            cam: CameraBox {
                h: 1.5,
                w: 1.6,
                l: 3.9,
                x: x / 50.0,
                y: 1.7,
                z: 20.0,
                ry: 0.0,
            },
            score,
        }
    }

    /// 40 easy cars over 10 frames, each detected exactly with a distinct score.
    fn perfect() -> Vec<KittiFrame> {
        (0..10)
            .map(|f| {
                let gt: Vec<_> = (0..4)
                    .map(|k| obj(ObjectClass::Car, 100.0 + 200.0 * k as f32, 60.0, None))
                    .collect();
                let dt = (0..4)
                    .map(|k| {
                        obj(
                            ObjectClass::Car,
                            100.0 + 200.0 * k as f32,
                            60.0,
                            Some(0.5 + 0.01 * (f * 4 + k) as f32),
                        )
                    })
                    .collect();
                KittiFrame {
                    labels: gt,
                    detections: dt,
                }
            })
            .collect()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-4
    }

    #[test]
    fn perfect_detections_with_exactly_40_objects() {
        // 40 objects give 40 sampled thresholds, filling samples 0..=39 of 41 with precision 1:
        // R11 = 10/11 and R40 = 39/40 (OpenPCDet's eval.py prints 90.909091 and 97.500000).
        let r = &kitti_ap(&perfect(), &[ObjectClass::Car])[0];
        for ap in r
            .bbox
            .iter()
            .chain(&r.bev)
            .chain(&r.three_d)
            .chain(r.aos.as_ref().unwrap())
        {
            assert!(close(ap.r11, 1000.0 / 11.0) && close(ap.r40, 97.5), "{ap:?}");
        }
    }

    #[test]
    fn one_high_scoring_false_positive() {
        // It counts at every threshold: precision k / (k + 1) at the k-th, made monotone from
        // the right → 40/41 everywhere: R11 = 10/11 · 40/41, R40 = 39/40 · 40/41.
        let mut frames = perfect();
        frames[3]
            .detections
            .push(obj(ObjectClass::Car, 1000.0, 60.0, Some(0.99)));
        let r = &kitti_ap(&frames, &[ObjectClass::Car])[0];
        assert!(
            close(r.bbox[0].r11, 1000.0 / 11.0 * 40.0 / 41.0) && close(r.bbox[0].r40, 97.5 * 40.0 / 41.0),
            "{:?}",
            r.bbox[0]
        );
        assert!(close(r.three_d[1].r40, 97.5 * 40.0 / 41.0));
    }

    #[test]
    fn ignore_rules() {
        let base = kitti_ap(&perfect(), &[ObjectClass::Car])[0].clone();
        // A car detection on a Van is neither TP nor FP when evaluating Car.
        let mut f = perfect();
        f[0].labels.push(obj(ObjectClass::Van, 1000.0, 60.0, None));
        f[0].detections.push(obj(ObjectClass::Car, 1000.0, 60.0, Some(0.99)));
        assert_eq!(kitti_ap(&f, &[ObjectClass::Car])[0].bbox, base.bbox, "Van is ignored");
        // A detection inside a DontCare region is forgiven in 2D only (DontCare has no 3D box).
        let mut f = perfect();
        let dc = KittiObject::dont_care([1000.0, 150.0, 1080.0, 210.0]);
        f[0].labels.push(dc);
        f[0].detections.push(obj(ObjectClass::Car, 1005.0, 50.0, Some(0.99)));
        let r = &kitti_ap(&f, &[ObjectClass::Car])[0];
        assert_eq!(r.bbox, base.bbox, "DontCare forgives in 2D");
        assert!(
            close(r.bev[0].r40, 97.5 * 40.0 / 41.0),
            "but not in BEV: {:?}",
            r.bev[0]
        );
        // A detection shorter than 40 px is ignored at easy but counts (as an FP) at moderate.
        let mut f = perfect();
        f[0].detections.push(obj(ObjectClass::Car, 1000.0, 30.0, Some(0.99)));
        let r = &kitti_ap(&f, &[ObjectClass::Car])[0];
        assert_eq!(r.bbox[0], base.bbox[0]);
        assert!(close(r.bbox[1].r40, 97.5 * 40.0 / 41.0));
        // Five 30 px ground truths, missed: no objects at easy (height ≤ 40), misses at moderate
        // (40 of 45 found: the sampled recall stops at 36 of 40 steps). A single miss would not
        // show: 40 of 41 still fills 40 samples.
        let mut f = perfect();
        for frame in f.iter_mut().take(5) {
            frame.labels.push(obj(ObjectClass::Car, 1000.0, 30.0, None));
        }
        let r = &kitti_ap(&f, &[ObjectClass::Car])[0];
        assert_eq!(r.bbox[0], base.bbox[0]);
        assert!(r.bbox[1].r40 < base.bbox[1].r40 - 5.0, "{:?}", r.bbox[1]);
        // Other classes' detections do not count against Car.
        let mut f = perfect();
        f[0].detections
            .push(obj(ObjectClass::Pedestrian, 1000.0, 60.0, Some(0.99)));
        assert_eq!(kitti_ap(&f, &[ObjectClass::Car])[0].bbox, base.bbox);
    }

    #[test]
    fn fewer_than_40_objects() {
        // One object, found: a single threshold fills sample 0 only, so R40 (which skips
        // recall 0) is 0 and R11 is 1/11 — the devkit's small-sample behaviour.
        let f = vec![KittiFrame {
            labels: vec![obj(ObjectClass::Car, 100.0, 60.0, None)],
            detections: vec![obj(ObjectClass::Car, 100.0, 60.0, Some(0.9))],
        }];
        let r = &kitti_ap(&f, &[ObjectClass::Car])[0];
        assert!(
            close(r.bbox[0].r11, 100.0 / 11.0) && r.bbox[0].r40 == 0.0,
            "{:?}",
            r.bbox[0]
        );
        // No object of the class: AP 0.
        assert_eq!(kitti_ap(&f, &[ObjectClass::Cyclist])[0].bbox[1].r40, 0.0);
    }

    /// `testdata/kitti_eval_case`: 30 generated frames exercising every rule (neighbour classes,
    /// DontCare regions with detections in them, all three difficulties' limits, duplicates and
    /// false positives, wrong classes, noisy alpha). Expected values from a transcription of
    /// OpenPCDet's `eval.py` (bbox metric, `get_official_eval_result` thresholds), run on the same
    /// files.
    #[test]
    fn matches_openpcdet_on_a_generated_case() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/kitti_eval_case");
        let mut ids: Vec<String> = std::fs::read_dir(root.join("gt"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        ids.sort();
        let frames: Vec<_> = ids
            .iter()
            .map(|id| KittiFrame {
                labels: read_labels(&root.join("gt").join(id)).unwrap(),
                detections: read_labels(&root.join("dt").join(id)).unwrap(),
            })
            .collect();
        let r = kitti_ap(&frames, &[ObjectClass::Car, ObjectClass::Pedestrian]);
        let want: [[(f64, f64, f64, f64); 3]; 2] = [
            [
                (0.909091, 0.238095, 0.888789, 0.228150),
                (16.025641, 14.935897, 15.817296, 14.720320),
                (29.090909, 30.666667, 28.407260, 29.945987),
            ],
            [
                (4.545455, 0.0, 4.288625, 0.0),
                (7.575758, 4.166667, 7.226958, 4.040208),
                (9.409888, 6.422306, 9.051108, 6.179870),
            ],
        ];
        for (c, rows) in want.iter().enumerate() {
            for (d, &(r11, r40, a11, a40)) in rows.iter().enumerate() {
                let (bbox, aos) = (r[c].bbox[d], r[c].aos.unwrap()[d]);
                assert!(
                    close(bbox.r11, r11) && close(bbox.r40, r40),
                    "{:?} difficulty {d}: {bbox:?}",
                    r[c].class
                );
                assert!(
                    close(aos.r11, a11) && close(aos.r40, a40),
                    "{:?} difficulty {d} AOS: {aos:?}",
                    r[c].class
                );
            }
        }
    }
}
