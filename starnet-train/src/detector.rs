//! [`Detector`]: a trained StarNet with everything inference needs — the anchor grid its outputs
//! are laid out on, its classes, the center sampling and gathering at a [`Budget`], the views its
//! centers take ([`CenterViews`]), and the final NMS — so detecting is one call and needs no TOML
//! file. Every command that runs a model (`eval`, `detect`, sequence and streaming evaluation)
//! goes through it.
//!
//! A custom inference loop over a KITTI split (`no_run`: it needs a trained run):
//!
//! ```no_run
//! use starnet_data::kitti::KittiDataset;
//! use starnet_train::detector::Detector;
//! use std::path::Path;
//!
//! let detector = Detector::load(Path::new("runs/quickstart/checkpoints/best"))?;
//! let val = KittiDataset::open(Path::new("data/sim"), Some("val"))?;
//! for (i, id) in val.ids().iter().enumerate() {
//!     let frame = val.load(id)?;
//!     for d in detector.detect(&frame, i as u64) {
//!         println!("{id} {} {:.2} {:?}", d.class, d.score, d.b.to_array());
//!     }
//! }
//! # Ok::<(), starnet_train::TrainError>(())
//! ```

use crate::budget::Budget;
use crate::config::ExperimentConfig;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use starnet_data::kitti::{Frame, ObjectClass};
use starnet_data::sampling::{AnchorGrid, CenterViews, PipelineConfig, PreparedFrame, prepare_frame};
use starnet_data::seed::sub_seed;
use starnet_model::batch::{decode_viewed_detections, make_viewed_input};
use starnet_model::flops::forward_gflop;
use starnet_model::nms::{Detection, NmsConfig, nms};
use starnet_model::nn::{ModelInput, ModelOutput, SliceState, StarNet, StarNetConfig};

/// A streamed slice's boxes before NMS and the LSTM state the next slice starts from.
pub struct SliceDetections {
    /// Every box above its class's score threshold, in anchor order.
    pub raw: Vec<Detection>,
    /// The state after this slice (`None` without an LSTM).
    pub state: Option<SliceState>,
}

/// A model in validation mode with its anchors, classes, pipeline and NMS.
#[derive(Debug, Clone)]
pub struct Detector {
    /// The network.
    pub model: StarNet,
    /// Its architecture (FLOP counts).
    pub network: StarNetConfig,
    /// The anchor grid the model's outputs are laid out on.
    pub anchors: AnchorGrid,
    /// The class of each class index the model scores.
    pub classes: Vec<ObjectClass>,
    /// Center sampling and gathering, at this detector's budget.
    pub pipeline: PipelineConfig,
    /// Which centers see their neighbourhood in the mirror (their boxes mirrored back).
    pub views: CenterViews,
    /// Score thresholds and NMS of the final boxes.
    pub nms: NmsConfig,
}

impl Detector {
    /// `model`, trained with `cfg`, at `cfg`'s evaluation budget.
    pub fn new(model: StarNet, cfg: &ExperimentConfig) -> Self {
        Self {
            model,
            network: cfg.model_config(),
            anchors: cfg.model.anchors.clone(),
            classes: cfg.data.classes.clone(),
            pipeline: Budget::of(cfg).pipeline(&cfg.pipeline),
            views: cfg.eval.views,
            nms: cfg.nms_config(),
        }
    }

    /// This detector at another budget (the same weights: StarNet's one model, many costs).
    pub fn at_budget(&self, budget: Budget) -> Self {
        Self {
            pipeline: budget.pipeline(&self.pipeline),
            ..self.clone()
        }
    }

    /// Its budget.
    pub fn budget(&self) -> Budget {
        Budget {
            num_centers: self.pipeline.num_centers,
            num_points: self.pipeline.gather.num_points,
            target: self.pipeline.target,
        }
    }

    /// Forward GFLOP per frame at its budget.
    pub fn gflop_per_frame(&self) -> f64 {
        let b = self.budget();
        forward_gflop(&self.network, b.model_centers(), b.num_points)
    }

    /// Samples `frame`'s centers (after the given `seeds`, which lead) and gathers their
    /// neighbourhoods; `seed` seeds the sampler.
    pub fn prepare(&self, frame: &Frame, seeds: &[[f32; 3]], seed: u64) -> PreparedFrame {
        prepare_frame(frame, &self.pipeline, None, seeds, &mut ChaCha8Rng::seed_from_u64(seed))
    }

    /// The network on prepared frames, one batch, each center seen as [`Self::views`] says.
    ///
    /// # Shapes
    /// - output: cls_logits `[B, C, A, K]`, box_residuals `[B, C, A, 7]`
    pub fn forward(&self, frames: &[&PreparedFrame]) -> ModelOutput {
        self.model.forward(self.input(frames))
    }

    /// The model input of prepared frames under [`Self::views`].
    fn input(&self, frames: &[&PreparedFrame]) -> ModelInput {
        make_viewed_input(frames, self.views, &starnet_model::backend::default_device())
    }

    /// Frame `i` of [`Self::forward`]'s `out` decoded: every box above `thresholds`' score
    /// thresholds, before NMS, in `frame`'s LiDAR frame whatever view its center took.
    pub fn raw_detections(
        &self,
        out: &ModelOutput,
        i: usize,
        frame: &PreparedFrame,
        thresholds: &NmsConfig,
    ) -> Vec<Detection> {
        decode_viewed_detections(out, i, frame, &self.anchors, thresholds, self.views)
    }

    /// The final boxes of prepared frames, best first per frame.
    pub fn detect_prepared(&self, frames: &[&PreparedFrame]) -> Vec<Vec<Detection>> {
        let out = self.forward(frames);
        frames
            .iter()
            .enumerate()
            .map(|(i, f)| nms(&self.raw_detections(&out, i, f, &self.nms), &self.nms))
            .collect()
    }

    /// The final boxes of one frame (LiDAR frame, best first); `seed` seeds the center sampler.
    pub fn detect(&self, frame: &Frame, seed: u64) -> Vec<Detection> {
        self.detect_batch(&[frame], &[seed]).swap_remove(0)
    }

    /// The final boxes of frames run as one batch, frame `k` sampled from `seeds[k]`: one result
    /// per (frame, seed) pair.
    pub fn detect_batch(&self, frames: &[&Frame], seeds: &[u64]) -> Vec<Vec<Detection>> {
        let prepared: Vec<PreparedFrame> = frames
            .iter()
            .zip(seeds)
            .map(|(f, &s)| self.prepare(f, &[], s))
            .collect();
        self.detect_prepared(&prepared.iter().collect::<Vec<_>>())
    }

    /// One streamed slice through the network with the LSTM `state` of the sweep's earlier
    /// slices (`None` at the sweep's start): its boxes before NMS and the next state.
    pub fn detect_slice(&self, slice: &PreparedFrame, state: Option<SliceState>) -> SliceDetections {
        let (out, state) = self.model.forward_slices(self.input(&[slice]), 1, state);
        SliceDetections {
            raw: self.raw_detections(&out, 0, slice, &self.nms),
            state,
        }
    }
}

/// The seed of the `i`-th evaluated frame's sampling RNG, for experiment seed `seed`.
pub fn frame_seed(seed: u64, i: usize) -> u64 {
    sub_seed(seed, 21, i as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use starnet_data::kitti::Calib;
    use starnet_data::sampling::{CenterTarget, NUM_FEATURES};
    use starnet_sim::{SynthConfig, simulate_scene_frame};

    fn frame(scene: u64) -> Frame {
        let calib = Calib::kitti_000000();
        simulate_scene_frame(scene, 0, &SynthConfig::default(), &calib).into_frame(format!("{scene:06}"), calib)
    }

    fn detector() -> Detector {
        let mut cfg = ExperimentConfig::default();
        cfg.model.blocks = vec![[16, 8]];
        cfg.model.d_fc0 = 8;
        cfg.model.d_offset = 8;
        // Keep every box, so the comparisons are not vacuous.
        cfg.nms.score = vec![0.0];
        cfg.eval.num_centers = 32;
        cfg.eval.num_points = 16;
        let model = cfg.model_config().init(&starnet_model::backend::default_device());
        Detector::new(model, &cfg)
    }

    #[test]
    fn a_budget_round_trips_and_sets_the_pipeline() {
        let d = detector();
        let b = Budget {
            num_centers: 48,
            num_points: 8,
            target: CenterTarget::Nearest(24),
        };
        let at = d.at_budget(b);
        assert_eq!(at.budget(), b);
        assert_eq!((at.pipeline.num_centers, at.pipeline.gather.num_points), (48, 8));
        assert_eq!(at.at_budget(d.budget()).budget(), d.budget());
        // Half the centers reach the model: half the FLOPs of the same budget with all of them.
        let all = d.at_budget(Budget {
            target: CenterTarget::All,
            ..b
        });
        assert!((at.gflop_per_frame() * 2.0 - all.gflop_per_frame()).abs() < 1e-9);
    }

    /// `frame` with only the centers of rank parity `parity` valid.
    fn only(frame: &PreparedFrame, parity: usize) -> PreparedFrame {
        let mut f = frame.clone();
        for (rank, valid) in f.centers.valid.iter_mut().enumerate() {
            *valid &= rank % 2 == parity;
        }
        f
    }

    #[test]
    fn a_mirrored_center_finds_the_mirror_image_of_what_it_finds_in_the_mirrored_frame() {
        let seen = detector();
        let alternate = Detector {
            views: CenterViews::Alternate,
            ..seen.clone()
        };
        let f = seen.prepare(&frame(3), &[], 9);
        // The frame's mirror image, by hand: every center's y and its points' y offsets negated.
        let mut m = f.clone();
        m.centers.xyz.iter_mut().for_each(|c| c[1] = -c[1]);
        m.neighbourhoods
            .features
            .chunks_exact_mut(NUM_FEATURES)
            .for_each(|p| p[1] = -p[1]);
        let raw = |d: &Detector, g: &PreparedFrame| d.raw_detections(&d.forward(&[g]), 0, g, &d.nms);
        // Even ranks as seen; odd ranks found in the mirrored frame, mirrored back.
        let mut want = raw(&seen, &only(&f, 0));
        want.extend(
            raw(&seen, &only(&m, 1))
                .into_iter()
                .map(|d| Detection { b: d.b.mirrored(), ..d }),
        );
        let got = raw(&alternate, &f);
        assert_eq!(got.len(), want.len());
        // Every anchor of every valid center (32 centers of 100 car anchors).
        assert!(got.len() > 1000, "{}", got.len());
        let gap = |a: &Detection, b: &Detection| {
            let (x, y) = (a.b.to_array(), b.b.to_array());
            x.iter()
                .zip(y)
                .map(|(u, v)| (u - v).abs())
                .fold((a.score - b.score).abs(), f32::max)
        };
        for g in &got {
            let nearest = want.iter().map(|w| gap(g, w)).fold(f32::INFINITY, f32::min);
            assert!(nearest < 1e-4, "{g:?}: nearest expected box {nearest} away");
        }
        // And the mirrored centers do see something else: half the boxes move.
        let as_seen = raw(&seen, &f);
        let moved = got.iter().zip(&as_seen).filter(|(a, b)| gap(a, b) > 1e-3).count();
        assert!(moved > got.len() / 4, "{moved} of {} boxes moved", got.len());
    }

    #[test]
    fn a_batch_detects_what_its_frames_detect_alone() {
        let d = detector();
        let frames = [frame(1), frame(2)];
        let batch = d.detect_batch(&[&frames[0], &frames[1]], &[5, 6]);
        assert_eq!(batch.len(), 2);
        for (k, (f, seed)) in frames.iter().zip([5, 6]).enumerate() {
            let alone = d.detect(f, seed);
            assert!(!alone.is_empty());
            assert_eq!(alone.len(), batch[k].len());
            for (a, b) in alone.iter().zip(&batch[k]) {
                assert_eq!(a.class, b.class);
                assert!((a.score - b.score).abs() < 1e-4, "{} vs {}", a.score, b.score);
                assert!((a.b.x - b.b.x).abs() < 1e-3 && (a.b.heading - b.b.heading).abs() < 1e-3);
            }
        }
        // Another sampling seed, other centers: the seed reaches the sampler.
        assert_ne!(
            d.prepare(&frames[0], &[], 5).centers,
            d.prepare(&frames[0], &[], 7).centers
        );
    }
}
