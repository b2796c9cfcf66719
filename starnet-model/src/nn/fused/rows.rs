//! Parallel passes over the rows of a row-major matrix. Reductions split the rows into chunks of
//! a fixed size and add the chunks' partial sums in order, so a result does not depend on the
//! number of threads (same seed, same weights).

use rayon::prelude::*;

/// Rows per reduction chunk (fixed, for thread-independent sums).
const CHUNK: usize = 256;

/// Rows per parallel task of a row map.
const MIN_ROWS_PER_TASK: usize = 64;

/// Column sums of `K` quantities over rows: `f(r, acc)` adds row `r`'s contribution to the
/// `K` accumulators (`cols` wide each), which it is handed chunk by chunk.
pub fn col_sums<const K: usize>(
    rows: usize,
    cols: usize,
    f: impl Fn(usize, &mut [Vec<f32>; K]) + Sync,
) -> [Vec<f32>; K] {
    let zeros = || std::array::from_fn(|_| vec![0.0f32; cols]);
    let partial: Vec<[Vec<f32>; K]> = (0..rows.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut acc: [Vec<f32>; K] = zeros();
            for r in chunk * CHUNK..((chunk + 1) * CHUNK).min(rows) {
                f(r, &mut acc);
            }
            acc
        })
        .collect();
    let mut total = zeros();
    for p in partial {
        for (t, p) in total.iter_mut().zip(p) {
            add(t, &p);
        }
    }
    total
}

/// Calls `f(first_row, chunk)` on consecutive chunks of [`CHUNK`] rows of `dst`, in parallel,
/// and returns the results in row order: a reduction over them does not depend on the threads.
pub fn map_chunks<T: Send>(dst: &mut [f32], cols: usize, f: impl Fn(usize, &mut [f32]) -> T + Sync) -> Vec<T> {
    if cols == 0 {
        return Vec::new();
    }
    dst.par_chunks_mut(CHUNK * cols)
        .enumerate()
        .map(|(i, chunk)| f(i * CHUNK, chunk))
        .collect()
}

/// [`map_chunks`] over rows it only reads.
pub fn read_chunks<T: Send>(x: &[f32], cols: usize, f: impl Fn(usize, &[f32]) -> T + Sync) -> Vec<T> {
    if cols == 0 {
        return Vec::new();
    }
    x.par_chunks(CHUNK * cols)
        .enumerate()
        .map(|(i, chunk)| f(i * CHUNK, chunk))
        .collect()
}

/// `max(x, 0)`, except that NaN stays NaN (as Burn's and PyTorch's ReLU: `f32::max` would
/// turn it into 0 and hide a bad input from the loss).
pub fn relu(x: f32) -> f32 {
    if x.is_nan() || x > 0.0 { x } else { 0.0 }
}

/// Whether a ReLU whose output is `out` passes its gradient (NaN outputs do, as in Burn).
pub fn relu_passes(out: f32) -> bool {
    out.is_nan() || out > 0.0
}

/// `acc += x`.
pub fn add(acc: &mut [f32], x: &[f32]) {
    acc.iter_mut().zip(x).for_each(|(a, x)| *a += x);
}

/// `acc += w · x`.
pub fn add_scaled(acc: &mut [f32], x: &[f32], w: f32) {
    acc.iter_mut().zip(x).for_each(|(a, x)| *a += w * x);
}

/// Calls `f(r, row)` on every `cols`-wide row of `dst`, in parallel.
pub fn for_rows(dst: &mut [f32], cols: usize, f: impl Fn(usize, &mut [f32]) + Sync) {
    if cols == 0 {
        return;
    }
    dst.par_chunks_mut(cols)
        .with_min_len(MIN_ROWS_PER_TASK)
        .enumerate()
        .for_each(|(r, row)| f(r, row));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn column_sums_add_every_rows_contribution_in_chunks() {
        // 600 rows (three chunks) of (r, 2r), every even row twice.
        let [s] = col_sums(600, 2, |r, [acc]| {
            let w = if r % 2 == 0 { 2.0 } else { 1.0 };
            add_scaled(acc, &[r as f32, 2.0 * r as f32], w);
        });
        // Σ r over 0..600 = 179,700, plus the even rows again: 89,700.
        assert_eq!(s, [179_700.0 + 89_700.0, 2.0 * (179_700.0 + 89_700.0)]);
    }

    #[test]
    fn chunk_maps_see_every_row_once_at_its_index() {
        // 600 rows of 2: chunks start at rows 0, 256 and 512, the last one short.
        let mut x: Vec<f32> = (0..1200).map(|i| (i / 2) as f32).collect();
        let firsts = map_chunks(&mut x, 2, |r0, chunk| {
            assert!(chunk.chunks(2).enumerate().all(|(i, row)| row == [(r0 + i) as f32; 2]));
            chunk.iter_mut().for_each(|v| *v += 1.0);
            (r0, chunk.len() / 2)
        });
        assert_eq!(firsts, [(0, 256), (256, 256), (512, 88)]);
        let sums = read_chunks(&x, 2, |_, chunk| chunk.iter().sum::<f32>());
        // Σ (r + 1) over the rows, twice per row.
        assert_eq!(sums.iter().sum::<f32>(), 2.0 * (600.0 * 601.0 / 2.0));
    }

    #[test]
    fn relu_keeps_nan() {
        assert_eq!([relu(-1.0), relu(0.0), relu(2.5)], [0.0, 0.0, 2.5]);
        assert!(relu(f32::NAN).is_nan() && relu_passes(f32::NAN));
        assert!(!relu_passes(0.0) && relu_passes(1e-30));
    }

    #[test]
    fn row_map_visits_every_row_once_with_its_index() {
        let mut x = vec![0.0; 1000 * 3];
        for_rows(&mut x, 3, |r, row| row.iter_mut().for_each(|v| *v += r as f32));
        assert!(
            x.chunks(3)
                .enumerate()
                .all(|(r, row)| row.iter().all(|&v| v == r as f32))
        );
    }
}
