//! `starnet eval --sequences`: sequences evaluated frame by frame with temporal seeding
//! (StarNet §4.4, table 4) over a grid of (N, K), its table and plot.

use super::split::eval_report;
use crate::Result;
use crate::budget::Budget;
use crate::detector::{Detector, frame_seed};
use crate::json::read_json;
use crate::render::{LinePlot, Series};
use crate::report::ReportFiles;
use crate::temporal::{PrevCenters, SeedStats, SeededStep, Sequence, seed_distances, temporal_seeds};
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::Pose;
use starnet_eval::EvalReport;
use starnet_eval::Scorer;
use starnet_eval::Table;
use starnet_model::nms::Detection;
use std::path::Path;
use std::time::Instant;

/// One (N, K) evaluation over the sequences.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TemporalReport {
    /// Centers per frame N.
    pub num_centers: usize,
    /// How K was asked for.
    pub prev: PrevCenters,
    /// K: at most this many centers are seeded from the previous frame's detections (a frame
    /// takes [`crate::temporal::SEEDS_PER_DETECTION`] per detection, up to K; [`SeedStats::per_frame`]
    /// is how many it took).
    pub prev_centers: usize,
    /// The evaluation (every frame of every sequence; the first frames have no seeds).
    pub report: EvalReport,
    /// Where the seeds landed.
    pub seeds: SeedStats,
}

/// Runs every sequence frame by frame: frame t's first centers are seeds from frame t − 1's
/// detections ([`temporal_seeds`]: up to K, a few per detection, best first) moved into frame t
/// (`Pose::between` the two poses) and snapped to the nearest candidate center within the
/// gathering radius ([`crate::temporal::snap_seeds`]), and FPS draws the rest up to `budget.num_centers` as it
/// would without seeds;
/// the first frame of a sequence has no seeds. Frame `i`
/// (counting through the sequences) samples from `frame_seed(seed, i)`, as
/// [`super::evaluate`] does, so K = 0 reproduces it. `detector` is at the budget N.
pub fn evaluate_sequences(
    detector: &Detector,
    seed: u64,
    sequences: &[Sequence],
    prev: PrevCenters,
) -> Result<TemporalReport> {
    let step = SeededStep::new(detector, prev);
    let budget = detector.budget();
    let labels = sequences
        .first()
        .map_or(starnet_data::kitti::LabelSource::Camera, |s| s.dataset.labels());
    let mut scorer = Scorer::new(&detector.classes, labels, None);
    let mut latencies = Vec::new();
    let (mut corrected, mut uncorrected, mut seeded_frames) = (Vec::new(), Vec::new(), 0);
    let mut i = 0;
    for seq in sequences {
        let mut previous: Vec<Detection> = Vec::new();
        for (t, id) in seq.dataset.ids().iter().enumerate() {
            let frame = seq.dataset.load(id)?;
            let start = Instant::now();
            let moved = match t {
                0 => Vec::new(),
                _ => temporal_seeds(&previous, step.k, &Pose::between(&seq.poses[t - 1], &seq.poses[t])),
            };
            let (prepared, detections) = step.run(&frame, &moved, frame_seed(seed, i));
            let ms = start.elapsed().as_secs_f64() * 1e3;
            if !moved.is_empty() {
                let objects: Vec<Box3d> = prepared
                    .boxes
                    .iter()
                    .zip(&prepared.classes)
                    .filter(|(_, c)| detector.classes.contains(c))
                    .map(|(b, _)| *b)
                    .collect();
                corrected.extend(seed_distances(&moved, &objects));
                let unmoved = temporal_seeds(&previous, step.k, &Pose::IDENTITY);
                uncorrected.extend(seed_distances(&unmoved, &objects));
            }
            seeded_frames += usize::from(t > 0);
            scorer.add(frame, &detections)?;
            previous = detections;
            latencies.push(ms);
            i += 1;
        }
    }
    Ok(TemporalReport {
        num_centers: budget.num_centers,
        prev,
        prev_centers: step.k,
        report: eval_report(detector, scorer.finish(), &latencies),
        seeds: SeedStats::of(&corrected, &uncorrected, seeded_frames),
    })
}

/// [`evaluate_sequences`] at every centers N (outermost) and K of `prev`, calling `on_report`
/// after each run; a K asked for twice at one N (`32` and `50%` of 64) is evaluated once and
/// reported under each name.
pub fn temporal_sweep(
    detector: &Detector,
    seed: u64,
    sequences: &[Sequence],
    centers: &[usize],
    prev: &[PrevCenters],
    on_report: &mut dyn FnMut(&TemporalReport),
) -> Result<Vec<TemporalReport>> {
    let mut reports: Vec<TemporalReport> = Vec::new();
    for &n in centers {
        let at_n = detector.at_budget(Budget {
            num_centers: n,
            ..detector.budget()
        });
        let first = reports.len();
        for &p in prev {
            let same = reports[first..].iter().find(|r| r.prev_centers == p.of(n)).cloned();
            let r = match same {
                Some(r) => TemporalReport { prev: p, ..r },
                None => {
                    let r = evaluate_sequences(&at_n, seed, sequences, p)?;
                    on_report(&r);
                    r
                }
            };
            reports.push(r);
        }
    }
    Ok(reports)
}

/// The markdown table: per (N, K) the headline AP, its change from K = 0 at the same N, and
/// where the seeds landed.
pub fn temporal_table(reports: &[TemporalReport]) -> String {
    let mut t = Table::new([
        "centers N",
        "from t − 1, at most K",
        "seeds per frame",
        "headline AP",
        "BEV AP",
        "Δ vs K = 0",
        "within 1 m of an object",
        "median distance m",
        "without pose correction m",
    ]);
    for (i, r) in reports.iter().enumerate() {
        // A run asked for twice (`32` and `50%` of 64) is listed once.
        if reports[..i]
            .iter()
            .any(|q| (q.num_centers, q.prev_centers) == (r.num_centers, r.prev_centers))
        {
            continue;
        }
        let base = reports
            .iter()
            .find(|b| b.num_centers == r.num_centers && b.prev_centers == 0)
            .map(|b| b.report.headline());
        let delta = base.map_or(String::new(), |b| format!("{:+.1}", r.report.headline() - b));
        let bev = r.report.scores.classes.first().map_or(0.0, |c| c.bev[1].r40);
        let mut cells = vec![
            r.num_centers.to_string(),
            r.prev_centers.to_string(),
            format!("{:.1}", r.seeds.per_frame()),
            format!("{:.1}", r.report.headline()),
            format!("{bev:.1}"),
            delta,
        ];
        if r.seeds.seeds > 0 {
            cells.extend([
                format!("{:.0} %", 100.0 * r.seeds.within_1m),
                format!("{:.2}", r.seeds.median_m),
                format!("{:.2}", r.seeds.uncorrected_median_m),
            ]);
        } else {
            cells.extend(vec![String::new(); 3]);
        }
        t.row(cells);
    }
    t.to_string()
}

/// Headline AP against total centers, one curve per way of choosing K.
pub fn temporal_plot(reports: &[TemporalReport]) -> LinePlot {
    let mut kinds: Vec<PrevCenters> = Vec::new();
    for r in reports {
        if !kinds.contains(&r.prev) {
            kinds.push(r.prev);
        }
    }
    let series = kinds
        .iter()
        .map(|&p| {
            let mut points: Vec<(f64, f64)> = reports
                .iter()
                .filter(|r| r.prev == p)
                .map(|r| (r.num_centers as f64, r.report.headline()))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let name = match p {
                PrevCenters::Count(0) | PrevCenters::Percent(0) => "FPS only".to_string(),
                p => format!("{p} from frame t − 1"),
            };
            Series { name, points }
        })
        .collect();
    LinePlot {
        title: "AP vs centers, with and without seeds from frame t − 1".into(),
        x_label: "centers per frame".into(),
        y_label: "headline AP (%)".into(),
        series,
        log_x: true,
        y_range: None,
    }
}

/// Writes `temporal.md`, `temporal.json` and `temporal_ap.png` into `out`.
pub fn write_temporal(out: &Path, reports: &[TemporalReport]) -> Result<()> {
    ReportFiles {
        stem: "temporal",
        table: temporal_table(reports),
        data: reports,
        plots: vec![("temporal_ap", temporal_plot(reports))],
    }
    .write(out)
}

/// Redraws `temporal.md` and `temporal_ap.png` from a folder's `temporal.json`.
pub fn replot_temporal(dir: &Path) -> Result<()> {
    write_temporal(dir, &read_json::<Vec<TemporalReport>>(&dir.join("temporal.json"))?)
}
