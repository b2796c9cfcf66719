//! The StarNet block's forward and backward on raw f32 rows, the maths of
//! [`crate::nn::StarNetBlock`] rearranged so that nothing per point is computed twice:
//!
//! - The pooled half of the concat is per center: `BN(concat(x, g)) · W₁ = BN_x(x) · W₁ₓ +
//!   BN_g(g) · W₁g`, so its product is taken once per center (N rows, not N·P).
//! - BatchNorm is folded into the following Linear: `BN(x) · W = x · (diag(s) W) + t · W` with
//!   `s = γ / √(σ² + ε)` and `t = β − μ s`, so the normalised rows are never written; the
//!   weight gradient unfolds the same way, `BN(x)ᵀ dz = diag(s) (xᵀ dz) + t ⊗ Σ_rows dz`.
//!
//! - The BatchNorms' backward sums (`Σ dy`, `Σ dy x`) come from the weight gradient's product:
//!   with `dy = dz · Wᵀ`, `Σ_rows dy = W Σ_rows dz` and `Σ_rows dy ⊙ x = Σ_k W ⊙ (xᵀ dz)`, so no
//!   pass over the rows is spent on them.
//!
//! Rows are the real points of the N centers, packed center-major ([`Packed`]): a padded slot
//! of the composed block's `[N, P]` layout, zero there on the way in and out and in every
//! gradient, is simply absent. Batch statistics are over the real rows (the pooled half weighs
//! each center by its real-point count, as the broadcast concat does).

use super::gemm::{Mat, Op, matmul_new, matmul_tn};
pub use super::moments::BnStats;
use super::moments::Moments;
use super::packed::Packed;
use super::rows::{add, col_sums, for_rows, map_chunks, relu, relu_passes};

/// The block's widths.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockDims {
    /// Input width d.
    pub d_in: usize,
    /// Hidden width H.
    pub d_hidden: usize,
    /// Output width O.
    pub d_out: usize,
}

/// The block's parameters, in Burn's layouts (Linear weights `[d_in, d_out]`).
#[derive(Debug, Clone, Copy)]
pub struct BlockParams<'a> {
    /// BN₁ scale `[2d]` (the point half, then the pooled half).
    pub gamma1: &'a [f32],
    /// BN₁ shift `[2d]`.
    pub beta1: &'a [f32],
    /// fc1 weight `[2d, H]`.
    pub w1: &'a [f32],
    /// BN₂ scale `[H]`.
    pub gamma2: &'a [f32],
    /// BN₂ shift `[H]`.
    pub beta2: &'a [f32],
    /// fc2 weight `[H, O]`.
    pub w2: &'a [f32],
    /// Added to the variances.
    pub epsilon: f32,
}

/// One block's two BatchNorms' statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockStats {
    /// BN₁'s `[2d]`.
    pub bn1: BnStats,
    /// BN₂'s `[H]`.
    pub bn2: BnStats,
}

/// Where the BatchNorms take their statistics from.
#[derive(Debug, Clone, Copy)]
pub enum Normalization<'a> {
    /// The batch's own (training).
    Batch,
    /// Given ones: the running statistics (evaluation).
    Fixed {
        /// BN₁'s `[2d]`.
        bn1: &'a BnStats,
        /// BN₂'s `[H]`.
        bn2: &'a BnStats,
    },
}

/// What the forward computes besides its output, for the backward.
#[derive(Debug, Clone)]
pub struct BlockSaved {
    /// The first layer's ReLU output `[R, H]`.
    pub hidden: Vec<f32>,
    /// Max over each center's points `[N, d]` (0 for a center without any).
    pub pooled: Vec<f32>,
    /// Which of its center's rows gave each pooled value `[N, d]` (the first of equal ones).
    pub argmax: Vec<u32>,
    /// BN₁'s statistics `[2d]`.
    pub bn1: BnStats,
    /// BN₂'s statistics `[H]`.
    pub bn2: BnStats,
}

/// Gradients with respect to the block's input and parameters (shapes as theirs).
#[derive(Debug, Clone)]
pub struct BlockGrads {
    /// `[R, d]`.
    pub x: Vec<f32>,
    /// `[2d]`.
    pub gamma1: Vec<f32>,
    /// `[2d]`.
    pub beta1: Vec<f32>,
    /// `[2d, H]`.
    pub w1: Vec<f32>,
    /// `[H]`.
    pub gamma2: Vec<f32>,
    /// `[H]`.
    pub beta2: Vec<f32>,
    /// `[H, O]`.
    pub w2: Vec<f32>,
}

/// Max over each center's points, with the row it came from. Inputs are ReLU outputs (≥ 0),
/// so this is the composed block's max of `x · mask` over every slot; a center with no real
/// point pools to 0.
fn pool_max(x: &[f32], rows: &Packed, d: usize) -> (Vec<f32>, Vec<u32>) {
    let mut pooled = vec![0.0; rows.centers() * d];
    let mut argmax = vec![0u32; rows.centers() * d];
    for n in 0..rows.centers() {
        let (g, idx) = (&mut pooled[n * d..(n + 1) * d], &mut argmax[n * d..(n + 1) * d]);
        for (k, r) in rows.range(n).enumerate() {
            for ((g, i), x) in g.iter_mut().zip(idx.iter_mut()).zip(&x[r * d..(r + 1) * d]) {
                // Selects rather than branches, so the loop vectorises.
                let take = k == 0 || *x > *g;
                *g = if take { *x } else { *g };
                *i = if take { k as u32 } else { *i };
            }
        }
    }
    (pooled, argmax)
}

/// `(s, t)` of the folded BatchNorm: `BN(x) = x s + t`.
fn fold(gamma: &[f32], beta: &[f32], stats: &BnStats, eps: f32) -> (Vec<f32>, Vec<f32>) {
    let s: Vec<f32> = gamma
        .iter()
        .zip(&stats.var)
        .map(|(g, v)| g / (v + eps).sqrt())
        .collect();
    let t = beta
        .iter()
        .zip(&stats.mean)
        .zip(&s)
        .map(|((b, m), s)| b - m * s)
        .collect();
    (s, t)
}

/// `diag(s) · w` for `w` `[s.len(), cols]`.
fn scale_rows(w: &[f32], s: &[f32], cols: usize) -> Vec<f32> {
    w.chunks(cols)
        .zip(s)
        .flat_map(|(row, s)| row.iter().map(move |v| v * s))
        .collect()
}

/// `t · w` for `w` `[t.len(), cols]`: a bias row.
fn row_times(t: &[f32], w: &[f32], cols: usize) -> Vec<f32> {
    let mut out = vec![0.0; cols];
    for (row, t) in w.chunks(cols).zip(t) {
        out.iter_mut().zip(row).for_each(|(o, v)| *o += t * v);
    }
    out
}

/// `pooled · s + t` per center: the pooled half after BN₁ `[N, d]`.
fn normalize_pooled(pooled: &[f32], s: &[f32], t: &[f32]) -> Vec<f32> {
    let d = s.len();
    pooled
        .iter()
        .enumerate()
        .map(|(i, g)| g * s[i % d] + t[i % d])
        .collect()
}

/// The training (batch statistics) or evaluation (fixed statistics) forward.
///
/// # Shapes
/// - `x`: `[R, d]` (≥ 0), the rows of `rows`
/// - returns the output `[R, O]` and what the backward needs
pub fn forward(
    x: &[f32],
    rows: &Packed,
    params: BlockParams,
    dims: BlockDims,
    norm: Normalization,
) -> (Vec<f32>, BlockSaved) {
    let BlockDims {
        d_in: d,
        d_hidden: h,
        d_out: o,
    } = dims;
    let (pooled, argmax) = pool_max(x, rows, d);
    let bn1 = match norm {
        Normalization::Batch => batch_stats_bn1(x, rows, &pooled, d),
        Normalization::Fixed { bn1, .. } => bn1.clone(),
    };
    let (s1, t1) = fold(params.gamma1, params.beta1, &bn1, params.epsilon);
    let (w1x, w1g) = params.w1.split_at(d * h);
    // Per center: the point half's shift and the whole pooled half, `[N, H]`.
    let yg = normalize_pooled(&pooled, &s1[d..], &t1[d..]);
    let mut per_center = matmul_new(Mat::new(&yg, rows.centers(), d), Op::N, Mat::new(w1g, d, h), Op::N);
    let shift = row_times(&t1[..d], w1x, h);
    for_rows(&mut per_center, h, |_, row| add(row, &shift));
    let w1s = scale_rows(w1x, &s1[..d], h);
    let mut hidden = matmul_new(Mat::new(x, rows.rows(), d), Op::N, Mat::new(&w1s, d, h), Op::N);
    let batch = matches!(norm, Normalization::Batch);
    // The ReLU pass also takes BN₂'s batch moments, chunk by chunk while the rows are in cache.
    let parts = map_chunks(&mut hidden, h, |r0, chunk| {
        for (i, row) in chunk.chunks_exact_mut(h).enumerate() {
            let n = rows.center_of(r0 + i);
            let c = &per_center[n * h..(n + 1) * h];
            row.iter_mut().zip(c).for_each(|(v, c)| *v = relu(*v + c));
        }
        batch.then(|| Moments::of_rows(chunk, h, None))
    });
    let bn2 = match norm {
        Normalization::Batch => Moments::merge_all(parts.into_iter().flatten().collect(), h)
            .across_replicas()
            .stats(),
        Normalization::Fixed { bn2, .. } => bn2.clone(),
    };
    let (s2, t2) = fold(params.gamma2, params.beta2, &bn2, params.epsilon);
    let bias2 = row_times(&t2, params.w2, o);
    let w2s = scale_rows(params.w2, &s2, o);
    let mut out = matmul_new(Mat::new(&hidden, rows.rows(), h), Op::N, Mat::new(&w2s, h, o), Op::N);
    for_rows(&mut out, o, |_, row| {
        row.iter_mut().zip(&bias2).for_each(|(v, b)| *v = relu(*v + b));
    });
    (
        out,
        BlockSaved {
            hidden,
            pooled,
            argmax,
            bn1,
            bn2,
        },
    )
}

/// BN₁'s batch statistics: the point half over real rows, the pooled half over the same rows
/// (each center's pooled value counted once per real point).
fn batch_stats_bn1(x: &[f32], rows: &Packed, pooled: &[f32], d: usize) -> BnStats {
    let points = Moments::of_rows_chunked(x, d, None).across_replicas().stats();
    let centers = Moments::of_rows_chunked(pooled, d, Some(&rows.counts()))
        .across_replicas()
        .stats();
    BnStats {
        mean: [points.mean, centers.mean].concat(),
        var: [points.var, centers.var].concat(),
    }
}

/// The column sums a BatchNorm's backward needs: `Σ_rows dy` and `Σ_rows dy ⊙ (x − μ)` `[D]`.
struct BnSums {
    dy: Vec<f32>,
    dy_centered: Vec<f32>,
}

impl BnSums {
    /// For `dy = dz · Wᵀ` (`W` `[D, K]`), from `Σ_rows dz` `[K]` and `xᵀ dz` `[D, K]`, which
    /// the weight gradient has computed: `Σ dy = W Σ dz` and `Σ dy ⊙ x = Σ_k W ⊙ (xᵀ dz)`.
    fn through(w: &[f32], dz_sum: &[f32], xt_dz: &[f32], mean: &[f32]) -> Self {
        let k = dz_sum.len();
        let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f32>();
        let dy: Vec<f32> = w.chunks(k).map(|row| dot(row, dz_sum)).collect();
        let dy_centered = w
            .chunks(k)
            .zip(xt_dz.chunks(k))
            .zip(dy.iter().zip(mean))
            .map(|((w, g), (dy, m))| dot(w, g) - m * dy)
            .collect();
        Self { dy, dy_centered }
    }

    /// The sums over the rows of every replica of the calling thread's group
    /// ([`crate::replicas`]; `self` without a group): synchronised BatchNorm's backward.
    fn across_replicas(self) -> Self {
        if crate::replicas::current().is_none() {
            return self;
        }
        let d = self.dy.len();
        let mut both = [self.dy, self.dy_centered].concat();
        crate::replicas::sum(&mut both);
        let dy_centered = both.split_off(d);
        Self { dy: both, dy_centered }
    }
}

/// BatchNorm's backward over weighted rows (batch statistics): `dγ = Σ w dy x̂`, `dβ = Σ w dy`,
/// and, written into `dy`, `dx = (γ/σ)(dy − w (dβ + x̂ dγ) / M)`, where the weight `w` is a
/// row's multiplicity (1 for a point row, `weight` `None`; a center's real-point count for a
/// pooled row, whose `dy` is already the sum over its points) and rows of weight 0 get 0.
struct BnBackward<'a> {
    x: &'a [f32],
    stats: BnStats,
    gamma: &'a [f32],
    eps: f32,
    weight: Option<&'a [f32]>,
    total: f32,
    /// `x` is a ReLU's output and the gradient goes on through it: zero where `x` is not > 0.
    through_relu: bool,
}

impl BnBackward<'_> {
    fn row(&self, r: usize) -> &[f32] {
        let cols = self.gamma.len();
        &self.x[r * cols..(r + 1) * cols]
    }

    /// [`BnSums`] by a pass over the rows of `dy` (`[rows, D]`).
    fn sums(&self, dy: &[f32]) -> BnSums {
        let (cols, mean) = (self.gamma.len(), &self.stats.mean);
        // A pooled row's dy is already the sum over its points: it counts once here.
        let [dy_sum, dy_centered] = col_sums(self.x.len() / cols.max(1), cols, |r, [db, dd]| {
            let g = &dy[r * cols..(r + 1) * cols];
            add(db, g);
            for ((d, g), (x, m)) in dd.iter_mut().zip(g).zip(self.row(r).iter().zip(mean)) {
                *d += g * (x - m);
            }
        });
        BnSums {
            dy: dy_sum,
            dy_centered,
        }
    }

    /// Returns `(dγ, dβ)` from `sums` and turns `dy` (`[rows, D]`) into `dx`.
    fn apply(&self, sums: BnSums, dy: &mut [f32]) -> (Vec<f32>, Vec<f32>) {
        let (cols, mean) = (self.gamma.len(), &self.stats.mean);
        let inv_sigma: Vec<f32> = self.stats.var.iter().map(|v| 1.0 / (v + self.eps).sqrt()).collect();
        // dγ and dβ are this replica's (data-parallel training averages them with the other
        // gradients); dx goes through the statistics of the whole batch, so it takes the sums
        // over the replica group.
        let dgamma: Vec<f32> = sums.dy_centered.iter().zip(&inv_sigma).map(|(d, s)| d * s).collect();
        let dbeta = sums.dy.clone();
        let global = sums.across_replicas();
        // dx = a (dy − w (b + (x − μ) c)), with a = γ/σ, b = Σ dy/M, c = Σ dy (x − μ)/(σ² M).
        let a: Vec<f32> = self.gamma.iter().zip(&inv_sigma).map(|(g, s)| g * s).collect();
        let b: Vec<f32> = global.dy.iter().map(|d| d / self.total).collect();
        let c: Vec<f32> = global
            .dy_centered
            .iter()
            .zip(&inv_sigma)
            .map(|(d, s)| d * s * s / self.total)
            .collect();
        for_rows(dy, cols, |r, row| {
            let w = self.weight.map_or(1.0, |w| w[r]);
            if w == 0.0 {
                return row.fill(0.0);
            }
            let (x, a, b, c, mean) = (&self.row(r)[..cols], &a[..cols], &b[..cols], &c[..cols], &mean[..cols]);
            for j in 0..row.len().min(cols) {
                let g = a[j] * (row[j] - w * (b[j] + (x[j] - mean[j]) * c[j]));
                row[j] = if self.through_relu && !relu_passes(x[j]) {
                    0.0
                } else {
                    g
                };
            }
        });
        (dgamma, dbeta)
    }
}

/// A weight gradient through a folded BatchNorm, `dW = diag(s)(xᵀ dz) + t ⊗ Σ_rows dz`, and
/// the product `xᵀ dz` (`[D, K]`) that the BatchNorm's own backward reuses.
struct FoldedGrad {
    w: Vec<f32>,
    xt_dz: Vec<f32>,
}

fn folded_weight_grad(x: Mat, dz: Mat, dz_sum: &[f32], s: &[f32], t: &[f32]) -> FoldedGrad {
    let xt_dz = matmul_tn(x, dz);
    let mut w = xt_dz.clone();
    for_rows(&mut w, dz.cols, |i, row| {
        row.iter_mut().zip(dz_sum).for_each(|(g, c)| *g = s[i] * *g + t[i] * c);
    });
    FoldedGrad { w, xt_dz }
}

/// Zeroes `grad` (`[rows, cols]`) where the ReLU that produced `out` was off, and returns the
/// column sums of the result.
pub(super) fn relu_backward_sum(grad: &mut [f32], out: &[f32], cols: usize) -> Vec<f32> {
    let parts = map_chunks(grad, cols, |r0, chunk| {
        let mut sum = vec![0.0; cols];
        for (i, row) in chunk.chunks_exact_mut(cols).enumerate() {
            let out = &out[(r0 + i) * cols..(r0 + i + 1) * cols];
            row.iter_mut()
                .zip(out)
                .for_each(|(g, o)| *g = if relu_passes(*o) { *g } else { 0.0 });
            add(&mut sum, row);
        }
        sum
    });
    sum_parts(parts, cols)
}

/// Column sums of `x` (`[rows, cols]`), in fixed chunks.
pub(super) fn column_sums(x: &[f32], cols: usize) -> Vec<f32> {
    let [sum] = col_sums(x.len() / cols.max(1), cols, |r, [acc]| {
        add(acc, &x[r * cols..(r + 1) * cols])
    });
    sum
}

/// The element-wise sum of `parts`, in order.
fn sum_parts(parts: Vec<Vec<f32>>, cols: usize) -> Vec<f32> {
    parts.into_iter().fold(vec![0.0; cols], |mut total, p| {
        add(&mut total, &p);
        total
    })
}

/// A training forward's results, as the backward reads them.
#[derive(Debug, Clone, Copy)]
pub struct Forward<'a> {
    /// The output `[N·P, O]`.
    pub out: &'a [f32],
    /// The rest.
    pub saved: &'a BlockSaved,
}

/// The backward of the training forward ([`Normalization::Batch`]).
///
/// # Shapes
/// - `x`, `rows`: as in [`forward`]; `fwd`: its results; `d_out`: `[R, O]`
pub fn backward(
    x: &[f32],
    rows: &Packed,
    params: BlockParams,
    dims: BlockDims,
    fwd: Forward,
    d_out: &[f32],
) -> BlockGrads {
    // The whole batch's real rows, over the replica group when training data-parallel.
    let total = crate::replicas::sum_scalar(rows.rows() as f32).max(1.0);
    let second = second_layer_backward(rows.rows(), params, dims, fwd, d_out, total);
    let first = first_layer_backward(x, rows, params, dims, fwd.saved, second.dz1, total);
    BlockGrads {
        x: first.dx,
        gamma1: first.gamma1,
        beta1: first.beta1,
        w1: first.w1,
        gamma2: second.gamma2,
        beta2: second.beta2,
        w2: second.w2,
    }
}

/// The second layer's gradients, and the first layer's pre-activation gradient.
struct SecondLayerGrads {
    /// `[R, H]`.
    dz1: Vec<f32>,
    gamma2: Vec<f32>,
    beta2: Vec<f32>,
    w2: Vec<f32>,
}

/// BN₂ → fc2 → ReLU, backwards.
fn second_layer_backward(
    rows: usize,
    params: BlockParams,
    dims: BlockDims,
    fwd: Forward,
    d_out: &[f32],
    total: f32,
) -> SecondLayerGrads {
    let (h, o) = (dims.d_hidden, dims.d_out);
    let mut dz2 = d_out.to_vec();
    let dz2_sum = relu_backward_sum(&mut dz2, fwd.out, o);
    let fwd = fwd.saved;
    let (s2, t2) = fold(params.gamma2, params.beta2, &fwd.bn2, params.epsilon);
    let hidden = Mat::new(&fwd.hidden, rows, h);
    let w2 = folded_weight_grad(hidden, Mat::new(&dz2, rows, o), &dz2_sum, &s2, &t2);
    let mut dz1 = matmul_new(Mat::new(&dz2, rows, o), Op::N, Mat::new(params.w2, h, o), Op::T);
    let bn = BnBackward {
        x: &fwd.hidden,
        stats: fwd.bn2.clone(),
        gamma: params.gamma2,
        eps: params.epsilon,
        weight: None,
        total,
        through_relu: true,
    };
    let sums = BnSums::through(params.w2, &dz2_sum, &w2.xt_dz, &fwd.bn2.mean);
    let (gamma2, beta2) = bn.apply(sums, &mut dz1);
    SecondLayerGrads {
        dz1,
        gamma2,
        beta2,
        w2: w2.w,
    }
}

/// The first layer's gradients and the input's.
struct FirstLayerGrads {
    dx: Vec<f32>,
    gamma1: Vec<f32>,
    beta1: Vec<f32>,
    w1: Vec<f32>,
}

/// max-pool → BN₁ → fc1, backwards, from fc1's pre-activation gradient `dz1` `[R, H]`.
fn first_layer_backward(
    x: &[f32],
    rows: &Packed,
    params: BlockParams,
    dims: BlockDims,
    fwd: &BlockSaved,
    dz1: Vec<f32>,
    total: f32,
) -> FirstLayerGrads {
    let BlockDims {
        d_in: d, d_hidden: h, ..
    } = dims;
    let centers = rows.centers();
    let (s1, t1) = fold(params.gamma1, params.beta1, &fwd.bn1, params.epsilon);
    let (w1x, w1g) = params.w1.split_at(d * h);
    // The pooled half's gradient, summed over each center's points `[N, H]`.
    let mut dz_center = vec![0.0; centers * h];
    for_rows(&mut dz_center, h, |n, row| {
        for r in rows.range(n) {
            row.iter_mut().zip(&dz1[r * h..(r + 1) * h]).for_each(|(a, g)| *a += g);
        }
    });
    // Σ over the rows is Σ over the centers' sums.
    let dz1_sum = column_sums(&dz_center, h);
    let first = folded_weight_grad(
        Mat::new(x, rows.rows(), d),
        Mat::new(&dz1, rows.rows(), h),
        &dz1_sum,
        &s1[..d],
        &t1[..d],
    );
    let mut w1 = first.w;
    let yg = normalize_pooled(&fwd.pooled, &s1[d..], &t1[d..]);
    let w1_pooled = matmul_tn(Mat::new(&yg, centers, d), Mat::new(&dz_center, centers, h));
    w1.extend_from_slice(&w1_pooled);
    let mut d_pooled = matmul_new(Mat::new(&dz_center, centers, h), Op::N, Mat::new(w1g, d, h), Op::T);
    let mut dx = matmul_new(Mat::new(&dz1, rows.rows(), h), Op::N, Mat::new(w1x, d, h), Op::T);
    drop(dz1);
    let half = |from: usize, to: usize| BnStats {
        mean: fwd.bn1.mean[from..to].to_vec(),
        var: fwd.bn1.var[from..to].to_vec(),
    };
    let (eps, gamma) = (params.epsilon, params.gamma1.split_at(d));
    let points = BnBackward {
        x,
        stats: half(0, d),
        gamma: gamma.0,
        eps,
        weight: None,
        total,
        through_relu: false,
    };
    let sums = BnSums::through(w1x, &dz1_sum, &first.xt_dz, &points.stats.mean);
    let (gamma_x, beta_x) = points.apply(sums, &mut dx);
    let counts = rows.counts();
    let pooled = BnBackward {
        x: &fwd.pooled,
        stats: half(d, 2 * d),
        gamma: gamma.1,
        eps,
        weight: Some(&counts),
        total,
        through_relu: false,
    };
    let (gamma_g, beta_g) = pooled.apply(pooled.sums(&d_pooled), &mut d_pooled);
    scatter_pooled(&mut dx, &d_pooled, fwd, rows, d);
    FirstLayerGrads {
        dx,
        gamma1: [gamma_x, gamma_g].concat(),
        beta1: [beta_x, beta_g].concat(),
        w1,
    }
}

/// Routes each pooled value's gradient to the row it was taken from (the max's backward); a
/// center without points has none.
fn scatter_pooled(dx: &mut [f32], grad_g: &[f32], fwd: &BlockSaved, rows: &Packed, d: usize) {
    for n in (0..rows.centers()).filter(|&n| !rows.range(n).is_empty()) {
        let first = rows.range(n).start;
        for c in 0..d {
            let r = first + fwd.argmax[n * d + c] as usize;
            dx[r * d + c] += grad_g[n * d + c];
        }
    }
}
