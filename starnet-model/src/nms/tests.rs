//! NMS, voting and stateful NMS against hand-built boxes and global NMS.

use super::*;
use starnet_data::Box3d;
use starnet_data::class::ObjectClass;
use starnet_data::geometry::{iou_3d, wrap_angle};
use std::f32::consts::PI;

/// The classes `det` and `cfg` number 0 and 1.
const CLASSES: [ObjectClass; 2] = [ObjectClass::Car, ObjectClass::Pedestrian];

fn det(x: f32, class: usize, score: f32) -> Detection {
    Detection {
        b: Box3d::new(x, 0.0, -1.0, 4.0, 1.6, 1.5, 0.0),
        class: CLASSES[class],
        score,
    }
}

fn cfg(max: usize) -> NmsConfig {
    NmsConfig {
        per_class: CLASSES
            .map(|class| ClassNms {
                class,
                iou: 0.1,
                score: 0.2,
                vote_iou: None,
            })
            .to_vec(),
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
        class: ObjectClass::Car,
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
    // k = 1, but the box suppressed something in the last slice, so it is still in view.
    assert!(s.step(&[det(0.4, 0, 0.95)], &c).is_empty());
    // A slice without it: then it is forgotten.
    assert_eq!(s.step(&[det(30.0, 0, 0.5)], &c).len(), 1);
    assert_eq!(s.step(&[det(0.2, 0, 0.95)], &c).len(), 1);
    s.reset();
    assert_eq!(s.step(&[det(0.2, 0, 0.95)], &c).len(), 1);
    // Other classes are not suppressed.
    assert_eq!(s.step(&[det(0.2, 1, 0.95)], &c).len(), 1);
}

#[test]
fn an_object_across_many_slices_is_reported_once() {
    let c = cfg(10);
    // An object seen by six slices of k = 1, each view of it a little further along: every
    // view overlaps the first (IoU 0.23 at the last) but not always the one it follows.
    let views: Vec<Detection> = (0..6).map(|s| det(s as f32 * 0.5, 0, 0.5 + 0.05 * s as f32)).collect();
    assert!(iou_3d(&views[0].b, &views[5].b) > 0.1);
    let mut s = StatefulNms::new(1, Precedence::Arrival);
    let emitted: Vec<Detection> = views.iter().flat_map(|v| s.step(&[*v], &c)).collect();
    assert_eq!(emitted, [views[0]]);
    // Without the refresh (memory of emitted boxes only), slice 2 would emit it again.
    let mut plain = StatefulNms::new(1, Precedence::Arrival);
    plain.step(&views[..1], &c);
    plain.step(&views[1..2], &c);
    plain.history.back_mut().expect("slice 1").kept.clear();
    assert_eq!(plain.step(&views[2..3], &c), [views[2]]);
}

#[test]
fn the_last_slice_meets_the_first_across_the_seam() {
    let c = cfg(10);
    let slices = [
        vec![det(0.0, 0, 0.9)],
        vec![det(20.0, 0, 0.8)],
        vec![det(40.0, 0, 0.7)],
        vec![det(0.5, 0, 0.6)],
    ];
    let run = |last: bool| {
        let mut s = StatefulNms::new(1, Precedence::Arrival);
        let mut out: Vec<Detection> = slices[..3].iter().flat_map(|d| s.step(d, &c)).collect();
        out.extend(if last {
            s.step_last(&slices[3], &c)
        } else {
            s.step(&slices[3], &c)
        });
        out.len()
    };
    assert_eq!(run(false), 4, "slice 3 does not remember slice 0");
    assert_eq!(run(true), 3, "across the seam it does");
    // The sweep is forgotten after its last slice.
    let mut s = StatefulNms::new(1, Precedence::Arrival);
    s.step_last(&slices[0], &c);
    assert_eq!(s.step(&slices[3], &c).len(), 1);
}

#[test]
fn stateful_nms_votes_with_the_remembered_candidates() {
    let mut c = cfg(10);
    c.per_class[0].vote_iou = Some(0.5);
    // Score precedence: slice 1's box outscores slice 0's and is emitted; both slices'
    // candidates vote, as they would in NMS over the two slices together.
    let slice0 = [det(0.0, 0, 0.3), det(0.4, 0, 0.25)];
    let slice1 = [det(0.8, 0, 0.9)];
    let mut s = StatefulNms::new(1, Precedence::Score);
    s.step(&slice0, &c);
    let got = s.step(&slice1, &c);
    let together: Vec<Detection> = slice0.iter().chain(&slice1).copied().collect();
    let want = vote(&slice1[0], &together, 0.5);
    assert_eq!(got.len(), 1);
    assert!(
        (got[0].b.x - want.x).abs() < 1e-6 && want.x < 0.8,
        "{} vs {}",
        got[0].b.x,
        want.x
    );
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

#[test]
fn a_box_the_next_slice_may_overlap_waits_for_it() {
    let c = cfg(10);
    let edge = det(0.0, 0, 0.5); // slice 0 sees the object's edge, near the border
    let whole = det(0.4, 0, 0.9); // slice 1 sees it whole
    let other = det(-20.0, 0, 0.6); // far from the border: settled
    // The edge box reaches the border; the whole view and the far box do not.
    let settled = |d: &Detection| d.b.x < -10.0 || d.b.x > 0.3;
    for precedence in [Precedence::Arrival, Precedence::Score] {
        let mut s = StatefulNms::new(1, precedence);
        assert_eq!(
            s.step_holding(&[edge, other], &c, &settled),
            [other],
            "the edge box waits"
        );
        // Decided with slice 1's candidates: the better view wins, as global NMS would have it.
        assert_eq!(s.step_holding(&[whole], &c, &settled), [whole]);
        assert!(s.step_holding(&[], &c, &settled).is_empty(), "nothing left waiting");
    }
    // A waiting box that nothing outscores is emitted with the next slice.
    let mut s = StatefulNms::new(1, Precedence::Score);
    assert!(s.step_holding(&[edge], &c, &|_| false).is_empty());
    assert_eq!(s.step_holding(&[det(30.0, 0, 0.4)], &c, &|_| false), [edge]);
    // Without memory nothing could suppress a waiting box's candidates later: no waiting.
    let mut s = StatefulNms::new(0, Precedence::Score);
    assert_eq!(s.step_holding(&[edge], &c, &|_| false), [edge]);
}

proptest::proptest! {
    /// Two slices whose boxes all wait: the second slice decides them together, which is
    /// global NMS over the sweep, votes included.
    #[test]
    fn waiting_for_the_last_slice_is_global_nms(
        raw in proptest::collection::vec((0.0f32..20.0, 0.0f32..3.0, 0usize..2, 0.2f32..1.0, proptest::bool::ANY), 1..30),
    ) {
        let mut c = cfg(1000);
        c.per_class[0].vote_iou = Some(0.3);
        let mut slices = [Vec::new(), Vec::new()];
        for &(x, y, class, score, second) in &raw {
            let mut d = det(x, class, score);
            d.b.y = y;
            slices[usize::from(second)].push(d);
        }
        let mut s = StatefulNms::new(1, Precedence::Score);
        let mut out = s.step_holding(&slices[0], &c, &|_| false);
        out.extend(s.step_last(&slices[1], &c));
        let all: Vec<Detection> = slices.iter().flatten().copied().collect();
        let (got, want) = (sorted(out), sorted(nms(&all, &c)));
        proptest::prop_assert_eq!(got.len(), want.len());
        for (a, b) in got.iter().zip(&want) {
            // Votes sum their voters in another order: equal up to rounding.
            let close = a.b.to_array().iter().zip(b.b.to_array()).all(|(p, q)| (p - q).abs() < 1e-4);
            proptest::prop_assert!(a.score == b.score && a.class == b.class && close, "{:?} vs {:?}", a, b);
        }
    }
}

/// Greedy NMS taking boxes slice by slice (each slice best score first): the oracle of
/// stateful NMS with memory of every earlier slice.
fn nms_in_arrival_order(slices: &[Vec<Detection>], cfg: &NmsConfig) -> Vec<Detection> {
    let mut kept: Vec<Detection> = Vec::new();
    for slice in slices {
        let mut order: Vec<&Detection> = slice
            .iter()
            .filter(|d| d.score >= cfg.of(d.class).unwrap().score)
            .collect();
        order.sort_by(|a, b| b.score.total_cmp(&a.score));
        for d in order {
            if kept
                .iter()
                .all(|k| k.class != d.class || iou_3d(&k.b, &d.b) <= cfg.of(d.class).unwrap().iou)
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
                class: ObjectClass::Car,
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
            for d in slice.iter().filter(|d| d.score >= c.of(d.class).unwrap().score) {
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
