//! Row-major f32 matrix products on the `gemm` crate (the kernels flex itself uses), with the
//! transposes the block's backward needs expressed as strides rather than copies.

/// A row-major matrix view: `rows × cols` values, row `i` at `data[i * cols ..]`.
#[derive(Debug, Clone, Copy)]
pub struct Mat<'a> {
    /// The values, `rows * cols` of them.
    pub data: &'a [f32],
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
}

impl<'a> Mat<'a> {
    /// A view of `data` as `rows × cols`.
    ///
    /// # Panics
    /// If `data` does not hold exactly `rows * cols` values.
    pub fn new(data: &'a [f32], rows: usize, cols: usize) -> Self {
        assert_eq!(
            data.len(),
            rows * cols,
            "matrix {rows}×{cols} over {} values",
            data.len()
        );
        Self { data, rows, cols }
    }

    /// `[rows, cols]` of `op(self)`.
    fn op_dims(self, op: Op) -> [usize; 2] {
        match op {
            Op::N => [self.rows, self.cols],
            Op::T => [self.cols, self.rows],
        }
    }
}

/// How a product reads a matrix: as stored, or transposed (BLAS's `N` and `T`). A transpose
/// is a choice of strides, never a copy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `x`.
    N,
    /// `xᵀ`.
    T,
}

/// What a product does with the destination's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Write {
    /// `dst = op(a) · op(b)`.
    Overwrite,
    /// `dst += op(a) · op(b)`.
    Accumulate,
}

/// Where a product runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Threads {
    /// On the rayon pool, when it is large enough to gain from it.
    Pool,
    /// On the calling thread (a caller that already runs one product per thread).
    One,
}

/// Below this many multiply-adds one thread is faster than two (flex's own threshold).
const PARALLEL_MACS: usize = 192 * 192 * 192;

/// `dst (m×n) = [dst +] op(a) · op(b)`, where `op(x)` is `x` or `xᵀ` as `ta` / `tb` say;
/// `write` says whether it overwrites `dst` or adds to it.
///
/// # Panics
/// If the shapes do not chain or `dst` does not hold `m × n` values.
pub fn matmul(dst: &mut [f32], a: Mat, ta: Op, b: Mat, tb: Op, write: Write) {
    let [m, n, k] = product_dims(a, ta, b, tb);
    assert_eq!(dst.len(), m * n, "destination is not {m}×{n}");
    if k == 0 {
        if write == Write::Overwrite {
            dst.fill(0.0);
        }
        return;
    }
    // SAFETY: `dst` holds m × n values and, borrowed mutably, aliases neither input.
    unsafe { product(dst.as_mut_ptr(), a, ta, b, tb, write, Threads::Pool) }
}

/// `op(a) · op(b)` into a new `m × n` vector, written by the product alone (no zeroing pass).
pub fn matmul_new(a: Mat, ta: Op, b: Mat, tb: Op) -> Vec<f32> {
    let [m, n, k] = product_dims(a, ta, b, tb);
    if k == 0 || m * n == 0 {
        return vec![0.0; m * n];
    }
    let mut out: Vec<f32> = Vec::with_capacity(m * n);
    // SAFETY: the capacity holds m × n values; with k > 0 and no accumulation gemm writes every
    // one of them without reading any, and only then does the length cover them.
    unsafe {
        product(out.as_mut_ptr(), a, ta, b, tb, Write::Overwrite, Threads::Pool);
        out.set_len(m * n);
    }
    out
}

/// Rows per chunk of [`matmul_tn`]: fixed, so the sum's order does not depend on the threads.
const TN_CHUNK_ROWS: usize = 8192;

/// `aᵀ · b` for tall `a` (`[k, m]`) and `b` (`[k, n]`), as a weight gradient is: the rows are
/// cut into fixed chunks whose products run one per thread and are added in order. gemm
/// threads such a product over its small `m × n` output alone and reaches half its speed.
pub fn matmul_tn(a: Mat, b: Mat) -> Vec<f32> {
    use rayon::prelude::*;
    assert_eq!(a.rows, b.rows, "inner dimensions differ");
    let (m, n, k) = (a.cols, b.cols, a.rows);
    if k <= TN_CHUNK_ROWS {
        return matmul_new(a, Op::T, b, Op::N);
    }
    let part = |c: usize| {
        let rows = c * TN_CHUNK_ROWS..((c + 1) * TN_CHUNK_ROWS).min(k);
        let (a, b) = (row_range(a, rows.clone()), row_range(b, rows));
        let mut out = vec![0.0; m * n];
        // SAFETY: `out` holds m × n values and aliases neither input.
        unsafe { product(out.as_mut_ptr(), a, Op::T, b, Op::N, Write::Overwrite, Threads::One) };
        out
    };
    let parts: Vec<Vec<f32>> = (0..k.div_ceil(TN_CHUNK_ROWS)).into_par_iter().map(part).collect();
    let mut total = vec![0.0; m * n];
    for p in parts {
        total.iter_mut().zip(p).for_each(|(t, p)| *t += p);
    }
    total
}

/// Rows `rows` of `x`.
fn row_range(x: Mat, rows: std::ops::Range<usize>) -> Mat {
    Mat::new(&x.data[rows.start * x.cols..rows.end * x.cols], rows.len(), x.cols)
}

/// `[m, n, k]` of `op(a) · op(b)`.
fn product_dims(a: Mat, ta: Op, b: Mat, tb: Op) -> [usize; 3] {
    let [m, k] = a.op_dims(ta);
    let [kb, n] = b.op_dims(tb);
    assert_eq!(k, kb, "inner dimensions differ");
    [m, n, k]
}

/// # Safety
/// `dst` must be valid for writes (and, with [`Write::Accumulate`], reads) of `m × n` values
/// and alias neither input; `k > 0`.
unsafe fn product(dst: *mut f32, a: Mat, ta: Op, b: Mat, tb: Op, write: Write, threads: Threads) {
    let [m, n, k] = product_dims(a, ta, b, tb);
    // Element (i, j) of op(x) sits at i·rs + j·cs, inside its slice by `Mat::new`'s check.
    let strides = |x: Mat, t: Op| match t {
        Op::N => (x.cols as isize, 1),
        Op::T => (1, x.cols as isize),
    };
    let (a_rs, a_cs) = strides(a, ta);
    let (b_rs, b_cs) = strides(b, tb);
    let accumulate = write == Write::Accumulate;
    let parallelism = if threads == Threads::Pool && m * n * k >= PARALLEL_MACS {
        gemm::Parallelism::Rayon(0)
    } else {
        gemm::Parallelism::None
    };
    // SAFETY: the caller's contract for `dst`; the inputs' strides stay inside their slices.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst,
            1,
            n as isize,
            accumulate,
            a.data.as_ptr(),
            a_cs,
            a_rs,
            b.data.as_ptr(),
            b_cs,
            b_rs,
            if accumulate { 1.0 } else { 0.0 },
            1.0,
            false,
            false,
            false,
            parallelism,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook triple loop, as the oracle.
    fn naive(a: &[f32], b: &[f32], m: usize, k: usize, n: usize) -> Vec<f32> {
        let mut c = vec![0.0; m * n];
        for i in 0..m {
            for j in 0..n {
                c[i * n + j] = (0..k).map(|l| a[i * k + l] * b[l * n + j]).sum();
            }
        }
        c
    }

    fn op(transposed: bool) -> Op {
        if transposed { Op::T } else { Op::N }
    }

    fn transpose(x: &[f32], rows: usize, cols: usize) -> Vec<f32> {
        (0..cols * rows).map(|i| x[(i % rows) * cols + i / rows]).collect()
    }

    #[test]
    fn every_transpose_combination_matches_the_triple_loop() {
        let (m, k, n) = (5, 7, 3);
        let a: Vec<f32> = (0..m * k).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..k * n).map(|i| (i as f32 * 0.71).cos()).collect();
        let want = naive(&a, &b, m, k, n);
        let at = transpose(&a, m, k);
        let bt = transpose(&b, k, n);
        for (ta, tb) in [(false, false), (true, false), (false, true), (true, true)] {
            let lhs = if ta { Mat::new(&at, k, m) } else { Mat::new(&a, m, k) };
            let rhs = if tb { Mat::new(&bt, n, k) } else { Mat::new(&b, k, n) };
            let mut c = vec![1.0; m * n];
            matmul(&mut c, lhs, op(ta), rhs, op(tb), Write::Accumulate);
            assert!(
                c.iter().zip(&want).all(|(x, y)| (x - 1.0 - y).abs() < 1e-5),
                "({ta}, {tb}) accumulate"
            );
            matmul(&mut c, lhs, op(ta), rhs, op(tb), Write::Overwrite);
            assert!(c.iter().zip(&want).all(|(x, y)| (x - y).abs() < 1e-5), "({ta}, {tb})");
        }
    }

    #[test]
    fn a_new_product_matches_the_in_place_one() {
        let a: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let b: Vec<f32> = (0..8).map(|i| 1.0 - i as f32).collect();
        let new = matmul_new(Mat::new(&a, 6, 2), Op::N, Mat::new(&b, 4, 2), Op::T);
        assert_eq!(new, naive(&a, &transpose(&b, 4, 2), 6, 2, 4));
    }

    #[test]
    fn a_chunked_transposed_product_matches_the_triple_loop() {
        // 20,000 rows: three chunks, the last one short.
        let (k, m, n) = (20_000, 3, 2);
        let a: Vec<f32> = (0..k * m).map(|i| ((i % 13) as f32 - 6.0) * 0.1).collect();
        let b: Vec<f32> = (0..k * n).map(|i| ((i % 7) as f32 - 3.0) * 0.1).collect();
        let want = naive(&transpose(&a, k, m), &b, m, k, n);
        let got = matmul_tn(Mat::new(&a, k, m), Mat::new(&b, k, n));
        assert!(
            got.iter()
                .zip(&want)
                .all(|(x, y)| (x - y).abs() <= 1e-3 * y.abs().max(1.0)),
            "{got:?} {want:?}"
        );
    }

    #[test]
    fn an_empty_inner_dimension_gives_zeros() {
        let mut c = vec![3.0; 4];
        matmul(
            &mut c,
            Mat::new(&[], 2, 0),
            Op::N,
            Mat::new(&[], 0, 2),
            Op::N,
            Write::Overwrite,
        );
        assert_eq!(c, [0.0; 4]);
    }
}
