//! [`Trainer`]: the model, Adam, the weight EMA and the position of a run, and one optimisation
//! step on a batch of prepared sweeps — the piece a custom training loop calls.

use super::clip::{global_norm, scale_to_norm, squared_grad_norms};
use super::data::TrainItem;
use super::ema::WeightEma;
use super::init_from::{InitReport, InitSource, init_from};
use super::snapshot::{Restored, load_checkpoint, save_checkpoint};
use crate::checkpoint::TrainState;
use crate::config::ExperimentConfig;
use crate::distributed::{Replicas, average, average_gradients, scope};
use crate::{Result, TrainError};
use burn::module::{Module, ParamId};
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, GradientsParams};
use burn::prelude::{Device, Tensor};
use serde::{Deserialize, Serialize};
use starnet_model::batch::make_batch;
use starnet_model::loss::{LossConfig, LossTerms, starnet_loss};
use starnet_model::nn::StarNet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The loss terms of a step (batch means) and the gradient norm before clipping.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StepLosses {
    /// The weighted total.
    pub loss: f32,
    /// Focal classification.
    pub classification: f32,
    /// Position residuals.
    pub location: f32,
    /// Size residuals.
    pub dimension: f32,
    /// Heading residual.
    pub rotation: f32,
    /// Direction classifier.
    pub direction: f32,
    /// Global gradient norm before clipping.
    pub grad_norm: f32,
}

impl StepLosses {
    /// The six loss values (the total first, then the terms in field order).
    pub(crate) fn terms(&self) -> [f32; 6] {
        [
            self.loss,
            self.classification,
            self.location,
            self.dimension,
            self.rotation,
            self.direction,
        ]
    }

    /// These losses with the six values of [`StepLosses::terms`] replaced.
    fn with_terms(self, [loss, classification, location, dimension, rotation, direction]: [f32; 6]) -> Self {
        Self {
            loss,
            classification,
            location,
            dimension,
            rotation,
            direction,
            grad_norm: self.grad_norm,
        }
    }
}

/// A model being trained, with its optimiser, EMA and position.
pub struct Trainer {
    /// The model (on an autodiff device); `None` only inside [`Trainer::step`], so Adam
    /// updates parameters it owns alone (in place) rather than copies.
    model: Option<StarNet>,
    /// Adam's moments.
    pub optim: burn::optim::ModuleOptimizer,
    /// The weight EMA, when the run keeps one.
    pub ema: Option<WeightEma>,
    /// Steps done and the best validation metric.
    pub state: TrainState,
    loss: LossConfig,
    num_classes: usize,
    grad_clip_norm: f32,
    device: Device,
    /// The threads a step computes on (`train.step_threads`).
    pool: Arc<rayon::ThreadPool>,
    /// The replica group of data-parallel training ([`Trainer::with_replicas`]).
    replicas: Option<Arc<dyn Replicas>>,
    /// The parameters a step updates, when some are held fixed ([`Trainer::set_featurizer`]).
    trainable: Option<Vec<ParamId>>,
}

/// Whether a step updates the point featurizer (fine-tuning may hold it fixed at first, as
/// `train.freeze_featurizer_epochs` does). Its BatchNorm statistics still follow the data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Featurizer {
    /// Updated with the rest of the model.
    Trained,
    /// Held fixed: only the projection and the heads learn.
    Frozen,
}

/// The step's pool: `threads` threads, 0 meaning rayon's default (`RAYON_NUM_THREADS`, else one
/// per core).
fn step_pool(threads: usize) -> Result<Arc<rayon::ThreadPool>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("starnet-step-{i}"))
        .build()
        .map_err(|source| TrainError::Threads { threads, source })?;
    Ok(Arc::new(pool))
}

impl Trainer {
    /// A fresh model on `device` (an autodiff device; its initial weights drawn from `cfg.seed`,
    /// [`starnet_model::nn::StarNetConfig::init_seeded`]), or the checkpoint `resume_from`; its
    /// steps compute on `cfg.train.step_threads` threads of their own.
    pub fn start(cfg: &ExperimentConfig, resume_from: Option<&Path>, device: &Device) -> Result<Self> {
        let model_cfg = cfg.model_config();
        let adam = AdamConfig::new()
            .with_epsilon(cfg.train.adam_epsilon)
            .with_weight_decay(Some(WeightDecayConfig::new(cfg.train.l2)));
        let ema_decay = cfg.train.ema_decay;
        let restored = match resume_from {
            Some(dir) => load_checkpoint(dir, || model_cfg.init(device), &adam, ema_decay)?,
            None => {
                let model = model_cfg.init_seeded(device, cfg.seed);
                Restored {
                    ema: (ema_decay > 0.0).then(|| WeightEma::new(ema_decay, &model)),
                    model,
                    optim: adam.init(),
                    state: TrainState {
                        step: 0,
                        best_metric: None,
                    },
                }
            }
        };
        Ok(Self {
            model: Some(restored.model),
            optim: restored.optim,
            ema: restored.ema,
            state: restored.state,
            loss: cfg.loss.clone(),
            num_classes: cfg.data.classes.len(),
            grad_clip_norm: cfg.train.grad_clip_norm,
            device: device.clone(),
            pool: step_pool(cfg.train.step_threads)?,
            replicas: None,
            trainable: None,
        })
    }

    /// A fresh trainer whose model starts from the weights of `source` wherever name and shape
    /// match ([`init_from`]); the optimizer, EMA and position start fresh.
    pub fn fine_tune(cfg: &ExperimentConfig, source: &InitSource, device: &Device) -> Result<(Self, InitReport)> {
        let mut trainer = Self::start(cfg, None, device)?;
        let fresh = trainer.model.take().expect("a new trainer holds its model");
        let (model, report) = init_from(fresh, &source.model, source.path.clone());
        let decay = cfg.train.ema_decay;
        trainer.ema = (decay > 0.0).then(|| WeightEma::new(decay, &model));
        trainer.model = Some(model);
        Ok((trainer, report))
    }

    /// Whether the next steps update the featurizer. The training loop calls it every step; the
    /// parameter lists are only built when the choice changes.
    pub fn set_featurizer(&mut self, featurizer: Featurizer) {
        if (featurizer == Featurizer::Frozen) == self.trainable.is_some() {
            return;
        }
        self.trainable = match featurizer {
            Featurizer::Trained => None,
            Featurizer::Frozen => {
                let frozen = self.model().featurizer_param_ids();
                let all = burn::module::list_param_ids(self.model());
                Some(all.into_iter().filter(|id| !frozen.contains(id)).collect())
            }
        };
    }

    /// Makes this trainer one replica of `group` (data-parallel training, see
    /// [`crate::distributed`]): its steps synchronise the BatchNorms over the group, average the
    /// gradients and report the group's mean losses, so every member takes the same Adam step.
    /// Every member must start from the same weights and step in lockstep. Needs the flex
    /// device (synchronised BatchNorm is written for it).
    pub fn with_replicas(mut self, group: Arc<dyn Replicas>) -> Result<Self> {
        if !starnet_model::replicas::supported(&self.device) {
            return Err(TrainError::InvalidArgument {
                name: "distributed".into(),
                message: format!(
                    "data-parallel training runs on the flex CPU device, not {:?}",
                    self.device
                ),
            });
        }
        self.replicas = Some(group);
        Ok(self)
    }

    /// One step at learning rate `lr` on `sweeps` (each a sequence of slices, all of one
    /// length; one slice each unless streaming): forward, loss, backward, clipping, Adam, EMA,
    /// with one read back to the host. A non-finite loss changes nothing: it stops before the
    /// weights change, and the BatchNorm running statistics the forward moved are put back.
    pub fn step(&mut self, sweeps: &[Vec<TrainItem>], lr: f64) -> Result<StepLosses> {
        // The whole step on the step's threads: its operations' parallel parts then stay
        // there instead of each being handed over from this thread.
        let pool = Arc::clone(&self.pool);
        pool.install(|| self.step_here(sweeps, lr))
    }

    fn step_here(&mut self, sweeps: &[Vec<TrainItem>], lr: f64) -> Result<StepLosses> {
        // The forward moves the BatchNorm running statistics; a failed step puts them back.
        let running = self.model().running_stats();
        let model = self.model.take().expect("the model is only taken within a step");
        let (terms, mut grads) = match self.replicas.clone() {
            Some(group) => scope(group, || self.gradients(&model, sweeps)),
            None => self.gradients(&model, sweeps),
        };
        if let Some(group) = &self.replicas {
            average_gradients(&model, &mut grads, group.as_ref());
        }
        let mut losses = read_back(terms, &model, &grads);
        if let Some(group) = &self.replicas {
            // The norm is already the averaged gradients'; the terms are each member's own.
            let mut terms = losses.terms();
            average(&mut terms, group.as_ref());
            losses = losses.with_terms(terms);
        }
        // The same decision on every replica: the values it reads are the group's.
        if let Some(err) = non_finite(&losses, self.state.step) {
            model.restore_running_stats(running);
            self.model = Some(model);
            return Err(err);
        }
        scale_to_norm(&model, &mut grads, losses.grad_norm, self.grad_clip_norm);
        let model = self.model.insert(self.optim.step(lr, model, grads));
        self.state.step += 1;
        if let Some(e) = self.ema.as_mut() {
            e.update(model, self.state.step);
        }
        Ok(losses)
    }

    /// The loss terms of `model` on `sweeps` and their gradients.
    fn gradients(&self, model: &StarNet, sweeps: &[Vec<TrainItem>]) -> (LossTerms, GradientsParams) {
        let slices = sweeps[0].len();
        // Sweep-major: the slices of each sweep in order, as `forward_slices` expects.
        let frames: Vec<_> = sweeps.iter().flatten().map(|i| &i.frame).collect();
        let targets: Vec<_> = sweeps.iter().flatten().map(|i| &i.targets).collect();
        let b = make_batch(&frames, &targets, self.num_classes, &self.device);
        let (out, _) = model.forward_slices(b.input, slices, None);
        let terms = starnet_loss(&out, &b.targets, &self.loss);
        let mut backward = terms.total.backward();
        let grads = match &self.trainable {
            Some(ids) => GradientsParams::from_params(&mut backward, model, ids),
            None => GradientsParams::from_grads(backward, model),
        };
        (terms, grads)
    }

    /// The model being trained.
    pub fn model(&self) -> &StarNet {
        self.model.as_ref().expect("the model is only taken within a step")
    }

    /// The model to evaluate and keep as `best`: the averaged weights when there is an EMA.
    /// It lives on the CPU, where evaluation runs, whichever device trains.
    pub fn eval_model(&self) -> StarNet {
        let model = match &self.ema {
            Some(e) => e.apply(self.model()),
            None => self.model().valid(),
        };
        model.to_device(&starnet_model::backend::default_device())
    }

    /// Writes the whole state as checkpoint `dir/name` (atomically).
    pub fn save(&self, dir: &Path, name: &str) -> Result<PathBuf> {
        save_checkpoint(dir, name, self.model(), &self.optim, self.ema.as_ref(), &self.state)
    }
}

/// The step's losses and gradient norm in one read back to the host (a GPU is not stalled
/// once per term and parameter): the loss terms, then each parameter's squared gradient norm.
fn read_back(terms: LossTerms, model: &StarNet, grads: &GradientsParams) -> StepLosses {
    let terms = [
        terms.total,
        terms.classification,
        terms.location,
        terms.dimension,
        terms.rotation,
        terms.direction,
    ];
    // The gradients live on the inner (non-autodiff) device; so do the terms' values.
    let mut parts: Vec<Tensor<1>> = terms.into_iter().map(Tensor::inner).collect();
    parts.extend(squared_grad_norms(model, grads));
    let host: Vec<f32> = Tensor::cat(parts, 0).into_data().iter::<f32>().collect();
    StepLosses {
        loss: host[0],
        classification: host[1],
        location: host[2],
        dimension: host[3],
        rotation: host[4],
        direction: host[5],
        grad_norm: global_norm(&host[6..]),
    }
}

/// The error a step with a non-finite loss or gradient norm ends in (Adam would write NaN
/// into every weight).
fn non_finite(losses: &StepLosses, step: u64) -> Option<TrainError> {
    if !losses.loss.is_finite() {
        Some(TrainError::NonFiniteLoss {
            step,
            value: losses.loss,
        })
    } else if !losses.grad_norm.is_finite() {
        Some(TrainError::NonFiniteGradient {
            step,
            norm: losses.grad_norm,
        })
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::load_config;
    use rand::SeedableRng;
    use starnet_data::sampling::{NUM_FEATURES, prepare_frame};
    use starnet_model::batch::frame_targets;
    use starnet_model::export::named_tensors;
    use starnet_sim::{SynthConfig, simulate_scene_frame};

    /// A simulated frame prepared as the loader prepares it (no augmentation).
    fn item(cfg: &ExperimentConfig) -> TrainItem {
        let calib = starnet_data::kitti::Calib::kitti_000000();
        let frame = simulate_scene_frame(1, 0, &SynthConfig::default(), &calib).into_frame("000001", calib);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let frame = prepare_frame(&frame, &cfg.pipeline, None, &[], &mut rng);
        TrainItem {
            targets: frame_targets(&frame, &cfg.model.anchors, &cfg.data.classes, &cfg.assign),
            frame,
        }
    }

    #[test]
    fn a_step_reports_its_terms_a_non_finite_loss_changes_nothing_and_padded_slots_are_not_read() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/quickstart.toml");
        let cfg = load_config(&path, &["train.step_threads=1".into()]).unwrap();
        let device = starnet_model::backend::default_device().autodiff();
        let mut trainer = Trainer::start(&cfg, None, &device).unwrap();
        let good = item(&cfg);
        let losses = trainer.step(&[vec![good.clone()]], 1e-3).unwrap();
        // The total read back is the weighted sum of the terms read back with it.
        let w = &cfg.loss;
        let localization = losses.location as f64 * w.location_weight
            + losses.dimension as f64 * w.dimension_weight
            + losses.rotation as f64 * w.rotation_weight;
        let total = localization * w.localization_weight
            + losses.classification as f64 * w.classification_weight
            + losses.direction as f64 * w.direction_weight;
        assert!((losses.loss as f64 - total).abs() < 1e-5, "{losses:?}");
        assert!(losses.grad_norm > 0.0 && trainer.state.step == 1);
        // A NaN in the input: the step fails, naming the step, and nothing moves, the
        // BatchNorm running statistics included.
        let mut bad = good.clone();
        bad.frame.neighbourhoods.features[0] = f32::NAN;
        let before = named_tensors(trainer.model());
        let err = trainer.step(&[vec![bad]], 1e-3).unwrap_err();
        assert!(matches!(err, TrainError::NonFiniteLoss { step: 1, .. }), "{err}");
        assert_eq!(named_tensors(trainer.model()), before);
        assert_eq!(trainer.state.step, 1);
        // A NaN in a padded slot: the fused featurizer never reads padded slots, so the step
        // goes on; the composed blocks multiply it by the mask, and NaN · 0 is NaN.
        let mut padded = good;
        let slot = padded
            .frame
            .neighbourhoods
            .mask
            .iter()
            .position(|m| !m)
            .expect("a padded slot");
        padded.frame.neighbourhoods.features[slot * NUM_FEATURES] = f32::NAN;
        let composed_cfg = load_config(
            &path,
            &["train.step_threads=1".into(), "model.fused_blocks=false".into()],
        )
        .unwrap();
        let mut composed = Trainer::start(&composed_cfg, None, &device).unwrap();
        let composed_before = named_tensors(composed.model());
        let err = composed.step(&[vec![padded.clone()]], 1e-3).unwrap_err();
        assert!(matches!(err, TrainError::NonFiniteLoss { step: 0, .. }), "{err}");
        assert_eq!(named_tensors(composed.model()), composed_before);
        let losses = trainer.step(&[vec![padded]], 1e-3).expect("padded slots are not read");
        assert!(losses.loss.is_finite() && losses.grad_norm.is_finite() && trainer.state.step == 2);
        assert_ne!(named_tensors(trainer.model()), before);
    }

    #[test]
    fn a_finite_loss_with_a_non_finite_gradient_norm_is_an_error() {
        let ok = StepLosses {
            loss: 1.0,
            classification: 0.5,
            location: 0.1,
            dimension: 0.1,
            rotation: 0.1,
            direction: 0.2,
            grad_norm: 3.0,
        };
        assert!(non_finite(&ok, 7).is_none());
        let bad = StepLosses {
            grad_norm: f32::INFINITY,
            ..ok
        };
        assert!(matches!(
            non_finite(&bad, 7),
            Some(TrainError::NonFiniteGradient { step: 7, .. })
        ));
        let both = StepLosses { loss: f32::NAN, ..bad };
        assert!(matches!(
            non_finite(&both, 7),
            Some(TrainError::NonFiniteLoss { step: 7, .. })
        ));
    }
}
