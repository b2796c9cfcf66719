//! One frame of temporal seeding: frame t − 1's detections moved into frame t, snapped onto
//! candidate centers, leading FPS ([`SeededStep`]); and the centers a frame gets that way
//! ([`seeded_centers`], for `starnet render`).

use super::seeds::{PrevCenters, snap_seeds, temporal_seeds};
use super::sequence::Sequence;
use crate::Result;
use crate::detector::{Detector, frame_seed};
use starnet_data::geometry::Pose;
use starnet_data::kitti::Frame;
use starnet_data::sampling::{Centers, PreparedFrame, center_pool};
use starnet_model::nms::Detection;

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
pub(crate) struct SeededStep<'a> {
    detector: &'a Detector,
    /// At most this many seeds per frame.
    pub(crate) k: usize,
}

impl<'a> SeededStep<'a> {
    pub(crate) fn new(detector: &'a Detector, prev: PrevCenters) -> Self {
        let k = prev.of(detector.pipeline.num_centers);
        Self { detector, k }
    }

    /// Snaps the `moved` seeds onto the frame, samples centers from them and detects: the
    /// prepared frame and its detections (the next frame's seeds come from these).
    pub(crate) fn run(&self, frame: &Frame, moved: &[[f32; 3]], seed: u64) -> (PreparedFrame, Vec<Detection>) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::Budget;
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
