//! The values no type can express, checked section by section, then the rules that join
//! sections.

use super::experiment::ExperimentConfig;
use super::sections::{DataSection, EvalSection, ModelSection, NmsSection, StreamSection, TrainSection};
use crate::{Result, TrainError};
use starnet_data::sampling::{CenterViews, SliceCenters};
use starnet_data::settings::{Checked, InvalidSetting, at_least_one, non_negative, positive, width};
use std::path::Path;

impl ExperimentConfig {
    /// Checks values no type can express, section by section (each section's `validate`),
    /// then the rules that join sections; the error names the key and `file`.
    pub fn validate(&self, file: &Path) -> Result<()> {
        self.validate_settings().map_err(|e| TrainError::Config {
            file: file.into(),
            key: e.key,
            message: e.message,
        })
    }

    fn validate_settings(&self) -> Checked {
        let k = self.data.classes.len();
        self.data.validate().map_err(|e| e.within("data"))?;
        self.pipeline.validate().map_err(|e| e.within("pipeline"))?;
        self.augment.validate().map_err(|e| e.within("augment"))?;
        self.model.validate().map_err(|e| e.within("model"))?;
        self.assign.validate().map_err(|e| e.within("assign"))?;
        self.loss.validate().map_err(|e| e.within("loss"))?;
        self.nms.validate(k).map_err(|e| e.within("nms"))?;
        self.train.validate().map_err(|e| e.within("train"))?;
        self.eval.validate().map_err(|e| e.within("eval"))?;
        self.stream.validate().map_err(|e| e.within("stream"))?;
        if !(self.loss.class_weights.is_empty() || self.loss.class_weights.len() == k) {
            return Err(InvalidSetting::new(
                "loss.class_weights",
                format!("needs one weight per class ({k}), or none for all 1"),
            ));
        }
        if self.stream.enabled() && self.pipeline.pool.camera_frustum {
            return Err(InvalidSetting::new(
                "pipeline.pool.camera_frustum",
                "slices of a sweep cover 360°: set it to false (and data.labels = \"label_360\")",
            ));
        }
        if self.model.lstm_hidden > 0 && self.eval.views != CenterViews::AsSeen {
            // The LSTM sums up a slice by the mean of all its centers' features: a slice seen
            // half in the mirror is not one it was trained on.
            return Err(InvalidSetting::new(
                "eval.views",
                "the streaming LSTM summarises each slice over all its centers: use \"as_seen\"",
            ));
        }
        if self.stream.enabled() && self.pipeline.target != starnet_data::sampling::CenterTarget::All {
            return Err(InvalidSetting::new(
                "pipeline.target",
                "streaming spreads the centers over slices: use \"all\"",
            ));
        }
        Ok(())
    }
}

impl DataSection {
    /// At least one class.
    pub fn validate(&self) -> Checked {
        at_least_one("classes", self.classes.len())
    }
}

impl ModelSection {
    /// Widths in [1, `MAX_WIDTH`] (the LSTM's when it has one), at least one block, and valid
    /// anchors.
    pub fn validate(&self) -> Checked {
        width("d_fc0", self.d_fc0)?;
        at_least_one("blocks", self.blocks.len())?;
        for (i, b) in self.blocks.iter().enumerate() {
            width(&format!("blocks[{i}]"), b[0])?;
            width(&format!("blocks[{i}]"), b[1])?;
        }
        width("d_offset", self.d_offset)?;
        if self.lstm_hidden > 0 {
            width("lstm_hidden", self.lstm_hidden)?;
        }
        self.anchors.validate().map_err(|e| e.within("anchors"))
    }
}

impl NmsSection {
    /// One IoU and one score per class (of `classes`), voting for every class or none, each
    /// value in [0, 1], and at least one box kept.
    pub fn validate(&self, classes: usize) -> Checked {
        if self.iou.len() != classes || self.score.len() != classes {
            return Err(InvalidSetting::new(
                "iou",
                format!("nms.iou and nms.score need one value per class ({classes})"),
            ));
        }
        if !(self.vote_iou.is_empty() || self.vote_iou.len() == classes) {
            return Err(InvalidSetting::new(
                "vote_iou",
                format!("needs one value per class ({classes}), or none to turn voting off"),
            ));
        }
        for (key, values) in [("iou", &self.iou), ("score", &self.score), ("vote_iou", &self.vote_iou)] {
            if let Some(v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                return Err(InvalidSetting::new(
                    key,
                    format!("{v} is not an IoU or score in [0, 1]"),
                ));
            }
        }
        at_least_one("max_boxes", self.max_boxes)
    }
}

impl TrainSection {
    /// Counts ≥ 1, a positive rate and ε, non-negative decay start, clip norm and L2, an EMA
    /// decay in [0, 1).
    pub fn validate(&self) -> Checked {
        at_least_one("epochs", self.epochs)?;
        at_least_one("batch_size", self.batch_size)?;
        positive("learning_rate", self.learning_rate)?;
        non_negative("decay_start_epoch", self.decay_start_epoch)?;
        positive("adam_epsilon", self.adam_epsilon as f64)?;
        positive("grad_clip_norm", self.grad_clip_norm as f64)?;
        non_negative("l2", self.l2 as f64)?;
        if !(0.0..1.0).contains(&self.ema_decay) {
            return Err(InvalidSetting::new(
                "ema_decay",
                format!("{} is not in [0, 1) (0 turns the EMA off)", self.ema_decay),
            ));
        }
        at_least_one("workers", self.workers)?;
        at_least_one("prefetch", self.prefetch)
    }
}

impl EvalSection {
    /// Counts ≥ 1.
    pub fn validate(&self) -> Checked {
        at_least_one("num_centers", self.num_centers)?;
        at_least_one("num_points", self.num_points)?;
        at_least_one("batch_size", self.batch_size)
    }
}

impl StreamSection {
    /// Whether training cuts sweeps into slices.
    pub fn enabled(&self) -> bool {
        !self.train_slices.is_empty()
    }

    /// Slice counts ≥ 1, a positive range and scan rate, a valid slicing.
    pub fn validate(&self) -> Checked {
        if self.train_slices.contains(&0) {
            return Err(InvalidSetting::new("train_slices", "slice counts must be at least 1"));
        }
        at_least_one("eval_slices", self.eval_slices)?;
        positive("scan_hz", self.scan_hz)?;
        if self.eval_range.is_nan() || self.eval_range <= 0.0 {
            return Err(InvalidSetting::new(
                "eval_range",
                format!("{} is not a positive range (inf: everything)", self.eval_range),
            ));
        }
        if !self.train_slices.is_empty() && self.slicing.centers == SliceCenters::Spaced {
            // A training step runs its sweeps as one sequence of equally many slices; a spaced
            // sweep takes as many further steps as its seam needs.
            return Err(InvalidSetting::new(
                "slicing.centers",
                "\"spaced\" varies the steps per sweep and cannot train on slices (train_slices): \
                 train with \"continued\" or \"fresh\", stream-evaluate with \"spaced\"",
            ));
        }
        self.slicing.validate().map_err(|e| e.within("slicing"))
    }
}
