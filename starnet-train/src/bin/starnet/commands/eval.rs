//! `starnet eval`: evaluate a checkpoint.

use crate::parse::{parse_class, parse_labels};
use anyhow::Context;
use clap::Args;
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_data::sampling::CenterTarget;
use starnet_eval::{ResultFormat, score_results, write_scores};
use starnet_train::budget::Budget;
use starnet_train::evaluate::{
    EvalOptions, RunEval, budget_grid, budget_table, evaluate_run, run_table, sweep, temporal_sweep, temporal_table,
    write_temporal,
};
use starnet_train::temporal::{PrevCenters, open_sequences};
use starnet_train::trained::TrainedModel;
use std::path::{Path, PathBuf};

/// Evaluate a checkpoint: KITTI AP (3D, BEV, 2D, AOS; R40 and R11) and Waymo-style AP/APH on
/// a split, KITTI result files, a JSON summary and per-frame latency, at one or more
/// center/point budgets. Or score any detector's result folder (--results) the same way.
#[derive(Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["checkpoint", "results", "run"])))]
pub struct Eval {
    /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
    #[arg(long)]
    checkpoint: Option<PathBuf>,
    /// Every kept step-* checkpoint of a run folder (runs/NAME), oldest first, at the config's
    /// budget (or one --centers/--points): their tables and eval.json files, and the run's
    /// run_eval.md, run_eval.json and run_eval_ap.png (AP against step) in --out (default
    /// RUN/eval-SPLIT).
    #[arg(long, conflicts_with_all = ["checkpoint", "config", "sequences"])]
    run: Option<PathBuf>,
    /// Score this folder of result files instead of a checkpoint (with --data): `{id}.txt` in
    /// KITTI's result format (camera frame) or `{id}.json` from `starnet detect` (LiDAR
    /// frame), one per frame of the split.
    #[arg(long, conflicts_with_all = ["checkpoint", "config", "centers", "points", "sets", "sequences"])]
    results: Option<PathBuf>,
    /// With --results: `kitti` or `detect` (default: whichever the split's first frame has).
    #[arg(long, requires = "results")]
    format: Option<ResultFormat>,
    /// With --results: the classes to score (default: Car, Pedestrian and Cyclist, those with
    /// a detection).
    #[arg(long, requires = "results", value_delimiter = ',', value_parser = parse_class)]
    classes: Vec<ObjectClass>,
    /// With --results: the labels to score against, `label_2` (camera view) or `label_360`
    /// (the simulator's all-around labels).
    #[arg(long, requires = "results", default_value = "label_2", value_parser = parse_labels)]
    labels: LabelSource,
    /// The run's config (default: the config.toml of the run holding the checkpoint).
    #[arg(long)]
    config: Option<PathBuf>,
    /// KITTI root (default: the config's data root; needed with --results).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Split to evaluate.
    #[arg(long, default_value = "val")]
    split: String,
    /// Centers per frame (a list sweeps budgets).
    #[arg(long, value_delimiter = ',')]
    centers: Vec<usize>,
    /// Points per center (a list sweeps budgets).
    #[arg(long, value_delimiter = ',')]
    points: Vec<usize>,
    /// Which sampled centers the model sees: `all`, or `nearest:N` (the N closest to the
    /// sensor; compare the AP per 10 m).
    #[arg(long, default_value = "all")]
    target: CenterTarget,
    /// Override a config key, e.g. --set nms.score=[0.1] (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Where to write, per budget, the result files and eval.json (in c{C}_p{P}/), and for a
    /// sweep budget.md, budget.json and the plots budget_gflop.png and budget_latency.png;
    /// with --sequences, temporal.md, temporal.json and temporal_ap.png; with --results,
    /// eval.json.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Evaluate the sequences under ROOT/sequences/ (from `starnet synth --sequences`) frame
    /// by frame, seeding each frame's centers with the previous frame's detections.
    #[arg(long)]
    sequences: bool,
    /// With --sequences: how many of the centers come from the previous frame's best
    /// detections, as counts (32) or shares (50%); a list evaluates each with each --centers.
    #[arg(long, value_delimiter = ',', default_value = "0")]
    prev_centers: Vec<PrevCenters>,
}

impl Eval {
    pub fn run(self) -> anyhow::Result<()> {
        match (&self.checkpoint, &self.results, &self.run) {
            (Some(checkpoint), _, _) => self.checkpoint(checkpoint),
            (None, Some(results), _) => self.results(results),
            (None, None, Some(run)) => self.run_folder(run),
            (None, None, None) => unreachable!("clap requires --checkpoint, --results or --run"),
        }
    }

    fn run_folder(&self, run: &Path) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.centers.len() <= 1 && self.points.len() <= 1,
            "--run evaluates each checkpoint at one budget: give at most one --centers and one --points"
        );
        let mut sets = self.sets.clone();
        sets.extend(self.centers.first().map(|c| format!("eval.num_centers={c}")));
        sets.extend(self.points.first().map(|p| format!("eval.num_points={p}")));
        let out = self
            .out
            .clone()
            .unwrap_or_else(|| run.join(format!("eval-{}", self.split)));
        let what = RunEval {
            split: &self.split,
            data: self.data.as_deref(),
            sets: &sets,
            out: &out,
        };
        let evals = evaluate_run(run, &what, &mut |e| {
            println!(
                "step {} ({}): headline AP {:.2}",
                e.step,
                e.checkpoint.display(),
                e.report.headline()
            );
        })?;
        print!("{}", run_table(&evals));
        println!("wrote {}", out.display());
        Ok(())
    }

    fn results(&self, results: &Path) -> anyhow::Result<()> {
        let root = self
            .data
            .as_deref()
            .context("--results needs --data ROOT (the KITTI root it scores against)")?;
        let ds = KittiDataset::open(root, Some(&self.split))?.with_labels(self.labels);
        let classes = (!self.classes.is_empty()).then_some(self.classes.as_slice());
        let scores = score_results(&ds, results, self.format, classes)?;
        println!("{} frames, results from {}", scores.frames, results.display());
        print!("{scores}");
        if let Some(out) = &self.out {
            write_scores(out, &scores)?;
            println!("wrote {}", out.join("eval.json").display());
        }
        Ok(())
    }

    fn checkpoint(&self, checkpoint: &Path) -> anyhow::Result<()> {
        let mut trained = TrainedModel::load(checkpoint, self.config.as_deref(), &self.sets)?;
        if let Some(d) = &self.data {
            trained.config.data.root = d.clone();
        }
        let cfg = &trained.config;
        let or = |v: &[usize], d: usize| if v.is_empty() { vec![d] } else { v.to_vec() };
        let centers = or(&self.centers, cfg.eval.num_centers);
        let points = or(&self.points, cfg.eval.num_points);
        anyhow::ensure!(
            centers.iter().chain(&points).all(|&n| n > 0),
            "--centers and --points need positive counts"
        );
        let detector = trained.detector();
        if self.sequences {
            let detector = detector.at_budget(Budget {
                num_centers: centers[0],
                num_points: points[0],
                target: self.target,
            });
            let seqs = open_sequences(&cfg.data.root, cfg)?;
            let reports = temporal_sweep(&detector, cfg.seed, &seqs, &centers, &self.prev_centers, &mut |r| {
                let (n, k, ap) = (r.num_centers, r.prev_centers, r.report.headline());
                println!("{n} centers, {k} from t - 1: headline AP {ap:.2}");
            })?;
            print!("{}", temporal_table(&reports));
            if let Some(out) = &self.out {
                write_temporal(out, &reports)?;
                println!("wrote {}", out.display());
            }
            return Ok(());
        }
        let ds = cfg.dataset(&self.split)?;
        let budgets = budget_grid(&centers, &points, self.target);
        let opts = EvalOptions::of(cfg);
        let reports = sweep(&detector, &ds, opts, &budgets, self.out.as_deref(), &mut |r| {
            println!("{r}")
        })?;
        if reports.len() > 1 {
            print!("{}", budget_table(&reports));
        }
        Ok(())
    }
}
