//! Maximum-weight bipartite matching, as the Waymo detection metrics match predictions to
//! ground truth: `pathfinding`'s Hungarian method (Kuhn–Munkres) on the weights scaled to
//! integers.

use pathfinding::kuhn_munkres::kuhn_munkres;
use pathfinding::matrix::Matrix;

/// The largest scaled total weight: far inside `i64`, and 10⁻¹⁵ of the largest weight per unit,
/// so only totals closer than that may be ordered otherwise than in floating point.
const TOTAL_RESOLUTION: f64 = 1e15;

/// Matches rows to columns of the `rows × cols` weights (row-major) to maximise the total weight
/// of the chosen pairs, each row and column used at most once. Pairs of weight ≤ 0 are never
/// returned. Returns `(row, col)` pairs sorted by row.
pub fn max_weight_matching(weights: &[f64], rows: usize, cols: usize) -> Vec<(usize, usize)> {
    assert_eq!(weights.len(), rows * cols, "weights must be rows × cols");
    let top = weights.iter().copied().fold(0.0, f64::max);
    if rows == 0 || cols == 0 || top <= 0.0 {
        return Vec::new();
    }
    // Kuhn–Munkres assigns every row of a rows ≤ cols problem: transpose if needed. A pair of
    // weight 0 is a free non-match, dropped below.
    let transposed = rows > cols;
    let (n, m) = if transposed { (cols, rows) } else { (rows, cols) };
    let scale = TOTAL_RESOLUTION / (top * n as f64);
    let at = |i: usize, j: usize| {
        if transposed {
            weights[j * cols + i]
        } else {
            weights[i * cols + j]
        }
    };
    let scaled = Matrix::from_fn(n, m, |(i, j)| (at(i, j).max(0.0) * scale).round() as i64);
    let (_, assignment) = kuhn_munkres(&scaled);
    let mut pairs: Vec<(usize, usize)> = assignment
        .into_iter()
        .enumerate()
        .filter(|&(i, j)| scaled[(i, j)] > 0)
        .map(|(i, j)| if transposed { (j, i) } else { (i, j) })
        .collect();
    pairs.sort_unstable();
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Exhaustive search over every partial matching (small sizes only).
    fn brute_force(w: &[f64], rows: usize, cols: usize) -> f64 {
        fn go(w: &[f64], rows: usize, cols: usize, i: usize, used: &mut Vec<bool>) -> f64 {
            if i == rows {
                return 0.0;
            }
            let mut best = go(w, rows, cols, i + 1, used);
            for j in 0..cols {
                if !used[j] && w[i * cols + j] > 0.0 {
                    used[j] = true;
                    best = best.max(w[i * cols + j] + go(w, rows, cols, i + 1, used));
                    used[j] = false;
                }
            }
            best
        }
        go(w, rows, cols, 0, &mut vec![false; cols])
    }

    #[test]
    fn prefers_the_total_over_the_greedy_pick() {
        // Greedy takes (0, 0) = 0.9 and leaves row 1 with nothing; the optimum is 0.8 + 0.8.
        let w = [0.9, 0.8, 0.8, 0.0];
        assert_eq!(max_weight_matching(&w, 2, 2), vec![(0, 1), (1, 0)]);
    }

    #[test]
    fn never_returns_zero_weight_pairs() {
        assert_eq!(max_weight_matching(&[0.0, 0.5, 0.0], 3, 1), vec![(1, 0)]);
        assert!(max_weight_matching(&[0.0; 6], 2, 3).is_empty());
        assert!(max_weight_matching(&[], 0, 4).is_empty());
    }

    proptest! {
        #[test]
        fn reaches_the_brute_force_optimum(
            rows in 1usize..5,
            cols in 1usize..5,
            raw in proptest::collection::vec(0.0f64..1.0, 16),
        ) {
            // About a third of the pairs are non-matches, as below an IoU threshold.
            let w: Vec<f64> = raw[..rows * cols].iter().map(|&x| if x < 0.33 { 0.0 } else { x }).collect();
            let pairs = max_weight_matching(&w, rows, cols);
            let total: f64 = pairs.iter().map(|&(i, j)| w[i * cols + j]).sum();
            prop_assert!((total - brute_force(&w, rows, cols)).abs() < 1e-9);
            let mut r: Vec<_> = pairs.iter().map(|p| p.0).collect();
            let mut c: Vec<_> = pairs.iter().map(|p| p.1).collect();
            r.dedup();
            c.sort_unstable();
            c.dedup();
            prop_assert_eq!(r.len(), pairs.len());
            prop_assert_eq!(c.len(), pairs.len());
        }
    }
}
