//! One experiment: every section, their defaults (which document every key), and the
//! library configs they assemble.

use super::sections::{DataSection, EvalSection, ModelSection, NmsSection, StreamSection, TrainSection};
use crate::{Result, TrainError};
use serde::{Deserialize, Serialize};
use starnet_data::augment::AugmentConfig;
use starnet_data::kitti::{KittiDataset, LabelSource, Layout, MissingIntensity, ObjectClass};
use starnet_data::sampling::{AnchorGrid, CenterViews, PipelineConfig, ReflectanceInput, SliceConfig};
use starnet_model::assign::AssignConfig;
use starnet_model::backend::DeviceChoice;
use starnet_model::loss::LossConfig;
use starnet_model::nms::{ClassNms, Emission, NmsConfig, Precedence};
use starnet_model::nn::{FeaturizerConfig, RowLayout, StarNetConfig};

/// One experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentConfig {
    /// The one seed every RNG derives from.
    pub seed: u64,
    /// Data.
    pub data: DataSection,
    /// Centers and neighbourhoods for training.
    pub pipeline: PipelineConfig,
    /// Training augmentation.
    pub augment: AugmentConfig,
    /// Model.
    pub model: ModelSection,
    /// Target assignment.
    pub assign: AssignConfig,
    /// Loss (`starnet_model::loss::LossConfig`, the authors' Waymo defaults).
    pub loss: LossConfig,
    /// Post-processing.
    pub nms: NmsSection,
    /// Optimisation.
    pub train: TrainSection,
    /// Evaluation budget.
    pub eval: EvalSection,
    /// Streaming.
    pub stream: StreamSection,
}

impl Default for ExperimentConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            data: DataSection {
                root: "data/sim".into(),
                simulate_frames: 0,
                simulate_seed: 0,
                classes: vec![ObjectClass::Car],
                train_split: "train".into(),
                val_split: "val".into(),
                labels: LabelSource::Camera,
            },
            pipeline: PipelineConfig::default(),
            augment: AugmentConfig::default(),
            model: ModelSection {
                d_fc0: 64,
                blocks: vec![[256, 64]; 5],
                d_offset: 128,
                anchors: AnchorGrid::kitti_car(),
                lstm_hidden: 0,
                direction_classifier: false,
                shared_size: false,
                fused_blocks: true,
                row_layout: RowLayout::Auto,
            },
            assign: AssignConfig::default(),
            loss: LossConfig::new(),
            nms: NmsSection {
                iou: vec![0.083],
                score: vec![0.321],
                vote_iou: Vec::new(),
                max_boxes: 512,
            },
            train: TrainSection {
                epochs: 20,
                batch_size: 2,
                learning_rate: 1e-3,
                decay_start_epoch: 5.0,
                adam_epsilon: 1e-6,
                grad_clip_norm: 5.0,
                l2: 1e-4,
                ema_decay: 0.99,
                workers: 1,
                step_threads: 0,
                device: DeviceChoice::Flex,
                prefetch: 4,
                log_every: 50,
                eval_every: 0,
                keep_last: 2,
                freeze_featurizer_epochs: 0,
                run_root: "runs".into(),
            },
            eval: EvalSection {
                num_centers: 768,
                num_points: 64,
                batch_size: 2,
                views: CenterViews::AsSeen,
            },
            stream: StreamSection {
                train_slices: Vec::new(),
                eval_slices: 8,
                nms_memory: 1,
                nms_precedence: Precedence::Score,
                nms_emission: Emission::Immediate,
                eval_range: f32::INFINITY,
                scan_hz: 10.0,
                slicing: SliceConfig::default(),
            },
        }
    }
}
impl ExperimentConfig {
    /// The model's Burn config.
    pub fn model_config(&self) -> StarNetConfig {
        let f = FeaturizerConfig::new(self.model.d_fc0, self.model.blocks.clone())
            .with_fused(self.model.fused_blocks)
            .with_rows(self.model.row_layout);
        StarNetConfig::new(
            f,
            self.model.d_offset,
            self.model.anchors.clone(),
            self.data.classes.len(),
        )
        .with_lstm_hidden((self.model.lstm_hidden > 0).then_some(self.model.lstm_hidden))
        .with_direction_classifier(self.model.direction_classifier)
        .with_shared_size(self.model.shared_size)
    }

    /// A split of the config's dataset, read with the config's labels.
    /// A root in the custom layout (no camera) needs centers all around the sensor: its frames'
    /// calibration is a stand-in, whose frustum would silently hide most of the scene.
    pub fn dataset(&self, split: &str) -> Result<KittiDataset> {
        let missing = match self.pipeline.gather.reflectance {
            ReflectanceInput::Measured => MissingIntensity::Refuse,
            ReflectanceInput::Ignored => MissingIntensity::Zero,
        };
        let ds = KittiDataset::open(&self.data.root, Some(split))?;
        if ds.layout() == Layout::Custom && self.pipeline.pool.camera_frustum {
            return Err(TrainError::InvalidArgument {
                name: "pipeline.pool.camera_frustum".into(),
                message: format!(
                    "{} is in the custom layout, which has no camera: set it to false (and data.labels = \"label_360\")",
                    self.data.root.display()
                ),
            });
        }
        Ok(ds
            .with_labels(self.data.labels)
            .with_missing_intensity(missing)
            .with_wild_points(self.pipeline.wild_points))
    }

    /// NMS settings per class.
    pub fn nms_config(&self) -> NmsConfig {
        let per_class = self
            .nms
            .iou
            .iter()
            .zip(&self.nms.score)
            .zip(&self.data.classes)
            .enumerate()
            .map(|(c, ((&iou, &score), &class))| ClassNms {
                class,
                iou,
                score,
                vote_iou: self.nms.vote_iou.get(c).copied(),
            })
            .collect();
        NmsConfig {
            per_class,
            max_boxes: self.nms.max_boxes,
        }
    }
}
