//! Per-class greedy NMS with oriented 3D IoU (lingvo `NonMaxSuppression3D`), its continuation
//! against boxes already kept, and box voting.

use super::Detection;
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::class::ObjectClass;
use starnet_data::geometry::{iou_3d, wrap_angle};
use std::f32::consts::PI;

/// Thresholds of one class.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassNms {
    /// The class these thresholds are for.
    pub class: ObjectClass,
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
    /// Per class, in the order of the model's class scores (a box of a class without an entry
    /// is dropped).
    pub per_class: Vec<ClassNms>,
    /// At most this many boxes are kept, best scores first (512).
    pub max_boxes: usize,
}

impl NmsConfig {
    /// The thresholds of `class`, if it has any.
    pub fn of(&self, class: ObjectClass) -> Option<&ClassNms> {
        self.per_class.iter().find(|c| c.class == class)
    }
}

/// Greedy per-class NMS: boxes are taken best score first (ties by input order) and kept unless
/// a kept box of the same class overlaps them above the class's IoU threshold. Output sorted by
/// descending score, at most `max_boxes`.
pub fn nms(dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
    nms_after(&[], dets, cfg, Precedence::Arrival).kept
}

/// What [`nms_after`] decided.
#[derive(Debug, Clone, PartialEq)]
pub struct Continued {
    /// The new boxes kept, best score first, at most `max_boxes`.
    pub kept: Vec<Detection>,
    /// Indices into `earlier` of the boxes that suppressed a new candidate: objects still in
    /// view.
    pub suppressors: Vec<usize>,
}

/// [`nms`] continuing from boxes emitted earlier: `earlier` suppress like kept boxes but are
/// not returned (nor counted against `max_boxes`). With [`Precedence::Arrival`] an earlier box
/// suppresses every overlapping new box; with [`Precedence::Score`] only those it outscores
/// (ties go to the earlier box). Kept boxes vote with this call's candidates.
pub fn nms_after(earlier: &[Detection], dets: &[Detection], cfg: &NmsConfig, precedence: Precedence) -> Continued {
    let mut order: Vec<usize> = (0..dets.len()).filter(|&i| is_candidate(&dets[i], cfg)).collect();
    order.sort_by(|&i, &j| dets[j].score.total_cmp(&dets[i].score).then(i.cmp(&j)));
    let mut kept: Vec<Detection> = Vec::new();
    let mut suppressors = Vec::new();
    for &i in &order {
        if kept.len() == cfg.max_boxes {
            break;
        }
        let d = dets[i];
        let thr = cfg.of(d.class).map_or(f32::INFINITY, |c| c.iou);
        let clash = |k: &Detection| k.class == d.class && iou_3d(&k.b, &d.b) > thr;
        let outranks = |e: &Detection| precedence == Precedence::Arrival || e.score >= d.score;
        let before = suppressors.len();
        suppressors.extend((0..earlier.len()).filter(|&e| outranks(&earlier[e]) && clash(&earlier[e])));
        if suppressors.len() == before && !kept.iter().any(clash) {
            kept.push(d);
        }
    }
    suppressors.sort_unstable();
    suppressors.dedup();
    // Voting reads the selected boxes, so it runs after every suppression decision is made.
    let voters: Vec<Detection> = order.iter().map(|&i| dets[i]).collect();
    let kept = kept.into_iter().map(|k| voted(k, &voters, cfg)).collect();
    Continued { kept, suppressors }
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

/// Whether `d` is of a configured class and scores at least its threshold.
pub(crate) fn is_candidate(d: &Detection, cfg: &NmsConfig) -> bool {
    cfg.of(d.class).is_some_and(|c| d.score >= c.score)
}

/// `kept` after box voting with `voters` ([`vote`]), when its class votes.
pub(crate) fn voted(mut kept: Detection, voters: &[Detection], cfg: &NmsConfig) -> Detection {
    if let Some(min_iou) = cfg.of(kept.class).and_then(|c| c.vote_iou) {
        let same_class: Vec<Detection> = voters.iter().copied().filter(|d| d.class == kept.class).collect();
        kept.b = vote(&kept, &same_class, min_iou);
    }
    kept
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
