//! [`DeferredNms`]: global NMS over a streamed sweep, each box emitted as soon as nothing still
//! to come can change it.

use super::{Detection, NmsConfig, Precedence, is_candidate, nms_after, voted};
use starnet_data::geometry::iou_3d;

/// Global NMS, streamed. Each step's candidates join those still undecided, which fall into
/// groups that could overlap one another, directly or through a chain; a group whose every
/// member is `settled` (no later step's box can overlap it) is decided by greedy NMS over its
/// members and its boxes emitted, voted with its members. The rest wait. While `settled` is
/// right, the sweep's boxes are those of NMS over the whole sweep at once (a group never
/// crosses another's boxes, so greedy NMS and voting read the same candidates); a candidate
/// that overlaps a box already emitted anyway is dropped, so nothing is reported twice.
#[derive(Debug, Clone, Default)]
pub struct DeferredNms {
    /// Candidates not yet decided.
    waiting: Vec<Detection>,
    /// The boxes emitted this sweep (before voting).
    emitted: Vec<Detection>,
}

impl DeferredNms {
    /// Nothing seen yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one step's boxes and returns those now decided: the boxes NMS keeps in each group
    /// of undecided candidates that could overlap one another (chained) whose every member is
    /// `settled`. Greedy NMS decides such a group from its own members alone, and no later box
    /// can join it, so its boxes are final.
    pub fn step(
        &mut self,
        dets: &[Detection],
        cfg: &NmsConfig,
        settled: &dyn Fn(&Detection) -> bool,
    ) -> Vec<Detection> {
        let clash = |a: &Detection, b: &Detection| {
            a.class == b.class && cfg.of(a.class).is_some_and(|c| iou_3d(&a.b, &b.b) > c.iou)
        };
        let emitted = &self.emitted;
        let fresh = dets
            .iter()
            .filter(|d| is_candidate(d, cfg) && !emitted.iter().any(|e| clash(e, d)));
        self.waiting.extend(fresh);
        let group = groups(&self.waiting);
        let mut open = vec![false; self.waiting.len()];
        for (d, &g) in self.waiting.iter().zip(&group) {
            open[g] |= !settled(d);
        }
        let (mut decided, mut waiting) = (Vec::new(), Vec::new());
        for (d, g) in self.waiting.drain(..).zip(group) {
            if open[g] { &mut waiting } else { &mut decided }.push(d);
        }
        self.waiting = waiting;
        // Selection first, voting after, as global NMS.
        let mut select = cfg.clone();
        select.per_class.iter_mut().for_each(|c| c.vote_iou = None);
        let kept = nms_after(&[], &decided, &select, Precedence::Arrival).kept;
        self.emitted.extend(&kept);
        kept.into_iter().map(|k| voted(k, &decided, cfg)).collect()
    }

    /// The sweep's last step: every box still waiting is decided, then the sweep is forgotten.
    pub fn finish(&mut self, dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
        let out = self.step(dets, cfg, &|_| true);
        self.waiting.clear();
        self.emitted.clear();
        out
    }
}

/// Each detection's group: the root of its connected component when two detections are
/// linked whose bird's-eye circumcircles overlap (a superset of the pairs that can overlap in
/// 3D, whatever the class).
fn groups(dets: &[Detection]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..dets.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let radius = |d: &Detection| 0.5 * d.b.dx.hypot(d.b.dy);
    for i in 0..dets.len() {
        for j in i + 1..dets.len() {
            let (a, b) = (&dets[i], &dets[j]);
            if (a.b.x - b.b.x).hypot(a.b.y - b.b.y) < radius(a) + radius(b) {
                let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
                parent[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    (0..dets.len()).map(|i| root(&mut parent, i)).collect()
}

#[cfg(test)]
mod tests {
    use super::super::{ClassNms, nms};
    use super::*;
    use starnet_data::Box3d;
    use starnet_data::class::ObjectClass;

    fn det(x: f32, score: f32) -> Detection {
        Detection {
            b: Box3d::new(x, 0.0, 0.0, 4.0, 2.0, 1.5, 0.0),
            class: ObjectClass::Car,
            score,
        }
    }

    fn cfg() -> NmsConfig {
        NmsConfig {
            per_class: vec![ClassNms {
                class: ObjectClass::Car,
                iou: 0.1,
                score: 0.05,
                vote_iou: Some(0.3),
            }],
            max_boxes: 100,
        }
    }

    #[test]
    fn streamed_it_is_global_nms_when_settled_is_right() {
        // Three objects at x = 0, 10, 20, each seen by candidates over three steps; a box is
        // settled once the step that covers x + 6 has been seen (step s covers x < 10 s + 5).
        let steps = [
            vec![det(0.0, 0.5), det(0.6, 0.4), det(9.5, 0.3)],
            vec![det(0.3, 0.7), det(10.2, 0.6), det(19.0, 0.2)],
            vec![det(10.0, 0.4), det(20.3, 0.9), det(20.9, 0.1)],
        ];
        let mut d = DeferredNms::new();
        let mut out = Vec::new();
        for (s, dets) in steps.iter().enumerate() {
            let settled = |b: &Detection| b.b.x + 6.0 < 10.0 * s as f32 + 5.0;
            out.extend(if s + 1 == steps.len() {
                d.finish(dets, &cfg())
            } else {
                d.step(dets, &cfg(), &settled)
            });
        }
        let all: Vec<Detection> = steps.concat();
        let mut global = nms(&all, &cfg());
        let key = |d: &Detection| (d.b.x * 1e4) as i64;
        out.sort_by_key(key);
        global.sort_by_key(key);
        assert_eq!(out.len(), 3);
        assert_eq!(out, global);
    }

    #[test]
    fn a_late_box_over_an_emitted_one_is_not_reported_twice() {
        let mut d = DeferredNms::new();
        let first = d.step(&[det(0.0, 0.5)], &cfg(), &|_| true);
        assert_eq!(first.len(), 1);
        // A wrong `settled`: a better box over it arrives later; it is dropped.
        let later = d.finish(&[det(0.4, 0.9), det(30.0, 0.8)], &cfg());
        assert_eq!(later.len(), 1);
        assert_eq!(later[0].b.x, 30.0);
    }

    #[test]
    fn a_settled_box_waits_for_the_chain_that_could_still_unseat_it() {
        // b (x = 0) is settled and kept now: a (x = 3.5, 0.8) suppresses c (x = 1.8, 0.6),
        // which would otherwise suppress b. A later f (x = 5.0, 0.9) suppresses a, so c returns
        // and b goes: global NMS keeps f and c. b must not be emitted before f is seen.
        let (b, c, a, f) = (det(0.0, 0.5), det(1.8, 0.6), det(3.5, 0.8), det(5.0, 0.9));
        let cfg = NmsConfig {
            per_class: vec![ClassNms {
                class: ObjectClass::Car,
                iou: 0.25,
                score: 0.05,
                vote_iou: None,
            }],
            max_boxes: 100,
        };
        let mut d = DeferredNms::new();
        let first = d.step(&[b, c, a], &cfg, &|x| x.b.x < 1.0);
        assert!(first.is_empty(), "{first:?}");
        let mut all = d.finish(&[f], &cfg);
        let mut global = nms(&[b, c, a, f], &cfg);
        all.sort_by(|p, q| p.b.x.total_cmp(&q.b.x));
        global.sort_by(|p, q| p.b.x.total_cmp(&q.b.x));
        assert_eq!(all, global);
        assert_eq!(all.iter().map(|d| d.b.x).collect::<Vec<_>>(), [1.8, 5.0]);
    }
}
