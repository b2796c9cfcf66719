//! Maximum-weight bipartite matching (the Hungarian method with potentials, O(n²m)), as the
//! Waymo detection metrics match predictions to ground truth.

/// Matches rows to columns of the `rows × cols` weights (row-major) to maximise the total weight
/// of the chosen pairs, each row and column used at most once. Pairs of weight ≤ 0 are never
/// returned. Returns `(row, col)` pairs sorted by row.
pub fn max_weight_matching(weights: &[f64], rows: usize, cols: usize) -> Vec<(usize, usize)> {
    assert_eq!(weights.len(), rows * cols, "weights must be rows × cols");
    if rows == 0 || cols == 0 {
        return Vec::new();
    }
    // The potential method assigns every row of a rows ≤ cols problem: transpose if needed, and
    // minimise the negated weights (a zero-weight pair is a free non-match).
    let (n, m, transposed) = if rows <= cols {
        (rows, cols, false)
    } else {
        (cols, rows, true)
    };
    let cost = |i: usize, j: usize| {
        let w = if transposed {
            weights[j * cols + i]
        } else {
            weights[i * cols + j]
        };
        -w.max(0.0)
    };
    // 1-based arrays as in the classic formulation; column 0 is the virtual start.
    let (mut u, mut v) = (vec![0.0; n + 1], vec![0.0; m + 1]);
    let mut owner = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        owner[0] = i;
        let mut j0 = 0;
        let mut minv = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = owner[j0];
            let (mut delta, mut j1) = (f64::INFINITY, 0);
            for j in 1..=m {
                if !used[j] {
                    let cur = cost(i0 - 1, j - 1) - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[owner[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if owner[j0] == 0 {
                break;
            }
        }
        while j0 != 0 {
            let j1 = way[j0];
            owner[j0] = owner[j1];
            j0 = j1;
        }
    }
    let mut pairs: Vec<(usize, usize)> = (1..=m)
        .filter(|&j| owner[j] != 0)
        .map(|j| (owner[j] - 1, j - 1))
        .filter(|&(i, j)| cost(i, j) < 0.0)
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
