//! Anchor target assignment (StarNet §3.3, lingvo `Utils3D.AssignAnchors`), on the CPU side so
//! it runs in data-loader threads. Each anchor takes the ground-truth box it overlaps most (rotated
//! BEV IoU): foreground at IoU ≥ `fg_iou`, background below `bg_iou`, ignored in between. An
//! object that no anchor reached is then force-matched to its best anchor, if that IoU is above 0
//! and the anchor is not already foreground for another object.
//!
//! Objects of a target class's neighbour (Van for Car, Person_sitting for Pedestrian) are
//! background by default, as lingvo and OpenPCDet train (labels filtered to the target
//! classes); [`NeighbourRule::Ignored`] leaves the anchors on them out of the classification
//! loss instead, as the KITTI devkit neither counts nor misses them. DontCare regions carry no
//! 3D box and take no part, as in both.
//!
//! Weights follow the authors' normalisation: each anchor counts `1 / (C · max(1, n_fg))`, where
//! `n_fg` is the number of foreground anchors at its center, so every center weighs the same.

use crate::coder::{direction_bin, encode};
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::{PreparedBox, iou_bev_prepared, iou_bev_upper_bound};
use starnet_data::settings::{Checked, InvalidSetting, within};

/// Assignment thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AssignConfig {
    /// Foreground at IoU ≥ this (0.6).
    pub fg_iou: f32,
    /// Background at IoU < this (0.45); between the two, ignored.
    pub bg_iou: f32,
    /// Force-match objects that got no foreground anchor.
    pub force_match: bool,
    /// What the anchors on a neighbour class's objects learn: `background` (lingvo, OpenPCDet)
    /// or `ignored` (no classification weight, as the devkit scores them).
    pub neighbours: NeighbourRule,
}

/// What training makes of the objects of a target class's neighbour
/// ([`ObjectClass::neighbour`](starnet_data::kitti::ObjectClass::neighbour)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NeighbourRule {
    /// Background, like any other object not of a target class.
    Background,
    /// Neither foreground nor background: an anchor that is not foreground and overlaps a
    /// neighbour's box at IoU ≥ the lower of the two thresholds gets no classification weight.
    Ignored,
}

impl AssignConfig {
    /// Checks that both thresholds are IoUs, the foreground one above 0 (keys relative to the
    /// assignment table). The background threshold may exceed the foreground one: 1.0 makes
    /// every anchor that is not foreground background (no ignore band).
    pub fn validate(&self) -> Checked {
        if !(self.fg_iou > 0.0 && self.fg_iou <= 1.0) {
            return Err(InvalidSetting::new(
                "fg_iou",
                format!("{} is not an IoU in (0, 1]", self.fg_iou),
            ));
        }
        within("bg_iou", self.bg_iou as f64, 0.0, 1.0)
    }
}

impl Default for AssignConfig {
    /// The paper's thresholds: foreground ≥ 0.6, background < 0.45.
    fn default() -> Self {
        Self {
            fg_iou: 0.6,
            bg_iou: 0.45,
            force_match: true,
            neighbours: NeighbourRule::Background,
        }
    }
}

impl AssignConfig {
    /// The authors' KITTI car setting (lingvo `StarNetCarModel0701`): foreground ≥ 0.567 and no
    /// ignore band (bg ≥ fg), so every other anchor is trained as background and none is left
    /// free to fire.
    pub fn kitti_car() -> Self {
        Self {
            fg_iou: 0.567,
            bg_iou: 1.0,
            force_match: true,
            neighbours: NeighbourRule::Background,
        }
    }
}

/// Targets of the `C · A` anchors of one frame (center-major, like the anchors).
#[derive(Debug, Clone, PartialEq)]
pub struct AnchorTargets {
    /// Per anchor: the matched object's class index for foreground, `None` otherwise.
    pub class: Vec<Option<usize>>,
    /// Per anchor: the matched object, `None` if none.
    pub matched: Vec<Option<usize>>,
    /// Per anchor: classification weight (0 when ignored or at an invalid center).
    pub cls_weight: Vec<f32>,
    /// Per anchor: regression weight (foreground only).
    pub reg_weight: Vec<f32>,
    /// Per anchor: encoded residuals of the matched box (zeros elsewhere).
    pub residuals: Vec<[f32; 7]>,
    /// Per anchor: the matched box's direction bin ([`direction_bin`]; 0 elsewhere, where the
    /// regression weight is 0).
    pub direction: Vec<u8>,
}

impl AnchorTargets {
    /// Number of foreground anchors.
    pub fn num_foreground(&self) -> usize {
        self.class.iter().flatten().count()
    }
}

/// Assigns targets to `anchors` (`C · A` boxes, center-major, `a` per center) from objects
/// `boxes` with class indices `classes`. Anchors of centers with `valid[c] == false` get no weight.
pub fn assign_targets(
    anchors: &[Box3d],
    a: usize,
    valid: &[bool],
    boxes: &[Box3d],
    classes: &[usize],
    cfg: &AssignConfig,
) -> AnchorTargets {
    let n = anchors.len();
    let c_n = n / a.max(1);
    let BestOverlaps {
        per_anchor: best,
        per_object: best_anchor,
    } = best_overlaps(anchors, a, boxes, cfg.fg_iou.min(cfg.bg_iou));
    let mut matched: Vec<Option<usize>> = best.iter().map(|b| b.of.filter(|_| b.iou >= cfg.fg_iou)).collect();
    let mut ignored: Vec<bool> = best.iter().map(|b| b.iou >= cfg.bg_iou && b.iou < cfg.fg_iou).collect();
    if cfg.force_match {
        for (j, b) in best_anchor.iter().enumerate() {
            let has_fg = matched.contains(&Some(j));
            if let Some(i) = b.of
                && !has_fg
                && matched[i].is_none()
            {
                matched[i] = Some(j);
                ignored[i] = false;
            }
        }
    }
    let mut out = AnchorTargets {
        class: vec![None; n],
        matched: matched.clone(),
        cls_weight: vec![0.0; n],
        reg_weight: vec![0.0; n],
        residuals: vec![[0.0; 7]; n],
        direction: vec![0; n],
    };
    for c in 0..c_n {
        if !valid.get(c).copied().unwrap_or(true) {
            out.matched[c * a..(c + 1) * a].fill(None);
            continue;
        }
        let range = c * a..(c + 1) * a;
        let fg = matched[range.clone()].iter().flatten().count();
        let w = 1.0 / (c_n as f32 * fg.max(1) as f32);
        for i in range {
            if let Some(j) = matched[i] {
                out.class[i] = Some(classes[j]);
                out.reg_weight[i] = w;
                out.cls_weight[i] = w;
                out.residuals[i] = encode(&boxes[j], &anchors[i]);
                out.direction[i] = direction_bin(boxes[j].heading) as u8;
            } else if !ignored[i] {
                out.cls_weight[i] = w;
            }
        }
    }
    out
}

/// Takes the classification weight from every anchor of `targets` that is not foreground and
/// overlaps one of `neighbours` (boxes of a target class's neighbour) at IoU ≥ the lower of
/// `cfg`'s thresholds: [`NeighbourRule::Ignored`]. `anchors` as for [`assign_targets`].
pub fn ignore_neighbours(
    targets: &mut AnchorTargets,
    anchors: &[Box3d],
    a: usize,
    neighbours: &[Box3d],
    cfg: &AssignConfig,
) {
    if neighbours.is_empty() {
        return;
    }
    let floor = cfg.fg_iou.min(cfg.bg_iou);
    let best = best_overlaps(anchors, a, neighbours, floor);
    for (i, b) in best.per_anchor.iter().enumerate() {
        if b.iou >= floor && targets.class[i].is_none() {
            targets.cls_weight[i] = 0.0;
        }
    }
}

/// Each anchor's best object and each object's best anchor by rotated BEV IoU (the first on
/// ties; none where every IoU is 0). An anchor's is exact where it reaches the assignment's
/// `floor` (the lower of its two thresholds) and below `floor` otherwise: below both
/// thresholds, which object it is and how far below do not matter.
#[derive(Debug, Clone, PartialEq)]
struct BestOverlaps {
    per_anchor: Vec<Best>,
    per_object: Vec<Best>,
}

/// The best partner so far (an object of an anchor, or an anchor of an object) and its IoU.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Best {
    /// `None` while every IoU is 0.
    of: Option<usize>,
    iou: f32,
}

impl Best {
    const NONE: Self = Self { of: None, iou: 0.0 };

    /// Takes `of` when `iou` beats the best so far (strictly: the first wins ties).
    fn offer(&mut self, of: usize, iou: f32) {
        if iou > self.iou {
            *self = Self { of: Some(of), iou };
        }
    }
}

/// [`BestOverlaps`] of `anchors` (center-major, `a` per center) and `boxes`.
fn best_overlaps(anchors: &[Box3d], a: usize, boxes: &[Box3d], floor: f32) -> BestOverlaps {
    let a = a.max(1);
    let mut best = BestOverlaps {
        per_anchor: vec![Best::NONE; anchors.len()],
        per_object: vec![Best::NONE; boxes.len()],
    };
    // Corners and circles once per box, not once per pair: this loop is most of the loader's
    // assignment time. A pair of IoU 0 changes nothing (every comparison is strict), so a
    // center's anchors meet only the objects within their reach, and only then get corners.
    let prepared: Vec<PreparedBox> = boxes.iter().map(PreparedBox::new).collect();
    let mut near = Vec::with_capacity(boxes.len());
    for (g, group) in anchors.chunks(a).enumerate() {
        objects_within_reach(group, boxes, &mut near);
        if near.is_empty() {
            continue;
        }
        for (k, an) in group.iter().map(PreparedBox::new).enumerate() {
            let i = g * a + k;
            for &j in &near {
                // A pair whose bound is below the floor and no better than the object's best
                // so far changes neither: no clip for it (most pairs, once an object has met
                // its first well-placed anchor).
                let bound = iou_bev_upper_bound(&an, &prepared[j]);
                if bound < floor && bound <= best.per_object[j].iou {
                    continue;
                }
                let iou = iou_bev_prepared(&an, &prepared[j]);
                best.per_anchor[i].offer(j, iou);
                best.per_object[j].offer(i, iou);
            }
        }
    }
    best
}

/// Fills `near` with the objects whose footprint circle can touch the circle of some anchor in
/// `group`: within the group's reach (its anchors' centroid to the farthest anchor's circle)
/// plus the object's radius, with a millimetre to spare against rounding. The others have
/// IoU 0 with every anchor of the group.
fn objects_within_reach(group: &[Box3d], objects: &[Box3d], near: &mut Vec<usize>) {
    near.clear();
    let n = group.len().max(1) as f64;
    let cx = group.iter().map(|b| b.x as f64).sum::<f64>() / n;
    let cy = group.iter().map(|b| b.y as f64).sum::<f64>() / n;
    let dist = |b: &Box3d| (b.x as f64 - cx).hypot(b.y as f64 - cy);
    let reach = group
        .iter()
        .map(|b| dist(b) + b.bev_radius() as f64)
        .fold(0.0, f64::max);
    near.extend((0..objects.len()).filter(|&j| dist(&objects[j]) <= reach + objects[j].bev_radius() as f64 + 1e-3));
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::geometry::iou_bev;
    use starnet_data::sampling::AnchorGrid;

    /// The definition, every pair: the pruned [`best_overlaps`] must equal it exactly.
    fn best_overlaps_of_every_pair(anchors: &[Box3d], boxes: &[Box3d]) -> BestOverlaps {
        let mut best = BestOverlaps {
            per_anchor: vec![Best::NONE; anchors.len()],
            per_object: vec![Best::NONE; boxes.len()],
        };
        for (i, an) in anchors.iter().enumerate() {
            for (j, b) in boxes.iter().enumerate() {
                let iou = iou_bev(an, b);
                best.per_anchor[i].offer(j, iou);
                best.per_object[j].offer(i, iou);
            }
        }
        best
    }

    #[test]
    fn pruned_overlaps_decide_as_those_of_every_pair() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for grid in [AnchorGrid::kitti_car(), AnchorGrid::kitti_pedestrian()] {
            // Centers and objects in a 20 m square: some far apart, some overlapping.
            let mut xy = || [rng.random_range(0.0..20.0), rng.random_range(0.0..20.0)];
            let centers: Vec<[f32; 3]> = (0..40)
                .map(|_| {
                    let [x, y] = xy();
                    [x, y, -1.0]
                })
                .collect();
            let boxes: Vec<Box3d> = (0..12)
                .map(|k| {
                    let [x, y] = xy();
                    Box3d::new(
                        x,
                        y,
                        -1.0,
                        0.5 + 0.4 * k as f32,
                        0.5 + 0.15 * k as f32,
                        1.5,
                        0.5 * k as f32,
                    )
                })
                .collect();
            let an: Vec<Box3d> = centers.iter().flat_map(|c| grid.anchors_around(*c)).collect();
            let every = best_overlaps_of_every_pair(&an, &boxes);
            assert!(
                every.per_anchor.iter().filter(|m| m.of.is_some()).count() > 50,
                "overlaps exist"
            );
            // Floor 0: nothing may be skipped but pairs of IoU 0, and the result is exact.
            assert_eq!(best_overlaps(&an, grid.len(), &boxes, 0.0), every);
            for floor in [0.45, 0.567] {
                let pruned = best_overlaps(&an, grid.len(), &boxes, floor);
                assert_eq!(pruned.per_object, every.per_object, "floor {floor}");
                for (i, (p, e)) in pruned.per_anchor.iter().zip(&every.per_anchor).enumerate() {
                    match e.iou >= floor {
                        true => assert_eq!(p, e, "anchor {i}"),
                        false => assert!(p.iou < floor && p.iou <= e.iou, "anchor {i}: {p:?} for {e:?}"),
                    }
                }
                assert!(
                    pruned.per_anchor.iter().zip(&every.per_anchor).any(|(p, e)| p != e),
                    "floor {floor} prunes something"
                );
            }
        }
    }

    fn anchors(centers: &[[f32; 3]]) -> (Vec<Box3d>, usize) {
        let g = AnchorGrid::kitti_car();
        (centers.iter().flat_map(|c| g.anchors_around(*c)).collect(), g.len())
    }

    #[test]
    fn foreground_background_and_the_ignore_band() {
        let (an, a) = anchors(&[[10.0, 0.0, 0.0]]);
        // An object equal to the centre anchor (index 48): IoU 1 there.
        let car = an[48];
        let t = assign_targets(&an, a, &[true], &[car], &[0], &AssignConfig::default());
        assert_eq!(t.class[48], Some(0));
        assert!(t.residuals[48].iter().all(|r| r.abs() < 1e-6));
        // Heading 0 lies in direction bin 1; unmatched anchors carry 0.
        assert_eq!(car.heading, 0.0);
        assert_eq!(t.direction[48], 1);
        assert!((0..an.len()).all(|i| t.class[i] == Some(0) || t.direction[i] == 0));
        for (i, anchor) in an.iter().enumerate() {
            let iou = iou_bev(anchor, &car);
            match t.class[i] {
                Some(0) => assert!(iou >= 0.6, "{i}: fg at {iou}"),
                _ if iou >= 0.45 => assert_eq!(t.cls_weight[i], 0.0, "{i}: IoU {iou} is in the ignore band"),
                _ => assert!(t.cls_weight[i] > 0.0, "{i}: background at {iou}"),
            }
        }
        // Weights: 1 / (C · n_fg).
        let fg = t.num_foreground();
        assert!((t.reg_weight[48] - 1.0 / fg as f32).abs() < 1e-7);
    }

    #[test]
    fn force_matching_fires_only_under_both_conditions() {
        let (an, a) = anchors(&[[10.0, 0.0, 0.0]]);
        // A small, shifted object: best IoU well below 0.6 but above 0.
        let ped = Box3d::new(11.3, 0.4, -1.0, 0.8, 0.6, 1.7, 0.3);
        let (best_i, best_iou) = (0..a)
            .map(|i| (i, iou_bev(&an[i], &ped)))
            .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
        assert!(best_iou > 0.0 && best_iou < 0.45);
        let t = assign_targets(&an, a, &[true], &[ped], &[0], &AssignConfig::default());
        assert_eq!(
            (t.num_foreground(), t.class[best_i]),
            (1, Some(0)),
            "forced onto its best anchor"
        );
        let off = AssignConfig {
            force_match: false,
            ..Default::default()
        };
        assert_eq!(assign_targets(&an, a, &[true], &[ped], &[0], &off).num_foreground(), 0);
        // Condition 2: the best anchor is already foreground for another object.
        let car = an[best_i];
        let t = assign_targets(&an, a, &[true], &[car, ped], &[0, 1], &AssignConfig::default());
        assert_eq!(t.matched[best_i], Some(0), "the car keeps its anchor");
        assert!(!t.matched.contains(&Some(1)), "the pedestrian stays unmatched");
    }

    #[test]
    fn without_an_ignore_band_every_anchor_is_trained() {
        let (an, a) = anchors(&[[10.0, 0.0, 0.0]]);
        let t = assign_targets(&an, a, &[true], &[an[48]], &[0], &AssignConfig::kitti_car());
        assert!(t.cls_weight.iter().all(|w| *w > 0.0));
    }

    #[test]
    fn an_object_far_from_every_anchor_stays_unmatched() {
        let (an, a) = anchors(&[[10.0, 0.0, 0.0], [20.0, 0.0, 0.0]]);
        let far = Box3d::new(50.0, 30.0, -1.0, 3.9, 1.6, 1.5, 0.0);
        let t = assign_targets(&an, a, &[true, true], &[far], &[0], &AssignConfig::default());
        assert_eq!(t.num_foreground(), 0);
        assert!(
            t.cls_weight.iter().all(|w| (*w - 1.0 / 2.0).abs() < 1e-7),
            "all background, 1/(C·1) each"
        );
    }

    #[test]
    fn invalid_centers_carry_no_weight() {
        let (an, a) = anchors(&[[10.0, 0.0, 0.0], [10.0, 0.0, 0.0]]);
        let t = assign_targets(&an, a, &[true, false], &[an[48]], &[0], &AssignConfig::default());
        assert!(t.cls_weight[a..].iter().all(|w| *w == 0.0) && t.class[a..].iter().all(Option::is_none));
        assert!(t.class[48] == Some(0));
    }

    #[test]
    fn ignoring_a_neighbour_zeroes_only_its_background_anchors() {
        // Two centers: a car on the first's centre anchor, a van on the second's.
        let (an, a) = anchors(&[[10.0, 0.0, 0.0], [30.0, 0.0, 0.0]]);
        let (car, van) = (an[48], an[a + 48]);
        for cfg in [AssignConfig::default(), AssignConfig::kitti_car()] {
            let plain = assign_targets(&an, a, &[true, true], &[car], &[0], &cfg);
            let mut t = plain.clone();
            ignore_neighbours(&mut t, &an, a, &[van], &cfg);
            let floor = cfg.fg_iou.min(cfg.bg_iou);
            for (i, anchor) in an.iter().enumerate() {
                let on_van = iou_bev(anchor, &van) >= floor;
                let want = if on_van { 0.0 } else { plain.cls_weight[i] };
                assert_eq!(
                    t.cls_weight[i],
                    want,
                    "anchor {i}, IoU with the van {}",
                    iou_bev(anchor, &van)
                );
            }
            assert!(
                t.cls_weight[a + 48] == 0.0 && plain.cls_weight[a + 48] > 0.0,
                "background before, ignored after"
            );
            assert_eq!(
                (t.class, t.reg_weight),
                (plain.class, plain.reg_weight),
                "the car's targets untouched"
            );
        }
        // A foreground anchor keeps its weight when a neighbour overlaps it too.
        let mut t = assign_targets(&an, a, &[true, true], &[car], &[0], &AssignConfig::default());
        let w = t.cls_weight[48];
        ignore_neighbours(&mut t, &an, a, &[car], &AssignConfig::default());
        assert_eq!(t.cls_weight[48], w);
    }
}
