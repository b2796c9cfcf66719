//! Sensor-scale augmentation of the reflectance channel (not in the paper).
//!
//! A LiDAR's reflectance is its own: gains differ from unit to unit and from beam to beam,
//! and each sensor has its own floor below which a return reads exactly 0 (on KITTI's
//! HDL-64E a third of the returns at 30–40 m). A detector trained on one scale learns it
//! ("dark blob = car"), and meets another on the street. Per frame this step draws a gain,
//! a floor and a share of returns to zero, and applies them with noise to every non-zero
//! value; zeros stay zeros (a weak return does not get stronger).

use crate::Point;
use crate::settings::{Checked, non_negative, ordered_range, positive, within};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Settings of the reflectance step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReflectanceAugment {
    /// Whether the step runs (off by default: the paper has none).
    pub enabled: bool,
    /// Range `[min, max]` of the frame's gain on reported values, drawn log-uniformly.
    pub gain: [f32; 2],
    /// Standard deviation of the Gaussian noise added to each non-zero value.
    pub noise: f32,
    /// The frame's floor is drawn from `U(0, max_floor)`: values below it read 0.
    pub max_floor: f32,
    /// The frame's share of returns set to 0 at random is drawn from `U(0, max_zeroed)`.
    pub max_zeroed: f32,
}

impl Default for ReflectanceAugment {
    fn default() -> Self {
        Self {
            enabled: false,
            gain: [0.6, 1.6],
            noise: 0.03,
            max_floor: 0.1,
            max_zeroed: 0.3,
        }
    }
}

/// What the step drew for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReflectanceDraw {
    /// Gain on every non-zero value.
    pub gain: f32,
    /// Values below this (after gain and noise) read 0.
    pub floor: f32,
    /// Probability that a return is set to 0.
    pub zeroed: f32,
}

impl ReflectanceAugment {
    /// Checks the ranges (keys relative to the `reflectance` table).
    pub fn validate(&self) -> Checked {
        positive("gain", self.gain[0] as f64)?;
        positive("gain", self.gain[1] as f64)?;
        ordered_range("gain", self.gain)?;
        non_negative("noise", self.noise as f64)?;
        within("max_floor", self.max_floor as f64, 0.0, 1.0)?;
        within("max_zeroed", self.max_zeroed as f64, 0.0, 1.0)
    }

    /// Draws one frame's gain, floor and zeroed share.
    pub fn draw(&self, rng: &mut impl Rng) -> ReflectanceDraw {
        let [lo, hi] = self.gain.map(f32::ln);
        let uniform = |rng: &mut dyn rand::RngCore, lo: f32, hi: f32| {
            if hi > lo { rng.random_range(lo..hi) } else { lo }
        };
        ReflectanceDraw {
            gain: uniform(rng, lo, hi).exp(),
            floor: uniform(rng, 0.0, self.max_floor),
            zeroed: uniform(rng, 0.0, self.max_zeroed),
        }
    }
}

/// Applies `draw` to every point's reflectance, with noise of standard deviation `noise`:
/// zeros stay 0, the rest become `gain · r + noise`, 0 below the floor or when zeroed, else
/// clamped to [0, 1] and quantised to 0.01 (as KITTI's values are).
pub fn augment_reflectance(points: &mut [Point], draw: ReflectanceDraw, noise: f32, rng: &mut impl Rng) {
    let normal = Normal::new(0.0, noise.max(0.0)).expect("finite sigma");
    for p in points.iter_mut().filter(|p| p[3] != 0.0) {
        let v = draw.gain * p[3] + normal.sample(rng);
        let zeroed = rng.random::<f32>() < draw.zeroed;
        p[3] = if zeroed || v < draw.floor {
            0.0
        } else {
            (v.clamp(0.0, 1.0) * 100.0).round() / 100.0
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn identity_draw_keeps_quantised_values() {
        let mut pts = vec![[0.0, 0.0, 0.0, 0.25], [1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.99]];
        let before = pts.clone();
        let id = ReflectanceDraw {
            gain: 1.0,
            floor: 0.0,
            zeroed: 0.0,
        };
        augment_reflectance(&mut pts, id, 0.0, &mut rand_chacha::ChaCha8Rng::seed_from_u64(1));
        assert_eq!(pts, before);
    }

    #[test]
    fn gain_floor_and_zeroing_act_as_drawn() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let base: Vec<Point> = (0..10_000).map(|i| [0.0, 0.0, 0.0, 0.01 * (i % 50) as f32]).collect();
        let mut pts = base.clone();
        let draw = ReflectanceDraw {
            gain: 2.0,
            floor: 0.3,
            zeroed: 0.25,
        };
        augment_reflectance(&mut pts, draw, 0.0, &mut rng);
        let (mut survivors, mut zeroed_at_random) = (0, 0);
        for (a, b) in base.iter().zip(&pts) {
            // Without noise the value is exactly 2 · r (in f32, as the step computes it).
            let doubled = 2.0 * a[3];
            if a[3] == 0.0 || doubled < 0.3 {
                assert_eq!(b[3], 0.0, "{a:?}: zero or below the floor");
                continue;
            }
            survivors += 1;
            if b[3] == 0.0 {
                zeroed_at_random += 1;
            } else {
                assert!(
                    (b[3] - (doubled * 100.0).round() / 100.0).abs() < 1e-6,
                    "{a:?} -> {b:?}"
                );
            }
        }
        // About 0.16..0.49 survive the floor (34 or 35 of every 50 values), a quarter of them zeroed.
        assert!((6800..=7000).contains(&survivors), "{survivors}");
        let expected = 0.25 * survivors as f32;
        assert!(
            (zeroed_at_random as f32 - expected).abs() < 150.0,
            "{zeroed_at_random} of {survivors}"
        );
    }

    #[test]
    fn draws_stay_in_their_ranges() {
        let cfg = ReflectanceAugment::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..500 {
            let d = cfg.draw(&mut rng);
            assert!((0.6..=1.6).contains(&d.gain), "{d:?}");
            assert!((0.0..=0.1).contains(&d.floor) && (0.0..=0.3).contains(&d.zeroed));
        }
        assert!(cfg.validate().is_ok());
        let bad = ReflectanceAugment {
            gain: [1.5, 0.5],
            ..cfg
        };
        assert_eq!(bad.validate().unwrap_err().key, "gain");
    }
}
