//! `starnet coverage`: how many objects the sampled centers can reach, per sampler and count.

use crate::Result;
use crate::render::{LinePlot, Series};
use starnet_data::events::note;
use starnet_data::kitti::{KittiDataset, ObjectClass};
use starnet_data::sampling::{CenterPoolConfig, CoverageConfig, CoverageTable, Sampler, coverage};
use std::path::Path;

/// The paper's figure-5 measurement of `classes`: objects with at least 5 points, covered at BEV
/// IoU > 0.5, centers drawn in the camera's view (all around the sensor within 80 m when
/// `all_around`).
pub fn paper_coverage(
    samples: &[usize],
    samplers: &[Sampler],
    classes: &[ObjectClass],
    all_around: bool,
) -> CoverageConfig {
    CoverageConfig {
        samples: samples.to_vec(),
        samplers: samplers.to_vec(),
        pool: if all_around {
            CenterPoolConfig::all_around(80.0)
        } else {
            CenterPoolConfig::kitti()
        },
        ground: None,
        min_points: 5,
        iou: 0.5,
        classes: classes.to_vec(),
    }
}

/// Measures coverage on `data` (optionally one split), reports the table and writes a PNG plot.
pub fn run_coverage(
    data: &Path,
    split: Option<&str>,
    cfg: &CoverageConfig,
    plot: &Path,
    seed: u64,
) -> Result<CoverageTable> {
    let ds = KittiDataset::open(data, split)?;
    let samples = &cfg.samples;
    let table = coverage(&ds, cfg, seed)?;
    let text = table.to_string();
    note(text.strip_suffix('\n').unwrap_or(&text));
    let chart = LinePlot {
        title: format!("Object coverage, {} objects with ≥ 5 points", table.objects),
        x_label: "centers per frame".into(),
        y_label: "% of objects with an anchor at BEV IoU > 0.5".into(),
        series: table
            .rows
            .iter()
            .map(|(s, v)| Series {
                name: s.label().into(),
                points: samples.iter().map(|&n| n as f64).zip(v.iter().copied()).collect(),
            })
            .collect(),
        log_x: true,
        y_range: Some((0.0, 100.0)),
    };
    chart.render()?.save_png(plot)?;
    note(format!("wrote {}", plot.display()));
    Ok(table)
}
