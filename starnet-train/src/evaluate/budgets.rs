//! `starnet eval`: one checkpoint over a grid of center/point budgets (StarNet's figure 7: one
//! model, many compute costs). Each budget gets its KITTI result files and `eval.json`; the
//! sweep gets a table (`budget.md`, `budget.json`) and two plots: AP against GFLOP per frame with
//! one curve per points value (`budget_gflop.png`) and AP against latency (`budget_latency.png`).

use super::split::{EvalOptions, evaluate};
use crate::Result;
use crate::budget::Budget;
use crate::detector::Detector;
use crate::json::{read_json, write_json};
use crate::render::{LinePlot, Series};
use crate::report::ReportFiles;
use starnet_data::kitti::KittiDataset;
use starnet_data::sampling::CenterTarget;
use starnet_eval::EvalReport;
use starnet_eval::Table;
use std::path::Path;

/// The budgets of a sweep: every (centers, points) pair, centers outermost.
pub fn budget_grid(centers: &[usize], points: &[usize], target: CenterTarget) -> Vec<Budget> {
    centers
        .iter()
        .flat_map(|&num_centers| {
            points.iter().map(move |&num_points| Budget {
                num_centers,
                num_points,
                target,
            })
        })
        .collect()
}

/// The folder name of a budget's outputs: `c256_p32`, or `c256_p32_nearest128`.
pub fn budget_dir_name(b: &Budget) -> String {
    match b.target {
        CenterTarget::All => format!("c{}_p{}", b.num_centers, b.num_points),
        CenterTarget::Nearest(n) => format!("c{}_p{}_nearest{n}", b.num_centers, b.num_points),
    }
}

/// Evaluates `detector` at every budget, calling `on_report` after each; with `out`, writes
/// each budget's results into `out/{budget_dir_name}/` and, for more than one budget, the
/// sweep's table and plots into `out/`.
pub fn sweep(
    detector: &Detector,
    dataset: &KittiDataset,
    opts: EvalOptions,
    budgets: &[Budget],
    out: Option<&Path>,
    on_report: &mut dyn FnMut(&EvalReport),
) -> Result<Vec<EvalReport>> {
    let mut reports = Vec::with_capacity(budgets.len());
    for b in budgets {
        let dir = out.map(|o| o.join(budget_dir_name(b)));
        let report = evaluate(&detector.at_budget(*b), dataset, opts, dir.as_deref())?;
        if let Some(d) = &dir {
            write_json(&d.join("eval.json"), &report)?;
        }
        on_report(&report);
        reports.push(report);
    }
    if let (Some(o), true) = (out, reports.len() > 1) {
        write_sweep(o, &reports)?;
    }
    Ok(reports)
}

/// The sweep as a Markdown table: budget, GFLOP, latency and the headline APs (KITTI's where the
/// labels are the camera's; Waymo-style LEVEL_1 always).
pub fn budget_table(reports: &[EvalReport]) -> String {
    let kitti = reports.first().and_then(|r| r.scores.classes.first()).map(|c| c.class);
    let mut header = vec![
        "centers".to_string(),
        "points".into(),
        "GFLOP / frame".into(),
        "latency mean (ms)".into(),
        "p95 (ms)".into(),
    ];
    if let Some(class) = kitti {
        header.extend([format!("{class} 3D R40 mod"), "BEV R40 mod".into()]);
    }
    header.extend(["LEVEL_1 AP".into(), "LEVEL_1 APH".into()]);
    let mut t = Table::new(header);
    for r in reports {
        let centers = match r.target {
            CenterTarget::All => r.num_centers.to_string(),
            t => format!("{} ({t})", r.num_centers),
        };
        let mut cells = vec![
            centers,
            r.num_points.to_string(),
            format!("{:.2}", r.gflop_per_frame),
            format!("{:.1}", r.latency_ms_mean),
            format!("{:.1}", r.latency_ms_p95),
        ];
        if kitti.is_some() {
            let (three_d, bev) = r
                .scores
                .classes
                .first()
                .map_or((0.0, 0.0), |c| (c.three_d[1].r40, c.bev[1].r40));
            cells.extend([format!("{three_d:.2}"), format!("{bev:.2}")]);
        }
        let waymo = r.scores.waymo.first().map(|w| w.levels[0]).unwrap_or_default();
        cells.extend([format!("{:.2}", waymo.ap), format!("{:.2}", waymo.aph)]);
        t.row(cells);
    }
    t.to_string()
}

/// The two sweep plots: AP against GFLOP per frame (one curve per points value, by centers) and
/// AP against mean latency.
pub fn budget_plots(reports: &[EvalReport]) -> [LinePlot; 2] {
    let mut points: Vec<usize> = reports.iter().map(|r| r.num_points).collect();
    points.sort_unstable();
    points.dedup();
    // `Scores::headline`: KITTI 3D AP R40 moderate, or LEVEL_1 AP where the labels are all around.
    let ap = |r: &EvalReport| r.scores.headline();
    let curve = |p: usize, x: &dyn Fn(&EvalReport) -> f64| {
        let mut pts: Vec<(f64, f64)> = reports
            .iter()
            .filter(|r| r.num_points == p)
            .map(|r| (x(r), ap(r)))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        Series {
            name: format!("{p} points"),
            points: pts,
        }
    };
    let y_label = if reports.iter().any(|r| !r.scores.classes.is_empty()) {
        "3D AP R40 moderate (%)"
    } else {
        "LEVEL_1 3D AP (%)"
    }
    .to_string();
    let gflop = LinePlot {
        title: "AP vs compute: one checkpoint, centers varied along each curve".into(),
        x_label: "GFLOP per frame".into(),
        y_label: y_label.clone(),
        series: points.iter().map(|&p| curve(p, &|r| r.gflop_per_frame)).collect(),
        log_x: true,
        y_range: None,
    };
    let latency = LinePlot {
        title: "AP vs latency (prepare + forward + decode, mean per frame)".into(),
        x_label: "ms per frame".into(),
        y_label,
        series: points.iter().map(|&p| curve(p, &|r| r.latency_ms_mean)).collect(),
        log_x: true,
        y_range: None,
    };
    [gflop, latency]
}

/// Writes `budget.md`, `budget.json`, `budget_gflop.png` and `budget_latency.png` into `out`.
pub fn write_sweep(out: &Path, reports: &[EvalReport]) -> Result<()> {
    let [gflop, latency] = budget_plots(reports);
    ReportFiles {
        stem: "budget",
        table: budget_table(reports),
        data: reports,
        plots: vec![("budget_gflop", gflop), ("budget_latency", latency)],
    }
    .write(out)
}

/// Redraws a sweep's table and plots from its `budget.json` (e.g. after a plotting change).
pub fn replot_sweep(dir: &Path) -> Result<()> {
    write_sweep(dir, &read_json::<Vec<EvalReport>>(&dir.join("budget.json"))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_centers_major_and_names_are_unique() {
        let grid = budget_grid(&[64, 128], &[16, 32], CenterTarget::All);
        let names: Vec<String> = grid.iter().map(budget_dir_name).collect();
        assert_eq!(names, ["c64_p16", "c64_p32", "c128_p16", "c128_p32"]);
        let near = budget_grid(&[256], &[32], CenterTarget::Nearest(64));
        assert_eq!(budget_dir_name(&near[0]), "c256_p32_nearest64");
        assert_eq!(near[0].model_centers(), 64);
    }
}
