//! Decoding's last step: per-class greedy non-maximum suppression with oriented 3D IoU
//! (lingvo `NonMaxSuppression3D`), and the stateful variant of the streaming paper (§3.3),
//! which also suppresses against the boxes kept in the previous k calls. Optionally each kept
//! box is then refined by box voting ([`vote`]; not in the paper, off by default).

use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::{iou_3d, wrap_angle};
use std::collections::VecDeque;
use std::f32::consts::PI;

/// A scored box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// The box, LiDAR frame.
    pub b: Box3d,
    /// Class index.
    pub class: usize,
    /// Score in [0, 1].
    pub score: f32,
}

/// Thresholds of one class.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassNms {
    /// A box is suppressed by a kept box of its class with 3D IoU above this.
    pub iou: f32,
    /// Boxes scoring below this are dropped first.
    pub score: f32,
    /// Box voting: a kept box becomes the score-weighted mean of the candidates overlapping it
    /// by at least this 3D IoU ([`vote`]); `None` keeps it as selected (the paper).
    #[serde(default)]
    pub vote_iou: Option<f32>,
}

/// NMS settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NmsConfig {
    /// Per class index.
    pub per_class: Vec<ClassNms>,
    /// At most this many boxes are kept, best scores first (512).
    pub max_boxes: usize,
}

/// Greedy per-class NMS: boxes are taken best score first (ties by input order) and kept unless
/// a kept box of the same class overlaps them above the class's IoU threshold. Output sorted by
/// descending score, at most `max_boxes`.
pub fn nms(dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
    nms_after(&[], dets, cfg, Precedence::Arrival)
}

/// [`nms`] continuing from boxes kept earlier: `earlier` suppress like kept boxes but are not
/// returned (nor counted against `max_boxes`). With [`Precedence::Arrival`] an earlier box
/// suppresses every overlapping new box; with [`Precedence::Score`] only those it outscores
/// (ties go to the earlier box).
pub fn nms_after(earlier: &[Detection], dets: &[Detection], cfg: &NmsConfig, precedence: Precedence) -> Vec<Detection> {
    let mut order: Vec<usize> = (0..dets.len())
        .filter(|&i| {
            cfg.per_class
                .get(dets[i].class)
                .is_some_and(|c| dets[i].score >= c.score)
        })
        .collect();
    order.sort_by(|&i, &j| dets[j].score.total_cmp(&dets[i].score).then(i.cmp(&j)));
    let mut kept: Vec<Detection> = Vec::new();
    for &i in &order {
        if kept.len() == cfg.max_boxes {
            break;
        }
        let d = dets[i];
        let thr = cfg.per_class[d.class].iou;
        let outranks = |e: &&Detection| precedence == Precedence::Arrival || e.score >= d.score;
        if earlier
            .iter()
            .filter(outranks)
            .chain(&kept)
            .all(|k| k.class != d.class || iou_3d(&k.b, &d.b) <= thr)
        {
            kept.push(d);
        }
    }
    // Voting reads the selected boxes, so it runs after every suppression decision is made.
    for k in &mut kept {
        if let Some(min_iou) = cfg.per_class[k.class].vote_iou {
            let same_class: Vec<Detection> = order.iter().map(|&i| dets[i]).filter(|d| d.class == k.class).collect();
            k.b = vote(k, &same_class, min_iou);
        }
    }
    kept
}

/// Box voting (Gidaris & Komodakis, ICCV 2015): the score-weighted mean of the `candidates`
/// whose 3D IoU with `kept` is at least `min_iou` (`kept` among them, or added). Centers and
/// sizes are averaged; headings are averaged as the box geometry (modulo π) about the kept
/// heading, and the direction is the weighted majority of the candidates' directions, so a box
/// whose top score points backwards is turned when most of the evidence disagrees.
pub fn vote(kept: &Detection, candidates: &[Detection], min_iou: f32) -> Box3d {
    let voters: Vec<&Detection> = candidates
        .iter()
        .filter(|c| c != &kept && iou_3d(&c.b, &kept.b) >= min_iou)
        .chain(std::iter::once(kept))
        .collect();
    let total: f32 = voters.iter().map(|c| c.score).sum();
    let mean = |f: fn(&Box3d) -> f32| voters.iter().map(|c| c.score * f(&c.b)).sum::<f32>() / total;
    let turn = |c: &Detection| wrap_angle(c.b.heading - kept.b.heading);
    // The turn modulo π, in [−π/2, π/2): the same box whichever way it points.
    let axis_turn = voters
        .iter()
        .map(|c| c.score * (wrap_angle(2.0 * turn(c)) / 2.0))
        .sum::<f32>()
        / total;
    let forward: f32 = voters.iter().map(|c| c.score * turn(c).cos().signum()).sum();
    let flip = if forward < 0.0 { PI } else { 0.0 };
    Box3d::new(
        mean(|b| b.x),
        mean(|b| b.y),
        mean(|b| b.z),
        mean(|b| b.dx),
        mean(|b| b.dy),
        mean(|b| b.dz),
        wrap_angle(kept.b.heading + axis_turn + flip),
    )
}

/// Which of two overlapping boxes stateful NMS keeps when one was emitted in an earlier slice
/// (already reported, so it cannot be withdrawn) and the other arrives now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precedence {
    /// As NMS over the remembered and the new boxes together: a remembered box suppresses the
    /// new boxes it outscores, and a more confident new box is emitted as well (global NMS
    /// would have dropped the remembered one instead). The default: a slice that saw only the
    /// edge of an object, at low confidence, does not veto the slice that sees it whole.
    #[default]
    Score,
    /// What was emitted first stands: a remembered box suppresses every overlapping new box.
    Arrival,
}

/// NMS that remembers the boxes it kept in its last `k` calls and suppresses new boxes that
/// overlap them (for the slices of a streaming sweep), under a [`Precedence`]. `reset` starts a
/// new sweep.
#[derive(Debug, Clone)]
pub struct StatefulNms {
    k: usize,
    precedence: Precedence,
    history: VecDeque<Vec<Detection>>,
}

impl StatefulNms {
    /// Remembers the last `k` calls (the streaming paper uses k = 1).
    pub fn new(k: usize, precedence: Precedence) -> Self {
        Self {
            k,
            precedence,
            history: VecDeque::new(),
        }
    }

    /// Forgets every previous call.
    pub fn reset(&mut self) {
        self.history.clear();
    }

    /// Greedy NMS of `dets` continuing from the remembered boxes ([`nms_after`]): a box is
    /// dropped when a newly kept box of its class, or a remembered one that takes precedence,
    /// overlaps it (a dropped box suppresses nothing).
    pub fn step(&mut self, dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
        let remembered: Vec<Detection> = self.history.iter().flatten().copied().collect();
        let kept = nms_after(&remembered, dets, cfg, self.precedence);
        if self.k > 0 {
            self.history.push_back(kept.clone());
            while self.history.len() > self.k {
                self.history.pop_front();
            }
        }
        kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x: f32, class: usize, score: f32) -> Detection {
        Detection {
            b: Box3d::new(x, 0.0, -1.0, 4.0, 1.6, 1.5, 0.0),
            class,
            score,
        }
    }

    fn cfg(max: usize) -> NmsConfig {
        NmsConfig {
            per_class: vec![
                ClassNms {
                    iou: 0.1,
                    score: 0.2,
                    vote_iou: None
                };
                2
            ],
            max_boxes: max,
        }
    }

    #[test]
    fn suppresses_overlaps_keeps_other_classes_and_honours_limits() {
        let dets = [
            det(0.0, 0, 0.9),
            det(0.5, 0, 0.8),
            det(0.5, 1, 0.7),
            det(10.0, 0, 0.6),
            det(20.0, 0, 0.1),
        ];
        let kept = nms(&dets, &cfg(10));
        let scores: Vec<f32> = kept.iter().map(|d| d.score).collect();
        assert_eq!(
            scores,
            [0.9, 0.7, 0.6],
            "0.8 overlaps 0.9; the class-1 box survives; 0.1 is below the score threshold"
        );
        assert_eq!(nms(&dets, &cfg(2)).len(), 2);
    }

    #[test]
    fn voting_averages_the_overlapping_candidates_by_score() {
        let dets = [det(0.0, 0, 0.9), det(0.5, 0, 0.6), det(10.0, 0, 0.5), det(0.3, 1, 0.8)];
        let mut c = cfg(10);
        c.per_class[0].vote_iou = Some(0.5);
        let kept = nms(&dets, &c);
        // Class 0: 0.9 and 0.6 overlap (IoU 3.5/4.5 = 0.78) and vote, (0.9·0 + 0.6·0.5)/1.5 = 0.2;
        // the far box is kept alone; class 1 has no voting.
        let xs: Vec<f32> = kept.iter().map(|d| d.b.x).collect();
        assert!((xs[0] - 0.2).abs() < 1e-6 && xs[1] == 0.3 && xs[2] == 10.0, "{xs:?}");
        assert_eq!(kept.iter().map(|d| d.score).collect::<Vec<_>>(), [0.9, 0.8, 0.5]);
        // Plain NMS keeps the selected box.
        assert_eq!(nms(&dets, &cfg(10))[0].b.x, 0.0);
    }

    #[test]
    fn voting_averages_headings_as_axes_and_takes_the_majority_direction() {
        let at = |heading: f32, score: f32| Detection {
            b: Box3d::new(0.0, 0.0, -1.0, 4.0, 1.6, 1.5, wrap_angle(heading)),
            class: 0,
            score,
        };
        let kept = at(0.1, 0.5);
        // Both others point backwards: axis turns +0.2 and 0; direction 0.5 − 0.4 − 0.3 < 0.
        let others = [at(PI + 0.3, 0.4), at(PI + 0.1, 0.3)];
        let b = vote(&kept, &others, 0.5);
        let want = wrap_angle(0.1 + 0.4 * 0.2 / 1.2 + PI);
        assert!((b.heading - want).abs() < 1e-5, "{} vs {want}", b.heading);
        // One backward voter of lower weight: the direction stays, the axis still moves.
        let b = vote(&kept, &others[..1], 0.5);
        assert!((b.heading - (0.1 + 0.4 * 0.2 / 0.9)).abs() < 1e-5, "{}", b.heading);
        // Nothing overlaps enough: the kept box as it was.
        let alone = vote(&kept, &others, 1.0);
        assert!((alone.heading - 0.1).abs() < 1e-6 && alone.x == 0.0 && alone.dx == 4.0);
    }

    #[test]
    fn stateful_nms_suppresses_a_previous_calls_box_and_forgets_after_k() {
        let mut s = StatefulNms::new(1, Precedence::Arrival);
        let c = cfg(10);
        assert_eq!(s.step(&[det(0.0, 0, 0.9)], &c).len(), 1);
        // The same object again in the next slice, even with a higher score: suppressed.
        assert!(s.step(&[det(0.2, 0, 0.95)], &c).is_empty());
        // k = 1: the slice before last is forgotten (the last call kept nothing).
        assert_eq!(s.step(&[det(0.2, 0, 0.95)], &c).len(), 1);
        s.reset();
        assert_eq!(s.step(&[det(0.2, 0, 0.95)], &c).len(), 1);
        // Other classes are not suppressed.
        assert_eq!(s.step(&[det(0.2, 1, 0.95)], &c).len(), 1);
    }

    #[test]
    fn score_precedence_lets_a_more_confident_later_box_through() {
        let c = cfg(10);
        let edge = det(0.0, 0, 0.3); // slice 0 saw the object's edge
        let whole = det(0.4, 0, 0.9); // slice 1 sees it whole
        let mut arrival = StatefulNms::new(1, Precedence::Arrival);
        let mut score = StatefulNms::new(1, Precedence::Score);
        assert_eq!(arrival.step(&[edge], &c), [edge]);
        assert_eq!(score.step(&[edge], &c), [edge]);
        assert!(arrival.step(&[whole], &c).is_empty());
        assert_eq!(score.step(&[whole], &c), [whole]);
        // Slice 2 sees it again, also at 0.9: a tie goes to the remembered box.
        assert!(score.step(&[det(0.8, 0, 0.9)], &c).is_empty());
    }

    /// Greedy NMS taking boxes slice by slice (each slice best score first): the oracle of
    /// stateful NMS with memory of every earlier slice.
    fn nms_in_arrival_order(slices: &[Vec<Detection>], cfg: &NmsConfig) -> Vec<Detection> {
        let mut kept: Vec<Detection> = Vec::new();
        for slice in slices {
            let mut order: Vec<&Detection> = slice
                .iter()
                .filter(|d| d.score >= cfg.per_class[d.class].score)
                .collect();
            order.sort_by(|a, b| b.score.total_cmp(&a.score));
            for d in order {
                if kept
                    .iter()
                    .all(|k| k.class != d.class || iou_3d(&k.b, &d.b) <= cfg.per_class[d.class].iou)
                {
                    kept.push(*d);
                }
            }
        }
        kept
    }

    fn stateful_all(slices: &[Vec<Detection>], k: usize, cfg: &NmsConfig) -> Vec<Detection> {
        let mut s = StatefulNms::new(k, Precedence::Arrival);
        slices.iter().flat_map(|d| s.step(d, cfg)).collect()
    }

    fn sorted(mut v: Vec<Detection>) -> Vec<Detection> {
        v.sort_by(|a, b| b.score.total_cmp(&a.score).then(a.b.x.total_cmp(&b.b.x)));
        v
    }

    proptest::proptest! {
        /// A vote is a weighted mean: its centre and sizes lie within the candidates' range, its
        /// axis within their spread about the kept heading (modulo π), and copies of one box vote
        /// for that box.
        #[test]
        fn votes_stay_within_the_candidates(
            raw in proptest::collection::vec((-0.5f32..0.5, -0.5f32..0.5, 3.5f32..4.5, -0.3f32..0.3, proptest::bool::ANY, 0.3f32..1.0), 1..12),
        ) {
            let dets: Vec<Detection> = raw
                .iter()
                .map(|&(x, y, dx, turn, back, score)| Detection {
                    b: Box3d::new(x, y, -1.0, dx, 1.6, 1.5, wrap_angle(0.2 + turn + if back { PI } else { 0.0 })),
                    class: 0,
                    score,
                })
                .collect();
            let v = vote(&dets[0], &dets, 0.0);
            let range = |f: fn(&Box3d) -> f32| {
                let vals: Vec<f32> = dets.iter().map(|d| f(&d.b)).collect();
                (vals.iter().copied().fold(f32::INFINITY, f32::min) - 1e-4, vals.iter().copied().fold(f32::NEG_INFINITY, f32::max) + 1e-4)
            };
            for (got, (lo, hi)) in [(v.x, range(|b| b.x)), (v.y, range(|b| b.y)), (v.dx, range(|b| b.dx))] {
                proptest::prop_assert!((lo..=hi).contains(&got), "{} not in [{}, {}]", got, lo, hi);
            }
            let axis = |h: f32| wrap_angle(2.0 * (h - 0.2)) / 2.0;
            let turns: Vec<f32> = dets.iter().map(|d| axis(d.b.heading)).collect();
            let (lo, hi) = (turns.iter().copied().fold(f32::INFINITY, f32::min), turns.iter().copied().fold(f32::NEG_INFINITY, f32::max));
            proptest::prop_assert!((lo - 1e-4..=hi + 1e-4).contains(&axis(v.heading)), "axis {} not in [{}, {}]", axis(v.heading), lo, hi);
            let copies = vec![dets[0]; 3];
            let same = vote(&dets[0], &copies, 0.5);
            proptest::prop_assert!((same.x - dets[0].b.x).abs() < 1e-5 && (wrap_angle(same.heading - dets[0].b.heading)).abs() < 1e-5);
        }

        /// Stateful NMS remembering the previous n − 1 slices is global NMS over the sweep in
        /// arrival order; when boxes arrive best first (no later box outscores an earlier one),
        /// it is exactly the global, score-ordered NMS.
        #[test]
        fn stateful_nms_with_k_n_minus_1_is_global_nms(
            raw in proptest::collection::vec((0.0f32..30.0, 0.0f32..3.0, 0usize..2, 0.2f32..1.0), 1..40),
            n in 1usize..6,
        ) {
            let c = cfg(1000);
            // Boxes spread over n slices by position, so neighbours often straddle a border.
            let slice_of = |x: f32| ((x / 30.0 * n as f32) as usize).min(n - 1);
            let mut slices = vec![Vec::new(); n];
            for &(x, y, class, score) in &raw {
                let mut d = det(x, class, score);
                d.b.y = y;
                slices[slice_of(x)].push(d);
            }
            let all: Vec<Detection> = slices.iter().flatten().copied().collect();
            proptest::prop_assert_eq!(
                sorted(stateful_all(&slices, n - 1, &c)),
                sorted(nms_in_arrival_order(&slices, &c))
            );
            // Rescore so every slice outscores the later ones: now it is the global NMS itself.
            let ranked: Vec<Vec<Detection>> = slices
                .iter()
                .enumerate()
                .map(|(s, v)| {
                    v.iter()
                        .map(|d| Detection { score: 1.0 - (s as f32 + 1.0 - d.score * 0.5) / n as f32 * 0.7, ..*d })
                        .collect()
                })
                .collect();
            let all_ranked: Vec<Detection> = ranked.iter().flatten().copied().collect();
            proptest::prop_assert_eq!(sorted(stateful_all(&ranked, n - 1, &c)), sorted(nms(&all_ranked, &c)));
            // Score precedence, checked against the definition of greedy NMS: an emitted box
            // overlaps no emitted box of its own or an earlier slice that outranks it (scores
            // higher, or ties and came first), and every dropped box overlaps one that does.
            let emitted: Vec<Vec<Detection>> = {
                let mut s = StatefulNms::new(n - 1, Precedence::Score);
                slices.iter().map(|d| s.step(d, &c)).collect()
            };
            for (s, slice) in slices.iter().enumerate() {
                let clash = |d: &Detection, e: &Detection| e.class == d.class && iou_3d(&e.b, &d.b) > c.per_class[0].iou;
                for d in slice.iter().filter(|d| d.score >= c.per_class[d.class].score) {
                    let mine = emitted[s].iter().position(|e| e == d);
                    let outranked = emitted[..s].iter().flatten().any(|e| e.score >= d.score && clash(d, e))
                        || emitted[s]
                            .iter()
                            .enumerate()
                            .any(|(j, e)| Some(j) != mine && (e.score > d.score || (e.score == d.score && Some(j) < mine)) && clash(d, e));
                    proptest::prop_assert_eq!(mine.is_some(), !outranked, "slice {} box {:?}", s, d);
                }
            }
            // Arriving best first, score precedence is the global NMS too.
            proptest::prop_assert_eq!(
                sorted({
                    let mut s = StatefulNms::new(n - 1, Precedence::Score);
                    ranked.iter().flat_map(|d| s.step(d, &c)).collect()
                }),
                sorted(nms(&all_ranked, &c))
            );
            // With one slice, all three are the same NMS.
            if n == 1 {
                proptest::prop_assert_eq!(sorted(stateful_all(&slices, 1, &c)), sorted(nms(&all, &c)));
            }
        }
    }
}
