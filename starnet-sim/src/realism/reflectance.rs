//! Reflectance by range: mean, and the share of returns that read exactly 0.

use serde::{Deserialize, Serialize};

/// Range bin edges, metres (bird's-eye distance from the sensor).
pub const RANGE_EDGES_M: [f32; 8] = [0.0, 5.0, 10.0, 20.0, 30.0, 40.0, 60.0, 120.0];

/// Reflectance of the returns in one range bin.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ReflectanceBin {
    /// Bin start, metres.
    pub lo: f32,
    /// Bin end, metres.
    pub hi: f32,
    /// Returns in the bin.
    pub points: u64,
    /// Mean reflectance.
    pub mean: f64,
    /// Share of returns that read exactly 0, percent.
    pub zero_percent: f64,
}

/// Running sums per range bin.
#[derive(Debug, Clone, Default)]
pub struct ReflectanceSums {
    count: [u64; RANGE_EDGES_M.len() - 1],
    sum: [f64; RANGE_EDGES_M.len() - 1],
    zeros: [u64; RANGE_EDGES_M.len() - 1],
}

/// The bin of range `r`, if inside the edges.
pub fn range_bin(r: f32) -> Option<usize> {
    RANGE_EDGES_M.windows(2).position(|w| (w[0]..w[1]).contains(&r))
}

impl ReflectanceSums {
    /// Adds a return with reflectance `v` at range `r`.
    pub fn add(&mut self, r: f32, v: f32) {
        if let Some(b) = range_bin(r) {
            self.count[b] += 1;
            self.sum[b] += v as f64;
            self.zeros[b] += u64::from(v == 0.0);
        }
    }

    /// The bins.
    pub fn bins(&self) -> Vec<ReflectanceBin> {
        RANGE_EDGES_M
            .windows(2)
            .enumerate()
            .map(|(b, w)| {
                let n = self.count[b].max(1) as f64;
                ReflectanceBin {
                    lo: w[0],
                    hi: w[1],
                    points: self.count[b],
                    mean: self.sum[b] / n,
                    zero_percent: 100.0 * self.zeros[b] as f64 / n,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_bin_by_range_and_count_exact_zeros() {
        let mut s = ReflectanceSums::default();
        for (r, v) in [(3.0, 0.2), (4.0, 0.0), (15.0, 0.5), (200.0, 0.9)] {
            s.add(r, v);
        }
        let b = s.bins();
        assert_eq!(b.len(), 7);
        assert_eq!((b[0].points, b[2].points), (2, 1));
        assert!((b[0].mean - 0.1).abs() < 1e-6 && (b[0].zero_percent - 50.0).abs() < 1e-9);
        assert!((b[2].mean - 0.5).abs() < 1e-6 && b[2].zero_percent == 0.0);
        assert_eq!(b.iter().map(|x| x.points).sum::<u64>(), 3, "beyond 120 m is not binned");
    }
}
