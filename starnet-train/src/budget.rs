//! [`Budget`]: the compute a frame gets — centers sampled, points per center, and which of the
//! sampled centers the model sees. One trained model runs at many budgets (StarNet's figure 7).

use crate::config::ExperimentConfig;
use serde::{Deserialize, Serialize};
use starnet_data::sampling::{CenterTarget, GatherConfig, PipelineConfig};

/// How much compute a frame gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Budget {
    /// Centers sampled per frame.
    pub num_centers: usize,
    /// Points per center.
    pub num_points: usize,
    /// Which sampled centers the model sees.
    pub target: CenterTarget,
}

impl Budget {
    /// The config's evaluation budget.
    pub fn of(cfg: &ExperimentConfig) -> Self {
        Self {
            num_centers: cfg.eval.num_centers,
            num_points: cfg.eval.num_points,
            target: CenterTarget::All,
        }
    }

    /// Centers the model sees.
    pub fn model_centers(&self) -> usize {
        self.target.count(self.num_centers)
    }

    /// `base` (the pool, sampler, center z, radius and metric) at this budget.
    pub fn pipeline(&self, base: &PipelineConfig) -> PipelineConfig {
        PipelineConfig {
            num_centers: self.num_centers,
            target: self.target,
            gather: GatherConfig {
                num_points: self.num_points,
                ..base.gather
            },
            ..base.clone()
        }
    }
}
