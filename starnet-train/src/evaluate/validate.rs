//! A training run's validation: the split or the streamed evaluation, whichever the config trains.

use super::split::{EvalOptions, evaluate};
use super::streams::{StreamGroundTruth, evaluate_stream};
use crate::Result;
use crate::budget::Budget;
use crate::config::ExperimentConfig;
use crate::detector::Detector;
use crate::stream::{NmsMode, StreamModel};
use starnet_data::events::note;
use starnet_data::kitti::KittiDataset;
use starnet_eval::EvalReport;
use starnet_model::nn::StarNet;
use std::path::Path;

/// The validation of a run: [`evaluate`] at the config's budget, or for a streaming config
/// (sliced training or an LSTM) the streamed evaluation at `stream.eval_slices` with stateful
/// NMS (which writes no result files).
pub fn validate(
    model: &StarNet,
    cfg: &ExperimentConfig,
    val: &KittiDataset,
    results: Option<&Path>,
) -> Result<EvalReport> {
    if !cfg.stream.enabled() && cfg.model.lstm_hidden == 0 {
        return evaluate(&Detector::new(model.clone(), cfg), val, EvalOptions::of(cfg), results);
    }
    let gt = StreamGroundTruth::read(cfg.stream.eval_range, val, None)?;
    let streamed = StreamModel::new(String::new(), model.clone(), cfg, Budget::of(cfg));
    let report = evaluate_stream(&streamed, val, &gt, cfg.stream.eval_slices)?;
    note(report.to_string());
    Ok(report.eval_report(NmsMode::Stateful))
}
