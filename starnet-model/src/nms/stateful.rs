//! Stateful NMS over the slices of a streaming sweep (the streaming paper, §3.3).

use super::{Continued, Detection, NmsConfig, Precedence, is_candidate, nms_after, voted};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// When stateful NMS emits a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Emission {
    /// Every box as soon as its slice is done (the paper): a box whose object runs on into
    /// the next slice is decided from this slice's view alone.
    #[default]
    Immediate,
    /// A box that the next slice's boxes could still overlap ([`StatefulNms::step_holding`]'s
    /// `settled` says which) waits for that slice and is decided with its candidates, as global
    /// NMS would decide it; the others at once. Costs the waiting boxes one slice of latency.
    Settled,
    /// Global NMS, streamed ([`super::DeferredNms`]): every candidate waits, however many slices it
    /// takes, until no later box can overlap the box NMS keeps for it; then that box is
    /// emitted, voted with its candidates, as global NMS over the sweep would. For centers that
    /// lag the laser ([`Self::Settled`] decides after one slice). Ignores the memory and the
    /// precedence.
    Deferred,
}

/// What stateful NMS remembers of one slice.
#[derive(Debug, Clone, Default)]
pub(super) struct SliceMemory {
    /// Its emitted boxes, and the earlier boxes that suppressed one of its candidates.
    pub(super) kept: Vec<Detection>,
    /// Its candidates above the score threshold (voters).
    candidates: Vec<Detection>,
}

/// NMS over the slices of a streaming sweep (the streaming paper, §3.3): a slice's boxes are
/// also suppressed by the boxes kept in the previous `k` slices (under a [`Precedence`]), and
/// vote with those slices' candidates. A remembered box that suppresses a new candidate is
/// remembered with the new slice too, so an object that spans more than k + 1 slices is still
/// reported once; [`Self::step_last`] also compares the sweep's last slice with its first, the
/// two sides of the seam where the sweep starts. [`Self::step_holding`] lets a box wait one
/// slice ([`Emission::Settled`]). `reset` starts a new sweep.
#[derive(Debug, Clone)]
pub struct StatefulNms {
    k: usize,
    precedence: Precedence,
    /// The last k slices, oldest first (the tests reach in to forget a kept box).
    pub(super) history: VecDeque<SliceMemory>,
    first: Option<SliceMemory>,
    /// The previous slice's candidates, while one of its boxes waits.
    pending: Vec<Detection>,
    seen: usize,
}

impl StatefulNms {
    /// Remembers the last `k` slices (the streaming paper uses k = 1); `k = 0` is NMS within
    /// each slice.
    pub fn new(k: usize, precedence: Precedence) -> Self {
        Self {
            k,
            precedence,
            history: VecDeque::new(),
            first: None,
            pending: Vec::new(),
            seen: 0,
        }
    }

    /// Forgets every previous slice.
    pub fn reset(&mut self) {
        self.history.clear();
        self.first = None;
        self.pending.clear();
        self.seen = 0;
    }

    /// Greedy NMS of a slice's `dets` continuing from the remembered slices ([`nms_after`]): a
    /// box is dropped when a newly kept box of its class, or a remembered one that takes
    /// precedence, overlaps it (a dropped box suppresses nothing). Returns the boxes to emit:
    /// all it keeps.
    pub fn step(&mut self, dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
        self.step_after(dets, cfg, None, &|_| true)
    }

    /// [`Self::step`], but a kept box that is not `settled` (the next slice's boxes could still
    /// overlap it) waits: the next call decides it again among that slice's candidates, and
    /// emits whatever it then keeps of this slice's. With `k = 0` nothing would suppress the
    /// waiting boxes' candidates once emitted, so every box is settled.
    pub fn step_holding(
        &mut self,
        dets: &[Detection],
        cfg: &NmsConfig,
        settled: &dyn Fn(&Detection) -> bool,
    ) -> Vec<Detection> {
        self.step_after(dets, cfg, None, settled)
    }

    /// [`Self::step`] for the sweep's last slice: it also continues from the sweep's first
    /// slice, across the seam where the sweep began, emits every box still waiting, then the
    /// sweep is forgotten.
    pub fn step_last(&mut self, dets: &[Detection], cfg: &NmsConfig) -> Vec<Detection> {
        // The first slice is still remembered when the sweep has at most k + 1 slices.
        let first = self.first.take().filter(|_| self.k > 0 && self.seen > self.k);
        let out = self.step_after(dets, cfg, first, &|_| true);
        self.reset();
        out
    }

    fn step_after(
        &mut self,
        dets: &[Detection],
        cfg: &NmsConfig,
        also: Option<SliceMemory>,
        settled: &dyn Fn(&Detection) -> bool,
    ) -> Vec<Detection> {
        let pending = std::mem::take(&mut self.pending);
        let remembered: Vec<Detection> = self
            .history
            .iter()
            .chain(&also)
            .flat_map(|m| m.kept.iter().copied())
            .collect();
        // Selection first, voting after, so that a box is recognised as the pending one it is.
        let mut select = cfg.clone();
        select.per_class.iter_mut().for_each(|c| c.vote_iou = None);
        let pool: Vec<Detection> = pending.iter().chain(dets).copied().collect();
        let Continued { kept, suppressors } = nms_after(&remembered, &pool, &select, self.precedence);
        let (emit, wait): (Vec<Detection>, Vec<Detection>) = kept
            .into_iter()
            .partition(|d| self.k == 0 || pending.contains(d) || settled(d));
        let candidates: Vec<Detection> = dets.iter().filter(|d| is_candidate(d, cfg)).copied().collect();
        // The pending candidates are the last remembered slice's: counted once.
        let skip_last = usize::from(!pending.is_empty());
        let voters: Vec<Detection> = self
            .history
            .iter()
            .rev()
            .skip(skip_last)
            .chain(&also)
            .flat_map(|m| m.candidates.iter().copied())
            .chain(pool.iter().filter(|d| is_candidate(d, cfg)).copied())
            .collect();
        let emitted: Vec<Detection> = emit.into_iter().map(|k| voted(k, &voters, cfg)).collect();
        if !wait.is_empty() {
            self.pending = candidates.clone();
        }
        self.remember(SliceMemory {
            kept: emitted
                .iter()
                .copied()
                .chain(still_seen(&remembered, &suppressors))
                .collect(),
            candidates,
        });
        emitted
    }

    fn remember(&mut self, memory: SliceMemory) {
        if self.seen == 0 {
            self.first = Some(memory.clone());
        }
        self.seen += 1;
        if self.k > 0 {
            self.history.push_back(memory);
            while self.history.len() > self.k {
                self.history.pop_front();
            }
        }
    }
}

/// The remembered boxes at `suppressors`, each once (a box remembered from two slices
/// suppresses as one).
fn still_seen(remembered: &[Detection], suppressors: &[usize]) -> Vec<Detection> {
    let mut out: Vec<Detection> = Vec::new();
    for &i in suppressors {
        if !out.contains(&remembered[i]) {
            out.push(remembered[i]);
        }
    }
    out
}
