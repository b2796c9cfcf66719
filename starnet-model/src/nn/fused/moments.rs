//! Weighted column means and variances of row-major rows, one chunk of rows at a time: each
//! chunk's two passes (mean, then squared deviations) run while it is in cache, and chunks merge
//! in row order by the parallel update of Chan, Golub and LeVeque, so a BatchNorm's batch
//! statistics cost one pass over memory and do not depend on the number of threads.

use super::rows::{add_scaled, read_chunks};

/// Per-channel mean and biased variance of one BatchNorm.
#[derive(Debug, Clone, PartialEq)]
pub struct BnStats {
    /// Mean `[D]`.
    pub mean: Vec<f32>,
    /// Biased variance `[D]`.
    pub var: Vec<f32>,
}

/// The weighted moments of some rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    /// Σ w.
    weight: f32,
    /// Σ w x / Σ w (0 without weight) `[cols]`.
    mean: Vec<f32>,
    /// Σ w (x − mean)² `[cols]`.
    m2: Vec<f32>,
}

impl Moments {
    /// Of the `cols`-wide rows of `x`, row `r` weighted by `w[r]` (a count: rows of weight 0
    /// are not read), or each by 1 without `w`.
    pub fn of_rows(x: &[f32], cols: usize, w: Option<&[f32]>) -> Self {
        let rows = x.len() / cols.max(1);
        let weight: f32 = w.map_or(rows as f32, |w| w.iter().sum());
        let (mut mean, mut m2) = (vec![0.0; cols], vec![0.0; cols]);
        if weight == 0.0 || cols == 0 {
            return Self { weight, mean, m2 };
        }
        let weight_of = |r: usize| w.map_or(1.0, |w| w[r]);
        let weighted = || {
            x.chunks_exact(cols)
                .enumerate()
                .map(move |(r, row)| (row, weight_of(r)))
                .filter(|(_, w)| *w != 0.0)
        };
        weighted().for_each(|(row, w)| add_scaled(&mut mean, row, w));
        mean.iter_mut().for_each(|m| *m /= weight);
        for (row, w) in weighted() {
            for ((a, x), m) in m2.iter_mut().zip(row).zip(&mean) {
                *a += w * (x - m) * (x - m);
            }
        }
        Self { weight, mean, m2 }
    }

    /// Of `x`'s rows, chunk by chunk in parallel.
    pub fn of_rows_chunked(x: &[f32], cols: usize, w: Option<&[f32]>) -> Self {
        let parts = read_chunks(x, cols, |r0, chunk| {
            Self::of_rows(chunk, cols, w.map(|w| &w[r0..r0 + chunk.len() / cols]))
        });
        Self::merge_all(parts, cols)
    }

    /// The moments of the union of the parts' rows, merged in order.
    pub fn merge_all(parts: Vec<Self>, cols: usize) -> Self {
        let empty = Self {
            weight: 0.0,
            mean: vec![0.0; cols],
            m2: vec![0.0; cols],
        };
        parts.into_iter().fold(empty, Self::merge)
    }

    /// The moments of both rows' sets together.
    pub fn merge(self, other: Self) -> Self {
        if other.weight == 0.0 {
            return self;
        }
        if self.weight == 0.0 {
            return other;
        }
        let weight = self.weight + other.weight;
        let (f, g) = (other.weight / weight, self.weight * other.weight / weight);
        let delta = |j: usize| other.mean[j] - self.mean[j];
        let mean = (0..self.mean.len()).map(|j| self.mean[j] + delta(j) * f).collect();
        let m2 = (0..self.m2.len())
            .map(|j| self.m2[j] + other.m2[j] + delta(j) * delta(j) * g)
            .collect();
        Self { weight, mean, m2 }
    }

    /// The moments of the rows of every replica of the calling thread's group
    /// ([`crate::replicas`]): their sums Σ w, Σ w x and Σ w x² (in f64) summed over the group
    /// (`self` without a group).
    pub fn across_replicas(self) -> Self {
        let Some(group) = crate::replicas::current() else {
            return self;
        };
        let (cols, w) = (self.mean.len(), f64::from(self.weight));
        let mut sums = Vec::with_capacity(1 + 2 * cols);
        sums.push(w);
        sums.extend(self.mean.iter().map(|&m| w * f64::from(m)));
        let second = self.m2.iter().zip(&self.mean);
        sums.extend(second.map(|(&m2, &m)| f64::from(m2) + w * f64::from(m) * f64::from(m)));
        group.sum_f64(&mut sums);
        let weight = sums[0];
        let mean: Vec<f64> = sums[1..=cols]
            .iter()
            .map(|s| if weight > 0.0 { s / weight } else { 0.0 })
            .collect();
        let m2 = sums[1 + cols..]
            .iter()
            .zip(&mean)
            .map(|(s, m)| (s - weight * m * m).max(0.0) as f32);
        Self {
            weight: weight as f32,
            m2: m2.collect(),
            mean: mean.into_iter().map(|m| m as f32).collect(),
        }
    }

    /// The mean and the biased variance (the squared deviations over the weight, over 1 when
    /// there is none: every value is then 0).
    pub fn stats(self) -> BnStats {
        let total = self.weight.max(1.0);
        BnStats {
            mean: self.mean,
            var: self.m2.into_iter().map(|m| m / total).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook two passes over every row, in f64: the oracle.
    fn direct(x: &[f32], cols: usize, w: &[f32]) -> (Vec<f64>, Vec<f64>) {
        let total: f64 = w.iter().map(|&w| f64::from(w)).sum();
        let col = |j: usize| {
            x.chunks(cols)
                .zip(w)
                .map(move |(r, &w)| (f64::from(r[j]), f64::from(w)))
        };
        let mean: Vec<f64> = (0..cols)
            .map(|j| col(j).map(|(x, w)| w * x).sum::<f64>() / total)
            .collect();
        let var = (0..cols)
            .map(|j| col(j).map(|(x, w)| w * (x - mean[j]).powi(2)).sum::<f64>() / total)
            .collect();
        (mean, var)
    }

    #[test]
    fn chunked_moments_match_the_two_pass_formula() {
        // 700 rows (three chunks) of 3 columns, one far from 0 (where one-pass sums lose
        // digits), weights 0..=3 with whole chunks' worth of zeros in the middle.
        let cols = 3;
        let x: Vec<f32> = (0..700 * cols)
            .map(|i| {
                let (r, j) = ((i / cols) as f32, i % cols);
                [(r * 0.37).sin(), 1e3 + (r * 0.11).cos(), r * 0.01][j]
            })
            .collect();
        let w: Vec<f32> = (0..700)
            .map(|r| if (250..520).contains(&r) { 0.0 } else { (r % 4) as f32 })
            .collect();
        let got = Moments::of_rows_chunked(&x, cols, Some(&w)).stats();
        // Without weights, every row weighs 1.
        assert_eq!(
            Moments::of_rows_chunked(&x, cols, None),
            Moments::of_rows_chunked(&x, cols, Some(&[1.0; 700]))
        );
        let (mean, var) = direct(&x, cols, &w);
        for j in 0..cols {
            assert!(
                (f64::from(got.mean[j]) - mean[j]).abs() <= 1e-5 * mean[j].abs().max(1.0),
                "mean {j}"
            );
            assert!((f64::from(got.var[j]) - var[j]).abs() <= 1e-4 * var[j], "variance {j}");
        }
    }

    #[test]
    fn rows_without_weight_give_zero_statistics() {
        let got = Moments::of_rows_chunked(&[5.0; 600], 2, Some(&[0.0; 300])).stats();
        assert_eq!(
            got,
            BnStats {
                mean: vec![0.0; 2],
                var: vec![0.0; 2]
            }
        );
    }

    #[test]
    fn merging_is_the_moments_of_the_union() {
        // {1, 3} and {6}: mean 10/3, Σ (x − mean)² = 49/9 + 1/9 + 64/9 = 114/9.
        let a = Moments::of_rows(&[1.0, 3.0], 1, None);
        let b = Moments::of_rows(&[6.0], 1, Some(&[1.0]));
        let s = a.merge(b).stats();
        assert!((s.mean[0] - 10.0 / 3.0).abs() < 1e-6);
        assert!((s.var[0] - 114.0 / 27.0).abs() < 1e-5);
    }
}
