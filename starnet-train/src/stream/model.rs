//! [`StreamModel`]: a model to stream, with its per-sweep budget and its run's streaming settings.

use crate::budget::Budget;
use crate::config::{ExperimentConfig, StreamSection};
use crate::detector::Detector;
use starnet_model::nn::StarNet;

/// A model to stream: a name, its detector at the per-sweep budget, and its run's streaming
/// settings and seed.
#[derive(Debug, Clone)]
pub struct StreamModel {
    /// Its name in tables (e.g. the run folder).
    pub label: String,
    /// The model with its anchors, classes, NMS and per-sweep budget.
    pub detector: Detector,
    /// Slicing, stateful NMS, evaluation range and scan rate.
    pub stream: StreamSection,
    /// The experiment seed.
    pub seed: u64,
}

impl StreamModel {
    /// `model`, trained with `cfg`, at `budget` per sweep.
    pub fn new(label: String, model: StarNet, cfg: &ExperimentConfig, budget: Budget) -> Self {
        Self {
            label,
            detector: Detector::new(model, cfg).at_budget(budget),
            stream: cfg.stream.clone(),
            seed: cfg.seed,
        }
    }
}
