//! `starnet eval --run RUN`: every kept `step-*` checkpoint of a run, oldest first, at one
//! budget (OpenPCDet's `--eval_all`): per checkpoint its result files and `eval.json` in
//! `out/step-NNNNNNNN/`, and for the run `run_eval.md`, `run_eval.json` and `run_eval_ap.png`
//! (AP against training step).

use super::split::{EvalOptions, evaluate};
use crate::checkpoint::{StepCheckpoint, step_checkpoints};
use crate::json::write_json;
use crate::render::{LinePlot, Series};
use crate::report::ReportFiles;
use crate::trained::TrainedModel;
use crate::{Result, TrainError};
use serde::{Deserialize, Serialize};
use starnet_eval::{EvalReport, Table};
use std::path::{Path, PathBuf};

/// One checkpoint's evaluation.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CheckpointEval {
    /// The steps it had trained.
    pub step: u64,
    /// Its folder.
    pub checkpoint: PathBuf,
    /// Its scores at the budget.
    pub report: EvalReport,
}

/// What to evaluate a run's checkpoints on.
#[derive(Debug, Clone)]
pub struct RunEval<'a> {
    /// The split.
    pub split: &'a str,
    /// The dataset root, when not the run config's.
    pub data: Option<&'a Path>,
    /// Config overrides (`--set`), e.g. the budget.
    pub sets: &'a [String],
    /// Where to write.
    pub out: &'a Path,
}

/// The kept checkpoints of `run`, oldest first; none is an error naming the folder.
pub fn run_checkpoints(run: &Path) -> Result<Vec<StepCheckpoint>> {
    let dir = run.join("checkpoints");
    let found = step_checkpoints(&dir);
    if found.is_empty() {
        return Err(TrainError::NoInput {
            dir,
            what: "step-* checkpoint".into(),
        });
    }
    Ok(found)
}

/// Evaluates every kept checkpoint of `run` as `what` says, calling `on_eval` after each, and
/// writes the run's table, JSON and plot into `what.out`.
pub fn evaluate_run(
    run: &Path,
    what: &RunEval,
    on_eval: &mut dyn FnMut(&CheckpointEval),
) -> Result<Vec<CheckpointEval>> {
    let mut all = Vec::new();
    for c in run_checkpoints(run)? {
        let mut trained = TrainedModel::load(&c.path, None, what.sets)?;
        if let Some(d) = what.data {
            trained.config.data.root = d.to_path_buf();
        }
        let cfg = &trained.config;
        let dir = what.out.join(format!("step-{:08}", c.step));
        let report = evaluate(
            &trained.detector(),
            &cfg.dataset(what.split)?,
            EvalOptions::of(cfg),
            Some(&dir),
        )?;
        write_json(&dir.join("eval.json"), &report)?;
        let eval = CheckpointEval {
            step: c.step,
            checkpoint: c.path,
            report,
        };
        on_eval(&eval);
        all.push(eval);
    }
    write_run_eval(what.out, &all)?;
    Ok(all)
}

/// The run's table: step, then the headline APs (KITTI's where the labels are the camera's;
/// Waymo-style LEVEL_1 always).
pub fn run_table(evals: &[CheckpointEval]) -> String {
    let kitti = evals
        .first()
        .and_then(|e| e.report.scores.classes.first())
        .map(|c| c.class);
    let mut header = vec!["step".to_string()];
    if let Some(class) = kitti {
        header.extend([format!("{class} 3D R40 mod"), "BEV R40 mod".into()]);
    }
    header.extend(["LEVEL_1 AP".into(), "LEVEL_1 APH".into()]);
    let mut t = Table::new(header);
    for e in evals {
        let mut cells = vec![e.step.to_string()];
        if let Some(c) = kitti.and(e.report.scores.classes.first()) {
            cells.extend([format!("{:.2}", c.three_d[1].r40), format!("{:.2}", c.bev[1].r40)]);
        }
        let waymo = e.report.scores.waymo.first().map(|w| w.levels[0]).unwrap_or_default();
        cells.extend([format!("{:.2}", waymo.ap), format!("{:.2}", waymo.aph)]);
        t.row(cells);
    }
    t.to_string()
}

/// AP against training step: the headline AP ([`starnet_eval::Scores::headline`]) and the
/// Waymo-style LEVEL_1 AP of the first class.
pub fn run_plot(evals: &[CheckpointEval]) -> LinePlot {
    let curve = |name: &str, ap: &dyn Fn(&EvalReport) -> f64| Series {
        name: name.into(),
        points: evals.iter().map(|e| (e.step as f64, ap(&e.report))).collect(),
    };
    let kitti = evals.iter().any(|e| !e.report.scores.classes.is_empty());
    let mut series = Vec::new();
    if kitti {
        series.push(curve("KITTI 3D AP R40 moderate", &|r| r.headline()));
    }
    series.push(curve("LEVEL_1 3D AP", &|r| {
        r.scores.waymo.first().map_or(0.0, |w| w.levels[0].ap)
    }));
    LinePlot {
        title: "AP of each kept checkpoint".into(),
        x_label: "training step".into(),
        y_label: "AP (%)".into(),
        series,
        log_x: false,
        y_range: None,
    }
}

/// Writes `run_eval.md`, `run_eval.json` and `run_eval_ap.png` into `out`.
pub fn write_run_eval(out: &Path, evals: &[CheckpointEval]) -> Result<()> {
    ReportFiles {
        stem: "run_eval",
        table: run_table(evals),
        data: evals,
        plots: vec![("run_eval_ap", run_plot(evals))],
    }
    .write(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_without_checkpoints_is_named() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("checkpoints/best")).unwrap();
        let msg = run_checkpoints(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("checkpoints") && msg.contains("step-"), "{msg}");
        for s in [20, 3, 100] {
            std::fs::create_dir_all(dir.path().join(format!("checkpoints/step-{s:08}"))).unwrap();
        }
        let steps: Vec<u64> = run_checkpoints(dir.path()).unwrap().iter().map(|c| c.step).collect();
        assert_eq!(steps, [3, 20, 100]);
    }
}
