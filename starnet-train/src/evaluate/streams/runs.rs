//! [`stream_runs`]: several models streamed at several slice counts ([`StreamRun`]), what
//! `starnet stream-eval` tabulates and plots.

use super::ground_truth::StreamGroundTruth;
use super::split::{StreamReport, evaluate_stream};
use crate::Result;
use crate::stream::StreamModel;
use serde::{Deserialize, Serialize};
use starnet_data::kitti::{KittiDataset, ObjectClass};

/// One model's reports, one per slice count (ascending; the first at n = 1).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StreamRun {
    /// A name for the model (its run folder).
    pub label: String,
    /// Classes, in the model's order.
    pub classes: Vec<ObjectClass>,
    /// LiDAR rotation rate, Hz.
    pub scan_hz: f64,
    /// Per slice count.
    pub reports: Vec<StreamReport>,
}

/// Streams every model over `gt`'s sweeps at each of `slices` (n = 1, the whole-sweep
/// reference, is added first when absent), calling `on_report` after each.
pub fn stream_runs(
    models: &[StreamModel],
    dataset: &KittiDataset,
    gt: &StreamGroundTruth,
    slices: &[usize],
    on_report: &mut dyn FnMut(&str, &StreamReport),
) -> Result<Vec<StreamRun>> {
    let mut ns: Vec<usize> = slices.to_vec();
    ns.push(1);
    ns.sort_unstable();
    ns.dedup();
    models
        .iter()
        .map(|m| {
            let reports = ns
                .iter()
                .map(|&n| {
                    let r = evaluate_stream(m, dataset, gt, n)?;
                    on_report(&m.label, &r);
                    Ok(r)
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(StreamRun {
                label: m.label.clone(),
                classes: m.detector.classes.clone(),
                scan_hz: m.stream.scan_hz,
                reports,
            })
        })
        .collect()
}
