//! Sequence evaluation with temporal seeding, its table and plot.

use super::seeds::{PrevCenters, SeedStats, seed_distances, snap_seeds, temporal_seeds};
use super::sequence::Sequence;
use crate::Result;
use crate::budget::Budget;
use crate::detector::Detector;
use crate::evaluate::{eval_report, frame_seed};
use crate::render::{LinePlot, Series};
use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::Pose;
use starnet_data::io::atomic_write;
use starnet_data::kitti::Frame;
use starnet_data::sampling::{Centers, PreparedFrame, center_pool};
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
    /// takes [`super::SEEDS_PER_DETECTION`] per detection, up to K; [`SeedStats::per_frame`]
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
/// gathering radius ([`snap_seeds`]), and FPS draws the rest up to `budget.num_centers` as it
/// would without seeds;
/// the first frame of a sequence has no seeds. Frame `i`
/// (counting through the sequences) samples from `frame_seed(seed, i)`, as
/// [`crate::evaluate::evaluate`] does, so K = 0 reproduces it. `detector` is at the budget N.
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

/// The centers frame `t` of `seq` gets at `detector`'s budget with `prev` from frame t − 1:
/// frame t − 1 is detected with plain FPS (as the first frame of a run would be), its seeds
/// moved and snapped into frame t, and frame t's centers sampled from them
/// (`Centers::num_seeded` lead). Frame `t` samples from `frame_seed(seed, t)`.
pub fn seeded_centers(detector: &Detector, seed: u64, seq: &Sequence, t: usize, prev: PrevCenters) -> Result<Centers> {
    let step = SeededStep::new(detector, prev);
    let ids = seq.dataset.ids();
    let moved = if t == 0 {
        Vec::new()
    } else {
        let before = seq.dataset.load(&ids[t - 1])?;
        let (_, detections) = step.run(&before, &[], frame_seed(seed, t - 1));
        temporal_seeds(&detections, step.k, &Pose::between(&seq.poses[t - 1], &seq.poses[t]))
    };
    let frame = seq.dataset.load(&ids[t])?;
    Ok(step.run(&frame, &moved, frame_seed(seed, t)).0.centers)
}

/// One frame of a seeded run: settings resolved once.
struct SeededStep<'a> {
    detector: &'a Detector,
    /// At most this many seeds per frame.
    k: usize,
}

impl<'a> SeededStep<'a> {
    fn new(detector: &'a Detector, prev: PrevCenters) -> Self {
        let k = prev.of(detector.pipeline.num_centers);
        Self { detector, k }
    }

    /// Snaps the `moved` seeds onto the frame, samples centers from them and detects: the
    /// prepared frame and its detections (the next frame's seeds come from these).
    fn run(&self, frame: &Frame, moved: &[[f32; 3]], seed: u64) -> (PreparedFrame, Vec<Detection>) {
        let pipeline = &self.detector.pipeline;
        let seeds = if moved.is_empty() {
            Vec::new()
        } else {
            let ground = pipeline.fit_ground(&frame.points);
            let pool = center_pool(
                &frame.points,
                &pipeline.pool,
                Some((&frame.calib, frame.image_size)),
                ground.as_ref(),
            );
            snap_seeds(moved, &frame.points, &pool, pipeline.gather.radius)
        };
        let prepared = self.detector.prepare(frame, &seeds, seed);
        let detections = self.detector.detect_prepared(&[&prepared]).swap_remove(0);
        (prepared, detections)
    }
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
    atomic_write(&out.join("temporal.md"), temporal_table(reports).as_bytes())?;
    let json = serde_json::to_string_pretty(reports).expect("reports serialise");
    atomic_write(&out.join("temporal.json"), json.as_bytes())?;
    temporal_plot(reports)
        .render()?
        .save_png(&out.join("temporal_ap.png"))?;
    Ok(())
}

/// Redraws `temporal.md` and `temporal_ap.png` from a folder's `temporal.json`.
pub fn replot_temporal(dir: &Path) -> Result<()> {
    write_temporal(
        dir,
        &crate::json::read_json::<Vec<TemporalReport>>(&dir.join("temporal.json"))?,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ExperimentConfig;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use starnet_data::kitti::Calib;
    use starnet_data::sampling::prepare_frame;
    use starnet_model::batch::decode_frame;
    use starnet_model::batch::make_input;
    use starnet_sim::{SynthConfig, simulate_scene_frame};

    fn frame() -> Frame {
        let calib = Calib::kitti_000000();
        simulate_scene_frame(3, 0, &SynthConfig::default(), &calib).into_frame("000000", calib)
    }

    fn setup() -> (ExperimentConfig, Detector, Budget) {
        let mut cfg = ExperimentConfig::default();
        cfg.model.blocks = vec![[16, 8]];
        cfg.model.d_fc0 = 8;
        cfg.model.d_offset = 8;
        // Keep every box, so comparing detections is not vacuous.
        cfg.nms.score = vec![0.0];
        let model = cfg.model_config().init(&starnet_model::backend::default_device());
        let budget = Budget {
            num_centers: 24,
            num_points: 16,
            target: starnet_data::sampling::CenterTarget::All,
        };
        let detector = Detector::new(model, &cfg).at_budget(budget);
        (cfg, detector, budget)
    }

    #[test]
    fn without_seeds_a_step_is_plain_fps_evaluation() {
        let (cfg, detector, budget) = setup();
        let f = frame();
        let (prepared, dets) = SeededStep::new(&detector, PrevCenters::Count(0)).run(&f, &[], 9);
        // What `evaluate` does with frame seed 9.
        let pipeline = budget.pipeline(&cfg.pipeline);
        let plain = prepare_frame(&f, &pipeline, None, &[], &mut ChaCha8Rng::seed_from_u64(9));
        let out = detector
            .model
            .forward(make_input(&[&plain], &starnet_model::backend::default_device()));
        let expected = decode_frame(&out, 0, &plain, &cfg.model.anchors, &cfg.nms_config());
        assert_eq!(prepared.centers, plain.centers);
        assert!(!expected.is_empty());
        assert_eq!(dets, expected);
        // 0 % is K = 0 too.
        let pct = SeededStep::new(&detector, PrevCenters::Percent(0)).run(&f, &[], 9);
        assert_eq!(pct.1, expected);
    }

    #[test]
    fn seeds_lead_the_centers_snapped_onto_candidate_points() {
        let (cfg, detector, _) = setup();
        let f = frame();
        let step = SeededStep::new(&detector, PrevCenters::Count(3));
        // Three positions in front of the sensor, and one far from any point (kept as is).
        let moved = [[12.0, 1.0, -1.0], [20.0, -4.0, -1.0], [35.0, 6.0, -1.0]];
        let (prepared, _) = step.run(&f, &moved, 4);
        let c = &prepared.centers;
        assert_eq!((c.len(), c.num_seeded), (24, 3));
        let pool = center_pool(&f.points, &cfg.pipeline.pool, Some((&f.calib, f.image_size)), None);
        let snapped = snap_seeds(&moved, &f.points, &pool, cfg.pipeline.gather.radius);
        for (center, (s, m)) in c.xyz.iter().zip(snapped.iter().zip(&moved)) {
            assert_eq!([center[0], center[1]], [s[0], s[1]]);
            assert_eq!(center[2], 0.0, "centers take z = 0 as configured");
            let d = (s[0] - m[0]).hypot(s[1] - m[1]);
            assert!(d <= cfg.pipeline.gather.radius);
            // A snapped seed is a pool point, and no pool point is closer to the seed.
            if d > 0.0 {
                assert!(pool.iter().any(|&i| f.points[i][0] == s[0] && f.points[i][1] == s[1]));
                assert!(
                    pool.iter()
                        .all(|&i| (f.points[i][0] - m[0]).hypot(f.points[i][1] - m[1]) >= d)
                );
            }
        }
    }
}
