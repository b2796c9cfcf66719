//! The simulated spinning LiDAR: an HDL-64E as KITTI mounts it (kitti-format.md §4).

use super::IntensityModel;
use serde::{Deserialize, Serialize};

/// A spinning multi-beam LiDAR.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LidarConfig {
    /// Beam elevations in degrees, top beam first (the order rings are written in).
    pub elevations_deg: Vec<f32>,
    /// Firings per turn; azimuth step = 360° / steps.
    pub azimuth_steps: usize,
    /// Returns beyond this range (metres) are lost.
    pub max_range: f32,
    /// Standard deviation of the range noise (metres), truncated at ±2.5 σ.
    pub range_noise: f32,
    /// Probability that a return is dropped.
    pub dropout: f32,
    /// Height of the sensor above the road (metres).
    pub mount_height: f32,
    /// What each return reports as reflectance (exact zeros for weak returns, gains).
    #[serde(default)]
    pub intensity: IntensityModel,
}

/// The HDL-64E's 64 elevations: the upper block of 32 beams 1/3° apart from +2°, the lower
/// block of 32 from −8.83° to −24.8° (about 1/2° apart).
pub fn hdl64_elevations() -> Vec<f32> {
    let upper = (0..32).map(|i| 2.0 - i as f32 / 3.0);
    let lower = (0..32).map(|i| -8.83 - i as f32 * (24.8 - 8.83) / 31.0);
    upper.chain(lower).collect()
}

impl Default for LidarConfig {
    fn default() -> Self {
        Self {
            elevations_deg: hdl64_elevations(),
            azimuth_steps: 2048,
            max_range: 120.0,
            range_noise: 0.02,
            dropout: 0.03,
            mount_height: 1.73,
            intensity: IntensityModel::default(),
        }
    }
}

impl LidarConfig {
    /// Unit direction of beam `beam` at azimuth step `step` (azimuth 0 = +x, counter-clockwise).
    pub fn direction(&self, beam: usize, step: usize) -> [f32; 3] {
        let e = self.elevations_deg[beam].to_radians();
        let a = self.azimuth(step);
        [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()]
    }

    /// Azimuth of step `step` in radians, [0, 2π).
    pub fn azimuth(&self, step: usize) -> f32 {
        std::f32::consts::TAU * step as f32 / self.azimuth_steps as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hdl64_layout() {
        let e = hdl64_elevations();
        assert_eq!(e.len(), 64);
        assert_eq!(e[0], 2.0);
        assert!((e[31] + 8.333).abs() < 1e-3 && (e[63] + 24.8).abs() < 1e-4);
        assert!(e.windows(2).all(|w| w[0] > w[1]), "top beam first, strictly descending");
        // The lowest beam meets flat ground at about 3.7 m (kitti-format.md §4).
        let d = 1.73 / (24.8f32).to_radians().tan();
        assert!((d - 3.75).abs() < 0.05, "{d}");
    }

    #[test]
    fn directions_are_unit_and_counter_clockwise() {
        let l = LidarConfig::default();
        let d = l.direction(0, l.azimuth_steps / 4);
        assert!((d.iter().map(|v| v * v).sum::<f32>() - 1.0).abs() < 1e-6);
        assert!(d[1] > 0.99, "a quarter turn looks along +y: {d:?}");
    }
}
