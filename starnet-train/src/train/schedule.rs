//! The authors' learning-rate schedule (lingvo `lr_util.SetExponentialLR`, no warm-up): flat
//! until the decay start, then exponential down to 1 % at 95 % of training, flat after.

use crate::config::TrainSection;

/// Where a run's steps fall: per epoch, in all, where the decay starts, and where this
/// invocation stops (`--max-steps`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Schedule {
    /// Steps per epoch (whole batches of the training split).
    pub steps_per_epoch: u64,
    /// Steps of the whole run.
    pub total: u64,
    /// The step the learning rate starts decaying at.
    pub decay_start: u64,
    /// The step this invocation stops at.
    pub end: u64,
}

impl Schedule {
    /// The schedule of `train` over a split of `frames` frames, stopping at `max_steps`.
    pub fn new(train: &TrainSection, frames: usize, max_steps: Option<u64>) -> Self {
        let steps_per_epoch = (frames / train.batch_size.max(1)).max(1) as u64;
        let total = train.epochs as u64 * steps_per_epoch;
        Self {
            steps_per_epoch,
            total,
            decay_start: (train.decay_start_epoch * steps_per_epoch as f64) as u64,
            end: max_steps.map_or(total, |m| m.min(total)),
        }
    }

    /// The learning rate of `step` for the base rate `base`.
    pub fn lr(&self, base: f64, step: u64) -> f64 {
        base * lr_multiplier(step, self.decay_start, self.total)
    }

    /// Epochs done after `step` steps.
    pub fn epoch(&self, step: u64) -> f64 {
        step as f64 / self.steps_per_epoch as f64
    }

    /// Whether `step` closes an epoch (or this invocation).
    pub fn epoch_ends(&self, step: u64) -> bool {
        step.is_multiple_of(self.steps_per_epoch) || step == self.end
    }
}

/// Multiplier of the base rate at `step` of `total`, decaying from `decay_start`.
pub fn lr_multiplier(step: u64, decay_start: u64, total: u64) -> f64 {
    let end = ((0.95 * total as f64) as u64).max(decay_start + 1);
    if step < decay_start {
        1.0
    } else if step < end {
        0.01f64.powf((step - decay_start) as f64 / (end - decay_start) as f64)
    } else {
        0.01
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_decay_floor() {
        // 1000 steps, decay from 200 to 950.
        assert_eq!(lr_multiplier(0, 200, 1000), 1.0);
        assert_eq!(lr_multiplier(199, 200, 1000), 1.0);
        assert_eq!(lr_multiplier(200, 200, 1000), 1.0);
        assert!(
            (lr_multiplier(575, 200, 1000) - 0.1).abs() < 1e-12,
            "halfway through the decay: 0.01^0.5"
        );
        assert_eq!(lr_multiplier(950, 200, 1000), 0.01);
        assert_eq!(lr_multiplier(999, 200, 1000), 0.01);
    }

    #[test]
    fn a_schedule_counts_whole_batches_and_stops_at_max_steps() {
        let train = TrainSection {
            epochs: 4,
            batch_size: 2,
            decay_start_epoch: 1.5,
            ..crate::config::ExperimentConfig::default().train
        };
        // 7 frames: 3 whole batches per epoch, the odd frame dropped.
        let s = Schedule::new(&train, 7, Some(10));
        assert_eq!((s.steps_per_epoch, s.total, s.decay_start, s.end), (3, 12, 4, 10));
        assert_eq!(Schedule::new(&train, 7, Some(99)).end, 12);
        assert!(s.epoch_ends(3) && s.epoch_ends(10) && !s.epoch_ends(4));
        assert_eq!(s.epoch(6), 2.0);
        assert_eq!(s.lr(0.5, 0), 0.5);
        assert_eq!(s.lr(0.5, 11), 0.005);
    }
}
