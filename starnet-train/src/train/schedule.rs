//! The authors' learning-rate schedule (lingvo `lr_util.SetExponentialLR`, no warm-up): flat
//! until the decay start, then exponential down to 1 % at 95 % of training, flat after.

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
}
