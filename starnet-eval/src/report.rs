//! A model's evaluation at one budget: what it cost (centers, points, GFLOP, latency) and what
//! it scored; `eval.json` holds it.

use crate::scorer::Scores;
use serde::{Deserialize, Serialize};
use starnet_data::sampling::{CenterTarget, CenterViews};

/// What an evaluation found: the budget and its cost, and the scores.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvalReport {
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Which sampled centers the model saw.
    pub target: CenterTarget,
    /// Which of them saw their neighbourhood in the mirror (reports older than it: `as_seen`).
    #[serde(default)]
    pub views: CenterViews,
    /// Forward GFLOP per frame at this budget.
    pub gflop_per_frame: f64,
    /// Mean wall time per frame (preparation, forward, decoding), ms.
    pub latency_ms_mean: f64,
    /// 95th percentile of the per-frame time, ms.
    pub latency_ms_p95: f64,
    /// The scores (`eval.json` holds their fields beside the budget's).
    #[serde(flatten)]
    pub scores: Scores,
}

impl EvalReport {
    /// The headline AP ([`Scores::headline`]).
    pub fn headline(&self) -> f64 {
        self.scores.headline()
    }
}

impl std::fmt::Display for EvalReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let target = match self.target {
            CenterTarget::All => String::new(),
            t => format!(" (target {t})"),
        };
        let views = match self.views {
            CenterViews::AsSeen => "",
            CenterViews::Alternate => ", every second center mirrored",
            CenterViews::Mirrored => ", every center mirrored",
        };
        writeln!(
            f,
            "{} frames, {} centers{target} x {} points ({:.2} GFLOP/frame{views}), latency {:.1} ms mean, {:.1} ms p95",
            self.scores.frames,
            self.num_centers,
            self.num_points,
            self.gflop_per_frame,
            self.latency_ms_mean,
            self.latency_ms_p95
        )?;
        write!(f, "{}", self.scores)
    }
}
