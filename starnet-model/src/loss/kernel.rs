//! The StarNet loss and its gradient on raw f32 rows: the maths of [`super::starnet_loss_composed`]
//! in one pass over the anchors instead of some forty whole-tensor operations (each a fresh
//! buffer and a memory pass, forward and backward). The regression terms visit only the anchors
//! with a regression weight (the foreground, a few percent), since the others add exactly 0.
//!
//! Rows are anchors (`B · C · A`, in the tensors' order). Each term is a weighted sum over rows
//! divided by the batch size B, accumulated in f64 over fixed chunks of rows added in order, so
//! it does not depend on the threads. Element-wise values are f32, with the composed path's
//! formulas. The forward keeps every term's slope (per logit, and per regressed anchor), so the
//! backward only scales them and keeps neither the predictions nor the targets.

use super::heading::HeadingLoss;
use rayon::prelude::*;

/// Anchors per parallel chunk of the classification pass (fixed, for thread-independent sums).
const CHUNK: usize = 4096;

/// The loss settings the kernel needs (the weights that combine the terms stay outside).
#[derive(Debug, Clone, PartialEq)]
pub struct KernelConfig {
    /// Focal α.
    pub alpha: f32,
    /// Focal γ.
    pub gamma: f32,
    /// Huber δ.
    pub huber_delta: f32,
    /// Heading comparison.
    pub heading: HeadingLoss,
    /// Weight of each class column's focal term (missing columns weigh 1).
    pub class_weights: Vec<f32>,
}

/// The network's outputs, row-major.
#[derive(Debug, Clone, Copy)]
pub struct Predictions<'a> {
    /// Class logits `[N, K]`.
    pub cls_logits: &'a [f32],
    /// Box residuals `[N, 7]`.
    pub box_residuals: &'a [f32],
    /// Direction-bin logits `[N, 2]`, when the model has the classifier.
    pub dir_logits: Option<&'a [f32]>,
}

/// The assignment's targets, row-major (see [`super::LossTargets`]).
#[derive(Debug, Clone, Copy)]
pub struct Targets<'a> {
    /// One-hot classes `[N, K]`.
    pub classes: &'a [f32],
    /// Classification weight `[N]`.
    pub cls_weight: &'a [f32],
    /// Encoded residuals `[N, 7]`.
    pub residuals: &'a [f32],
    /// Regression weight `[N]`.
    pub reg_weight: &'a [f32],
    /// Direction bin `[N]` (0.0 or 1.0).
    pub direction: &'a [f32],
}

impl Targets<'_> {
    fn rows(&self) -> usize {
        self.cls_weight.len()
    }

    fn classes_per_row(&self) -> usize {
        self.classes.len() / self.rows().max(1)
    }

    /// Rows with a regression weight: the only ones the regression terms see.
    fn regressed(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.rows()).filter(|&i| self.reg_weight[i] != 0.0)
    }
}

/// The five unweighted terms, each summed over anchors and averaged over the batch.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Terms {
    /// Focal classification.
    pub classification: f32,
    /// Position residuals (x, y, z).
    pub location: f32,
    /// Size residuals.
    pub dimension: f32,
    /// Heading residual.
    pub rotation: f32,
    /// Direction-bin cross-entropy (0 without the classifier).
    pub direction: f32,
}

impl Terms {
    /// The terms in order: classification, location, dimension, rotation, direction.
    pub fn to_array(self) -> [f32; 5] {
        [
            self.classification,
            self.location,
            self.dimension,
            self.rotation,
            self.direction,
        ]
    }

    /// [`Self::to_array`]'s inverse.
    pub fn from_array([classification, location, dimension, rotation, direction]: [f32; 5]) -> Self {
        Self {
            classification,
            location,
            dimension,
            rotation,
            direction,
        }
    }
}

/// A forward's result: the terms and each term's slope, all the backward needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Forward {
    /// The five terms.
    pub terms: Terms,
    /// Their slopes with respect to the predictions.
    pub slopes: Slopes,
}

/// Each term's derivative with respect to the predictions, times the batch size (the anchor
/// weights included, the terms' upstream factors not).
#[derive(Debug, Clone, PartialEq)]
pub struct Slopes {
    /// `cls_weight · ∂focal/∂logit` per logit `[N, K]`.
    pub cls: Vec<f32>,
    /// The regressed anchors' slopes, in row order (every other row's are 0).
    pub regressed: Vec<RowSlope>,
    /// Rows N.
    pub rows: usize,
    /// Whether the predictions have direction logits.
    pub has_direction: bool,
}

/// One regressed anchor's slopes, times its regression weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowSlope {
    /// The anchor (row).
    pub row: usize,
    /// Per residual: ∂(location | dimension | rotation)/∂residual, by the residual's term.
    pub boxes: [f32; 7],
    /// ∂direction/∂(l₁ − l₀).
    pub direction: f32,
}

/// The gradients of a weighted sum of the terms with respect to the predictions.
#[derive(Debug, Clone, PartialEq)]
pub struct Gradients {
    /// `[N, K]`.
    pub cls_logits: Vec<f32>,
    /// `[N, 7]`.
    pub box_residuals: Vec<f32>,
    /// `[N, 2]`, when the predictions have direction logits.
    pub dir_logits: Option<Vec<f32>>,
}

/// Focal loss of one logit and its derivative, `(f, df/dx)`, for target `y`.
fn focal(x: f32, y: f32, alpha: f32, gamma: f32) -> (f32, f32) {
    let ce = x.max(0.0) - x * y + (-x.abs()).exp().ln_1p();
    let p = 1.0 / (1.0 + (-x).exp());
    let p_t = p * y + (1.0 - p) * (1.0 - y);
    let q = 1.0 - p_t;
    let modulator = pow(q, gamma);
    let alpha_t = y * alpha + (1.0 - y) * (1.0 - alpha);
    // d(1 − p_t)/dx = −(2y − 1) p (1 − p); γ q^(γ−1) is 0 at q = 0 unless γ = 1 (and for γ < 1,
    // where it is infinite, ce is 0 there too: the product is taken as 0).
    let dq = -(2.0 * y - 1.0) * p * (1.0 - p);
    let dmod = if gamma == 0.0 {
        0.0
    } else if q > 0.0 {
        gamma * pow(q, gamma - 1.0) * dq
    } else if gamma == 1.0 {
        dq
    } else {
        0.0
    };
    (ce * modulator * alpha_t, alpha_t * ((p - y) * modulator + ce * dmod))
}

/// `q^e`, by multiplication for the usual focal exponents (γ = 2 and γ − 1 = 1).
fn pow(q: f32, e: f32) -> f32 {
    if e == 2.0 {
        q * q
    } else if e == 1.0 {
        q
    } else {
        q.powf(e)
    }
}

/// Huber of `x` and its derivative.
fn huber(x: f32, delta: f32) -> (f32, f32) {
    if x.abs() <= delta {
        (0.5 * x * x / delta, x / delta)
    } else {
        (x.abs() - 0.5 * delta, x.signum())
    }
}

/// The heading's Huber term of residual difference `d` and its derivative in `d`.
fn heading(d: f32, cfg: &KernelConfig) -> (f32, f32) {
    match cfg.heading {
        HeadingLoss::Sin => {
            let (s, c) = d.sin_cos();
            let (h, dh) = huber(s, cfg.huber_delta);
            (h, dh * c)
        }
        HeadingLoss::Wrap => {
            let tau = std::f32::consts::TAU;
            huber(d - ((d + std::f32::consts::PI) / tau).floor() * tau, cfg.huber_delta)
        }
    }
}

/// Two-bin cross-entropy of logits `l` against bin `y` and its derivative in `l₁ − l₀`.
fn two_bin(l: &[f32], y: f32) -> (f32, f32) {
    let d = l[1] - l[0];
    let ce = d.max(0.0) - d * y + (-d.abs()).exp().ln_1p();
    (ce, 1.0 / (1.0 + (-d).exp()) - y)
}

/// The five terms and their slopes for [`backward`].
///
/// # Shapes
/// `N` anchors over `batch` frames; see [`Predictions`] and [`Targets`].
pub fn forward(p: Predictions, t: Targets, cfg: &KernelConfig, batch: usize) -> Forward {
    let (classification, cls) = classification(p, t, cfg);
    let mut sums = [classification, 0.0, 0.0, 0.0, 0.0];
    let mut regressed = Vec::new();
    for i in t.regressed() {
        let w = t.reg_weight[i];
        let d = |j: usize| p.box_residuals[i * 7 + j] - t.residuals[i * 7 + j];
        let mut slope = RowSlope {
            row: i,
            boxes: [0.0; 7],
            direction: 0.0,
        };
        let mut part = [0f32; 3];
        for j in 0..7 {
            let (h, dh) = if j < 6 {
                huber(d(j), cfg.huber_delta)
            } else {
                heading(d(6), cfg)
            };
            part[term_of_residual(j) - 1] += h;
            slope.boxes[j] = w * dh;
        }
        for (sum, part) in sums[1..4].iter_mut().zip(part) {
            *sum += (w * part) as f64;
        }
        if let Some(l) = p.dir_logits {
            let (ce, dce) = two_bin(&l[i * 2..i * 2 + 2], t.direction[i]);
            sums[4] += (w * ce) as f64;
            slope.direction = w * dce;
        }
        regressed.push(slope);
    }
    let slopes = Slopes {
        cls,
        regressed,
        rows: t.rows(),
        has_direction: p.dir_logits.is_some(),
    };
    Forward {
        terms: Terms::from_array(sums.map(|s| (s / batch as f64) as f32)),
        slopes,
    }
}

/// Which term (index in [`Terms::to_array`]) residual `j` feeds: location, dimension, rotation.
fn term_of_residual(j: usize) -> usize {
    match j {
        0..3 => 1,
        3..6 => 2,
        _ => 3,
    }
}

/// The classification term's weighted sum over rows (in fixed chunks) and its slope per logit.
fn classification(p: Predictions, t: Targets, cfg: &KernelConfig) -> (f64, Vec<f32>) {
    let k = t.classes_per_row().max(1);
    let class_weights: Vec<f32> = (0..k)
        .map(|c| cfg.class_weights.get(c).copied().unwrap_or(1.0))
        .collect();
    let mut slope = vec![0.0; p.cls_logits.len()];
    let partial: Vec<f64> = slope
        .par_chunks_mut(CHUNK * k)
        .enumerate()
        .map(|(chunk, slope)| {
            let mut sum = 0f64;
            for (e, s) in (chunk * CHUNK * k..).zip(slope.iter_mut()) {
                let (f, df) = focal(p.cls_logits[e], t.classes[e], cfg.alpha, cfg.gamma);
                let w = t.cls_weight[e / k] * class_weights[e % k];
                sum += (f * w) as f64;
                *s = df * w;
            }
            sum
        })
        .collect();
    (partial.iter().sum(), slope)
}

/// The gradient of `Σ upstream[term] · term` with respect to the predictions, from the
/// forward's slopes of a batch of `batch` frames.
pub fn backward(slopes: &Slopes, batch: usize, upstream: Terms) -> Gradients {
    let g = upstream.to_array().map(|u| u / batch as f32);
    let cls_logits = slopes.cls.par_iter().with_min_len(CHUNK).map(|s| g[0] * s).collect();
    let mut box_residuals = vec![0.0; slopes.rows * 7];
    let mut dir_logits = slopes.has_direction.then(|| vec![0.0; slopes.rows * 2]);
    for r in &slopes.regressed {
        for (j, s) in r.boxes.iter().enumerate() {
            box_residuals[r.row * 7 + j] = g[term_of_residual(j)] * s;
        }
        if let Some(out) = dir_logits.as_mut() {
            let dd = g[4] * r.direction;
            out[r.row * 2] = -dd;
            out[r.row * 2 + 1] = dd;
        }
    }
    Gradients {
        cls_logits,
        box_residuals,
        dir_logits,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `f` at `x`, in f64 around f32 evaluations.
    fn derivative(f: impl Fn(f32) -> f32, x: f32) -> f64 {
        let h = 1e-3f32;
        (f(x + h) as f64 - f(x - h) as f64) / (2.0 * h as f64)
    }

    #[test]
    fn element_derivatives_match_finite_differences() {
        for &(x, y) in &[(1.3f32, 1.0f32), (-0.7, 0.0), (0.05, 1.0), (-2.5, 0.0), (3.0, 0.0)] {
            for gamma in [0.0f32, 1.0, 2.0] {
                let fd = derivative(|x| focal(x, y, 0.25, gamma).0, x);
                let d = focal(x, y, 0.25, gamma).1 as f64;
                assert!(
                    (d - fd).abs() < 2e-3 * fd.abs().max(1.0),
                    "focal({x}, {y}, γ {gamma}): {d} vs {fd}"
                );
            }
        }
        for x in [0.03f32, -0.08, 0.5, -2.0] {
            let fd = derivative(|x| huber(x, 1.0 / 9.0).0, x);
            assert!((huber(x, 1.0 / 9.0).1 as f64 - fd).abs() < 2e-3, "huber({x})");
        }
        for heading_loss in [HeadingLoss::Sin, HeadingLoss::Wrap] {
            let cfg = KernelConfig {
                alpha: 0.25,
                gamma: 2.0,
                huber_delta: 1.0 / 9.0,
                heading: heading_loss,
                class_weights: Vec::new(),
            };
            for d in [0.05f32, -0.3, 2.0, 4.0, -3.5] {
                let fd = derivative(|d| heading(d, &cfg).0, d);
                assert!((heading(d, &cfg).1 as f64 - fd).abs() < 2e-3, "{heading_loss:?}({d})");
            }
        }
        for (l, y) in [([0.3f32, -1.2], 1.0f32), ([2.0, 2.5], 0.0)] {
            let fd = derivative(|d| two_bin(&[0.0, d], y).0, l[1] - l[0]);
            assert!((two_bin(&l, y).1 as f64 - fd).abs() < 2e-3);
        }
    }
}
