//! The StarNet model (paper §3.3, lingvo `starnet.ModelV2`): featurizer → projector (BN →
//! Linear(cell → G²·D) → ReLU, one D-dim feature per grid offset) → heads shared across offsets:
//! class logits (bias −4.595, a 0.01 prior), box residuals (zero-initialised) and, optionally,
//! two direction-bin logits per anchor (SECOND's direction classifier, [`crate::coder`]).
//!
//! The streaming variant adds a [`SliceLstm`] between featurizer and projector
//! ([`StarNet::forward_slices`]); without it every center is independent of the others.

use super::fused::head_op::{self, HeadTensors};
use super::row_layout::{self, RowLayout};
use super::{
    Bias, Featurizer, FeaturizerConfig, MaskedBatchNorm, MaskedBatchNormConfig, RunningStats, SliceLstm,
    SliceLstmConfig, SliceState, linear,
};
use burn::module::{Module, Param};
use burn::nn::Linear;
use burn::prelude::*;
use burn::tensor::activation::relu;
use starnet_data::sampling::AnchorGrid;

/// The model's inputs for a batch.
#[derive(Debug, Clone)]
pub struct ModelInput {
    /// Neighbourhood features `[B, C, P, F]`.
    pub points: Tensor<4>,
    /// `[B, C, P]`: 1.0 for real points, 0.0 for padding.
    pub mask: Tensor<3>,
    /// `[B, C]`: 1.0 for real centers, 0.0 for repeats that pad a small pool.
    pub center_valid: Tensor<2>,
}

/// The model's outputs for a batch.
#[derive(Debug, Clone)]
pub struct ModelOutput {
    /// Class logits `[B, C, A, K]`.
    pub cls_logits: Tensor<4>,
    /// Box residuals `[B, C, A, 7]` (see [`crate::coder`]).
    pub box_residuals: Tensor<4>,
    /// Direction-bin logits `[B, C, A, 2]` ([`crate::coder::direction_bin`]), when the model
    /// has the direction classifier.
    pub dir_logits: Option<Tensor<4>>,
}

/// The heads' outputs per grid offset, before they are laid out per anchor.
struct OffsetOutputs {
    /// `[BC·G², R·Pr·K]`.
    cls: Tensor<2>,
    /// `[BC·G², R·Pr·7]`.
    reg: Tensor<2>,
    /// `[BC·G², R·Pr·2]`.
    dir: Option<Tensor<2>>,
}

/// Configuration of [`StarNet`].
#[derive(Config, Debug)]
pub struct StarNetConfig {
    /// The featurizer.
    pub featurizer: FeaturizerConfig,
    /// Per-offset feature width D.
    pub d_offset: usize,
    /// Anchors around each center (their count A and order fix the heads' layout).
    pub anchors: AnchorGrid,
    /// Classes K.
    pub num_classes: usize,
    /// Hidden width of the streaming LSTM over slices (the paper: 128); `None`: no LSTM.
    #[config(default = "None")]
    pub lstm_hidden: Option<usize>,
    /// A two-bin direction classifier beside the box head (SECOND / OpenPCDet), so that boxes
    /// point the right way; the paper has none.
    #[config(default = false)]
    pub direction_classifier: bool,
    /// Predict the size residuals (log dx, dy, dz) once per center from the cell feature, shared
    /// by all G² offsets, instead of per offset: an object's size does not depend on where the
    /// anchor sits, and each offset's own head sees only 1/G² of the foreground. The paper
    /// predicts them per offset.
    #[config(default = false)]
    pub shared_size: bool,
}

/// Logit of the classification prior 0.01: ln(0.01 / 0.99).
pub const CLASS_PRIOR_LOGIT: f32 = -4.595;

impl StarNetConfig {
    /// The paper's widths (cell 384, D = 128) with KITTI car anchors.
    pub fn paper_car() -> Self {
        Self::new(FeaturizerConfig::paper(), 128, AnchorGrid::kitti_car(), 1)
    }

    /// The CPU-sized preset (cell 128, D = 32) with KITTI car anchors.
    pub fn small_car() -> Self {
        Self::new(FeaturizerConfig::small(), 32, AnchorGrid::kitti_car(), 1)
    }

    /// Anchors per grid offset: rotations × priors.
    pub fn anchors_per_offset(&self) -> usize {
        self.anchors.rotations.len() * self.anchors.priors.len()
    }

    /// Builds the model.
    pub fn init(&self, device: &Device) -> StarNet {
        let cell = self.featurizer.cell_dim();
        let offsets = self.anchors.grid * self.anchors.grid;
        let per = self.anchors_per_offset();
        let mut cls_head = linear(self.d_offset, per * self.num_classes, Bias::Zero, device);
        cls_head.bias = Some(Param::from_tensor(Tensor::full(
            [per * self.num_classes],
            CLASS_PRIOR_LOGIT,
            device,
        )));
        let mut box_head = linear(self.d_offset, per * 7, Bias::Omitted, device);
        box_head.weight = Param::from_tensor(Tensor::zeros([self.d_offset, per * 7], device));
        let dir_head = self
            .direction_classifier
            .then(|| linear(self.d_offset, per * 2, Bias::Zero, device));
        let size_head = self.shared_size.then(|| {
            let mut h = linear(cell, per * 3, Bias::Omitted, device);
            h.weight = Param::from_tensor(Tensor::zeros([cell, per * 3], device));
            h
        });
        StarNet {
            featurizer: self.featurizer.init(device),
            proj_bn: MaskedBatchNormConfig::new(cell)
                .with_rows(self.featurizer.rows)
                .init(device),
            proj: linear(cell, offsets * self.d_offset, Bias::Zero, device),
            cls_head,
            box_head,
            dir_head,
            size_head,
            lstm: self
                .lstm_hidden
                .map(|h| SliceLstmConfig::new(cell).with_d_hidden(h).init(device)),
            d_offset: self.d_offset,
            num_classes: self.num_classes,
            rows: self.featurizer.rows,
        }
    }
}

/// Serialises [`StarNetConfig::init_seeded`]: Burn draws initial weights from its device's
/// generator, so two initialisations in one process must not interleave their draws.
static SEEDED_INIT: std::sync::Mutex<()> = std::sync::Mutex::new(());

impl StarNetConfig {
    /// A network whose initial weights depend on `seed` alone: the device's generator is seeded
    /// and every weight drawn at once, in the module's field order (Burn otherwise initialises
    /// lazily, at first use), while no other `init_seeded` runs. So trainers started together
    /// in one process each get their seed's weights. (The generator is still Burn's, shared by
    /// the device: other random tensors drawn on it meanwhile would take part of its stream,
    /// and a later draw continues from this seed. Nothing in training draws from it.)
    pub fn init_seeded(&self, device: &Device, seed: u64) -> StarNet {
        let _only_one = SEEDED_INIT.lock().unwrap_or_else(|e| e.into_inner());
        device.seed(seed);
        let model = self.init(device);
        model.visit(&mut Materialise);
        model
    }
}

/// Draws every lazily initialised parameter it visits.
struct Materialise;

impl burn::module::ModuleVisitor for Materialise {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let _ = param.val();
    }
}

/// StarNet.
#[derive(Module, Debug)]
pub struct StarNet {
    featurizer: Featurizer,
    proj_bn: MaskedBatchNorm,
    proj: Linear,
    cls_head: Linear,
    box_head: Linear,
    dir_head: Option<Linear>,
    size_head: Option<Linear>,
    lstm: Option<SliceLstm>,
    d_offset: usize,
    num_classes: usize,
    #[module(skip)]
    rows: RowLayout,
}

impl StarNet {
    /// Every batch item a whole sweep (for the streaming variant: a sweep of one slice, from a
    /// fresh state).
    ///
    /// # Shapes
    /// - input: points `[B, C, P, F]`, mask `[B, C, P]`, center_valid `[B, C]`
    /// - output: cls_logits `[B, C, A, K]`, box_residuals `[B, C, A, 7]`, dir_logits
    ///   `[B, C, A, 2]`
    pub fn forward(&self, input: ModelInput) -> ModelOutput {
        self.forward_slices(input, 1, None).0
    }

    /// S consecutive slices of each of B sweeps, batch rows sweep-major (row `b · S + s` is
    /// slice `s` of sweep `b`). The LSTM, if any, runs over the S slices from `state` (the state
    /// after the sweeps' earlier slices; `None` at a sweep's start): training passes a whole
    /// sweep (backpropagation through its slices), streaming inference one slice at a time.
    ///
    /// # Shapes
    /// - input: points `[B·S, C, P, F]`, mask `[B·S, C, P]`, center_valid `[B·S, C]`
    /// - state: cell and hidden `[B, H]`
    /// - output: cls_logits `[B·S, C, A, K]`, box_residuals `[B·S, C, A, 7]`, and the state after
    ///   slice S (`None` without an LSTM)
    pub fn forward_slices(
        &self,
        input: ModelInput,
        slices: usize,
        state: Option<SliceState>,
    ) -> (ModelOutput, Option<SliceState>) {
        let [bs, c, _, _] = input.points.dims();
        let cell = self.featurizer.forward(input.points, input.mask); // [BS, C, cell]
        let [_, _, d_cell] = cell.dims();
        let valid = input.center_valid.reshape([bs * c, 1]);
        let mut rows = self.proj_bn.forward(cell.reshape([bs * c, d_cell]), valid.clone()); // [BS·C, cell]
        let mut next = None;
        if let Some(lstm) = &self.lstm {
            // The context joins after the BatchNorm: before it, the batch statistics of a
            // training step (one n) absorb the per-slice offset, while evaluation's running
            // statistics, averaged over every n, do not.
            let b = bs / slices;
            let (ctx, st) = lstm.forward(
                rows.clone().reshape([b, slices, c, d_cell]),
                valid.reshape([b, slices, c]),
                state,
            ); // [B, S, 1, cell]
            rows = (rows.reshape([bs, c, d_cell]) + ctx.reshape([bs, 1, d_cell])).reshape([bs * c, d_cell]);
            next = Some(st);
        }
        (self.head(rows, bs, c), next)
    }

    /// The projector (after its BatchNorm) and heads.
    ///
    /// # Shapes
    /// - rows: `[B·C, cell]`, the projector's normalised input
    /// - output: cls_logits `[B, C, A, K]`, box_residuals `[B, C, A, 7]`, dir_logits
    ///   `[B, C, A, 2]`
    fn head(&self, rows: Tensor<2>, b: usize, c: usize) -> ModelOutput {
        let size = self.size_head.as_ref().map(|h| self.linear(h, rows.clone())); // [BC, R·Pr·3]
        let offsets = self.proj.weight.dims()[1] / self.d_offset;
        let OffsetOutputs { cls, reg, dir } = self
            .per_offset_fused(rows.clone())
            .unwrap_or_else(|| self.per_offset(rows));
        let per = cls.dims()[1] / self.num_classes;
        let mut reg = reg.reshape([b * c, offsets, per, 7]);
        if let Some(size) = size {
            // The per-center sizes replace residuals 3..6 at every offset.
            let size = size.reshape([b * c, 1, per, 3]).expand([b * c, offsets, per, 3]);
            reg = Tensor::cat(vec![reg.clone().slice_dim(3, 0..3), size, reg.slice_dim(3, 6..7)], 3);
        }
        ModelOutput {
            cls_logits: cls.reshape([b, c, offsets * per, self.num_classes]),
            box_residuals: reg.reshape([b, c, offsets * per, 7]),
            dir_logits: dir.map(|d| d.reshape([b, c, offsets * per, 2])),
        }
    }

    /// The projector's Linear and ReLU and the heads as Burn operations (the reference, and the
    /// path off flex).
    ///
    /// # Shapes
    /// - rows: `[BC, cell]` (the projector's BatchNorm output)
    fn per_offset(&self, rows: Tensor<2>) -> OffsetOutputs {
        let f = relu(self.linear(&self.proj, rows)); // [BC, G²·D]
        let [bc, width] = f.dims();
        let f = f.reshape([bc * width / self.d_offset, self.d_offset]); // [BC·G², D]
        OffsetOutputs {
            cls: self.linear(&self.cls_head, f.clone()),
            dir: self.dir_head.as_ref().map(|h| self.linear(h, f.clone())),
            reg: self.linear(&self.box_head, f),
        }
    }

    /// A layer over rows, laid out as the model's [`RowLayout`] says.
    ///
    /// # Shapes
    /// - `x`: `[N, C]`; output `[N, O]`
    fn linear(&self, layer: &Linear, x: Tensor<2>) -> Tensor<2> {
        row_layout::linear_flat(self.rows, layer, x)
    }

    /// [`Self::per_offset`] as one fused operation whose heads share a product
    /// ([`super::fused::head_op`]), where the featurizer is fused and the tensors are on flex.
    fn per_offset_fused(&self, rows: Tensor<2>) -> Option<OffsetOutputs> {
        if !self.featurizer.is_fused() {
            return None;
        }
        let device = rows.device();
        let heads: Vec<&Linear> = [Some(&self.cls_head), Some(&self.box_head), self.dir_head.as_ref()]
            .into_iter()
            .flatten()
            .collect();
        let width = |h: &Linear| h.weight.dims()[1];
        let bias = |h: &Linear| {
            h.bias
                .as_ref()
                .map_or_else(|| Tensor::zeros([width(h)], &device), |b| b.val())
        };
        let params = HeadTensors {
            w_proj: self.proj.weight.val(),
            b_proj: self.proj.bias.as_ref()?.val(),
            w_heads: Tensor::cat(heads.iter().map(|h| h.weight.val()).collect(), 1),
            b_heads: Tensor::cat(heads.iter().map(|h| bias(h)).collect(), 0),
        };
        let z = head_op::forward(rows, params)?; // [BC·G², Σ widths]
        let mut at = 0;
        let mut parts = heads.iter().map(|h| {
            at += width(h);
            z.clone().slice_dim(1, at - width(h)..at)
        });
        Some(OffsetOutputs {
            cls: parts.next()?,
            reg: parts.next()?,
            dir: parts.next(),
        })
    }

    /// Every BatchNorm's running statistics, in order: a training step that must be undone
    /// restores them with [`Self::restore_running_stats`].
    pub fn running_stats(&self) -> Vec<RunningStats> {
        self.batch_norms().into_iter().map(MaskedBatchNorm::running).collect()
    }

    /// Sets every BatchNorm's running statistics to `stats` ([`Self::running_stats`]' order).
    pub fn restore_running_stats(&self, stats: Vec<RunningStats>) {
        for (bn, s) in self.batch_norms().into_iter().zip(stats) {
            bn.set_running(s);
        }
    }

    fn batch_norms(&self) -> Vec<&MaskedBatchNorm> {
        let mut all = self.featurizer.batch_norms();
        all.push(&self.proj_bn);
        all
    }

    /// The parameters of the point featurizer (the StarNet blocks), which fine-tuning can hold
    /// fixed while the heads adapt.
    pub fn featurizer_param_ids(&self) -> Vec<burn::module::ParamId> {
        burn::module::list_param_ids(&self.featurizer)
    }

    /// Whether the model has the direction classifier.
    pub fn has_direction_classifier(&self) -> bool {
        self.dir_head.is_some()
    }

    /// Whether the model has the streaming LSTM.
    pub fn has_lstm(&self) -> bool {
        self.lstm.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use crate::testing;

    /// `b · c` centers of `p` slots with N(0, 1) points drawn from `seed`, the first `real`
    /// slots of each real.
    fn input(dev: &Device, b: usize, c: usize, p: usize, real: usize, seed: u64) -> ModelInput {
        let points = testing::normal([b, c, p, 4], 1.0, &mut testing::rng(seed), dev);
        let m: Vec<f32> = (0..b * c * p).map(|i| if i % p < real { 1.0 } else { 0.0 }).collect();
        ModelInput {
            points,
            mask: Tensor::<1>::from_floats(m.as_slice(), dev).reshape([b, c, p]),
            center_valid: Tensor::ones([b, c], dev),
        }
    }

    #[test]
    fn output_shapes() {
        let dev = default_device();
        let cfg = StarNetConfig::small_car();
        let out = cfg.init(&dev).forward(input(&dev, 2, 8, 16, 10, 1));
        assert_eq!(out.cls_logits.dims(), [2, 8, 100, 1]);
        assert_eq!(out.box_residuals.dims(), [2, 8, 100, 7]);
        assert!(out.dir_logits.is_none());
        let with_dir = StarNetConfig::small_car().with_direction_classifier(true).init(&dev);
        let d = with_dir
            .forward(input(&dev, 2, 8, 16, 10, 2))
            .dir_logits
            .expect("direction logits");
        assert_eq!(d.dims(), [2, 8, 100, 2]);
        // With shared sizes, residuals 3..6 are the same at every offset of a center.
        let shared = StarNetConfig::small_car().with_shared_size(true);
        let shared_out = crate::export::load_weights(shared.init(&dev), &randomised(&shared.init(&dev)))
            .expect("same layout")
            .forward(input(&dev, 1, 2, 16, 10, 3));
        let r: Vec<f32> = shared_out.box_residuals.into_data().iter::<f32>().collect();
        let at = |c: usize, offset: usize, j: usize| r[((c * 25 + offset) * 4) * 7 + j];
        for j in 0..7 {
            let same = (0..25).all(|o| (at(1, o, j) - at(1, 0, j)).abs() < 1e-6);
            assert_eq!(same, (3..6).contains(&j), "residual {j}");
        }
        // The box head starts at zero.
        assert!(out.box_residuals.into_data().iter::<f32>().all(|v| v == 0.0));
        // Without real points every feature is 0, so the logits are the class bias: the prior.
        let empty = cfg.init(&dev).forward(input(&dev, 1, 4, 16, 0, 4));
        assert!(
            empty
                .cls_logits
                .into_data()
                .iter::<f32>()
                .all(|v| (v - CLASS_PRIOR_LOGIT).abs() < 1e-6)
        );
    }

    #[test]
    fn a_model_trained_fused_evaluates_the_same_on_the_composed_blocks() {
        use burn::optim::{AdamConfig, GradientsParams};
        let train = default_device().autodiff();
        let cfg = StarNetConfig::small_car();
        assert!(cfg.featurizer.fused, "the fused blocks are the default");
        let mut model = cfg.init(&train);
        let mut optim = AdamConfig::new().init();
        for step in 0..3 {
            let out = model.forward(input(&train, 2, 8, 16, 12 - 3 * step, step as u64));
            let loss = out.cls_logits.powi_scalar(2).mean() + (out.box_residuals - 0.5).powi_scalar(2).mean();
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(1e-2, model, grads);
        }
        // The checkpoint's tensors, running statistics included, into a composed-block model.
        let weights = crate::export::named_tensors(&model.valid())
            .into_iter()
            .map(|t| (t.name.clone(), t))
            .collect();
        let dev = default_device();
        let mut composed_cfg = cfg.clone();
        composed_cfg.featurizer.fused = false;
        let composed = crate::export::load_weights(composed_cfg.init(&dev), &weights).expect("same layout");
        let fused = crate::export::load_weights(cfg.init(&dev), &weights).expect("same layout");
        let x = input(&dev, 1, 6, 16, 9, 5);
        let (a, b) = (fused.forward(x.clone()), composed.forward(x));
        for (a, b, what) in [
            (a.cls_logits, b.cls_logits, "logits"),
            (a.box_residuals, b.box_residuals, "residuals"),
        ] {
            let (a, b): (Vec<f32>, Vec<f32>) = (a.into_data().iter().collect(), b.into_data().iter().collect());
            let scale = b.iter().fold(1e-6f32, |m, v| m.max(v.abs()));
            let worst = a.iter().zip(&b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
            assert!(worst <= 1e-4 * scale, "{what}: {worst} against {scale}");
        }
    }

    #[test]
    fn the_fused_model_trains_as_the_composed_one() {
        let cfg = StarNetConfig::small_car().with_direction_classifier(true);
        let mut composed_cfg = cfg.clone();
        composed_cfg.featurizer.fused = false;
        let weights = randomised(&cfg.init(&default_device()));
        // Seeded inputs: the two paths sum in different orders, so their difference is float
        // rounding, and that depends on the draw. Over 24 draws the worst parameter differed by
        // 1e-5 to 7.7e-5 of its largest gradient, and the composed path alone moved by up to
        // 5.5e-5 when its inputs were scaled by 1 + 2^-22: 1e-4 is that floor, not slack (a 1 %
        // error in one gradient fails it). Random features in the padded slots too: neither path
        // may read them.
        for seed in 0..4 {
            let x = input(&default_device().autodiff(), 2, 6, 16, 11, seed);
            let (fused, composed) = (sgd_step(&cfg, &weights, &x), sgd_step(&composed_cfg, &weights, &x));
            let errors = gradient_errors(&fused.params, &composed.params, &weights);
            assert!(errors.len() >= 20, "every parameter: {}", errors.len());
            for (name, error) in errors {
                assert!(error <= 1e-4, "seed {seed}, {name}: {error} of the largest gradient");
            }
        }
    }

    #[test]
    fn grouped_rows_train_as_the_flat_ones() {
        // The composed path (every backend but flex's fused kernels) with its rows grouped as a
        // GPU gets them, against one flat product and sum: the same maths summed in another
        // order. 2 × 8 centers × 16 points: the featurizer's 256 rows as 16 × 16, the
        // projector's 16 as 4 × 4, the heads' 64 as 8 × 8. Seeded, as the fused test is: over
        // 12 draws the worst parameter differed by 8e-6 to 1.5e-4 of its largest gradient. At
        // 1,024 rows, with a loss weighing every center alike, it differed by 1.4e-5 to 5.8e-4
        // where the flat path alone, fed the same centers in reverse order (the same maths, its
        // sums reordered), moved by 1.4e-5 to 2.7e-2: the difference is a reordered sum's.
        let mut flat = StarNetConfig::small_car().with_direction_classifier(true);
        flat.featurizer.fused = false;
        flat.featurizer.rows = RowLayout::Flat;
        let mut grouped = flat.clone();
        grouped.featurizer.rows = RowLayout::Grouped;
        let weights = randomised(&flat.init(&default_device()));
        for seed in 0..5 {
            let x = input(&default_device().autodiff(), 2, 8, 16, 11, seed);
            let (a, b) = (sgd_step(&grouped, &weights, &x), sgd_step(&flat, &weights, &x));
            assert!(
                (a.loss - b.loss).abs() <= 1e-4 * b.loss.abs().max(1.0),
                "{} {}",
                a.loss,
                b.loss
            );
            let errors = gradient_errors(&a.params, &b.params, &weights);
            assert!(errors.len() >= 20, "every parameter: {}", errors.len());
            for (name, error) in errors {
                assert!(error <= 1e-4, "seed {seed}, {name}: {error} of the largest gradient");
            }
            // The running statistics took the same batch statistics.
            for (a, b) in a
                .params
                .iter()
                .zip(&b.params)
                .filter(|(a, _)| a.name.contains("running"))
            {
                let worst = a
                    .data
                    .iter()
                    .zip(&b.data)
                    .fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
                assert!(worst <= 1e-5, "seed {seed}, {}: {worst}", a.name);
            }
        }
        // Evaluation (running statistics, no autodiff) on the same weights.
        let dev = default_device();
        let load = |cfg: &StarNetConfig| crate::export::load_weights(cfg.init(&dev), &weights).expect("same layout");
        let x = input(&dev, 2, 8, 16, 9, 5);
        let (a, b) = (load(&grouped).forward(x.clone()), load(&flat).forward(x));
        let scale = b.cls_logits.clone().abs().max().into_scalar::<f32>().max(1e-6);
        assert!(max_diff(a.cls_logits, b.cls_logits) <= 1e-4 * scale);
        let scale = b.box_residuals.clone().abs().max().into_scalar::<f32>().max(1e-6);
        assert!(max_diff(a.box_residuals, b.box_residuals) <= 1e-4 * scale);
    }

    /// The parameters after one SGD step at rate 1 from `weights` (so each moved by exactly
    /// its gradient) on a loss that weighs every output of `x` differently.
    fn sgd_step(
        cfg: &StarNetConfig,
        weights: &std::collections::BTreeMap<String, crate::export::NamedTensor>,
        x: &ModelInput,
    ) -> Stepped {
        use burn::optim::{GradientsParams, SgdConfig};
        let train = default_device().autodiff();
        let model = crate::export::load_weights(cfg.init(&train), weights).expect("same layout");
        let out = model.forward(x.clone());
        let weigh = |t: Tensor<4>| {
            let n = t.shape().num_elements();
            let w: Vec<f32> = (0..n).map(|i| ((i * 37) % 11) as f32 / 11.0 - 0.4).collect();
            (t.reshape([n]) * Tensor::<1>::from_floats(w.as_slice(), &train)).sum()
        };
        let dir = out.dir_logits.expect("direction logits");
        let loss = weigh(out.cls_logits) + weigh(out.box_residuals) + weigh(dir);
        let value = loss.clone().into_scalar::<f32>();
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        let after = SgdConfig::new().init().step(1.0, model, grads);
        Stepped {
            params: crate::export::named_tensors(&after.valid()),
            loss: value,
        }
    }

    /// What [`sgd_step`] leaves: the parameters after the step and the loss before it.
    struct Stepped {
        params: Vec<crate::export::NamedTensor>,
        loss: f32,
    }

    /// For each trained parameter (running statistics left out), the largest difference
    /// between `a` and `b` as a fraction of the largest gradient `b` took from `before`.
    fn gradient_errors(
        a: &[crate::export::NamedTensor],
        b: &[crate::export::NamedTensor],
        before: &std::collections::BTreeMap<String, crate::export::NamedTensor>,
    ) -> Vec<(String, f32)> {
        let largest = |x: &[f32], y: &[f32]| x.iter().zip(y).fold(0.0f32, |m, (p, q)| m.max((p - q).abs()));
        a.iter()
            .zip(b)
            .filter(|(a, _)| !a.name.contains("running"))
            .map(|(a, b)| {
                assert_eq!(a.name, b.name);
                let gradient = largest(&b.data, &before[&b.name].data).max(1e-6);
                (a.name.clone(), largest(&a.data, &b.data) / gradient)
            })
            .collect()
    }

    /// Every parameter of `model` replaced by a deterministic non-zero value.
    fn randomised(model: &StarNet) -> std::collections::BTreeMap<String, crate::export::NamedTensor> {
        crate::export::named_tensors(model)
            .into_iter()
            .map(|mut t| {
                let var = t.name.ends_with("running_var");
                for (i, v) in t.data.iter_mut().enumerate() {
                    let u = ((i * 7919 + t.name.len() * 31) % 1000) as f32 / 1000.0;
                    *v = if var { 0.5 + u } else { u - 0.5 };
                }
                (t.name.clone(), t)
            })
            .collect()
    }

    fn max_diff(a: Tensor<4>, b: Tensor<4>) -> f32 {
        (a - b).abs().max().into_scalar::<f32>()
    }

    fn rows(x: &ModelInput, r: std::ops::Range<usize>) -> ModelInput {
        ModelInput {
            points: x.points.clone().slice_dim(0, r.clone()),
            mask: x.mask.clone().slice_dim(0, r.clone()),
            center_valid: x.center_valid.clone().slice_dim(0, r),
        }
    }

    #[test]
    fn lstm_carries_state_across_slices_and_starts_fresh_per_sweep() {
        let dev = default_device();
        let mut cfg = StarNetConfig::small_car();
        cfg.lstm_hidden = Some(16);
        // Every weight non-zero: the context projection starts at zero (see the test below).
        let model = crate::export::load_weights(cfg.init(&dev), &randomised(&cfg.init(&dev))).expect("same layout");
        assert!(model.has_lstm() && !StarNetConfig::small_car().init(&dev).has_lstm());
        // Two sweeps of four slices, three centers each: rows sweep-major.
        let x = input(&dev, 8, 3, 8, 6, 7);
        let (whole, state) = model.forward_slices(x.clone(), 4, None);
        assert_eq!(state.expect("an LSTM state").hidden.dims(), [2, 16]);
        // Streaming, one slice per call with the state carried, gives the same outputs.
        let mut st = None;
        for s in 0..4 {
            let step = ModelInput {
                points: Tensor::cat(vec![rows(&x, s..s + 1).points, rows(&x, 4 + s..5 + s).points], 0),
                mask: Tensor::cat(vec![rows(&x, s..s + 1).mask, rows(&x, 4 + s..5 + s).mask], 0),
                center_valid: Tensor::cat(
                    vec![rows(&x, s..s + 1).center_valid, rows(&x, 4 + s..5 + s).center_valid],
                    0,
                ),
            };
            let (out, next) = model.forward_slices(step, 1, st);
            st = next;
            let expect = Tensor::cat(
                vec![
                    whole.cls_logits.clone().slice_dim(0, s..s + 1),
                    whole.cls_logits.clone().slice_dim(0, 4 + s..5 + s),
                ],
                0,
            );
            assert!(max_diff(out.cls_logits, expect) < 1e-4, "slice {s}");
        }
        // The state changes the output: slice 2 of sweep 0, run as the first slice of a sweep,
        // differs from what it gave after slices 0 and 1.
        let fresh = model.forward_slices(rows(&x, 2..3), 1, None).0;
        let after = whole.cls_logits.clone().slice_dim(0, 2..3);
        assert!(max_diff(fresh.cls_logits.clone(), after) > 1e-3);
        // Sweeps do not share state: sweep 1's first slice equals a fresh run of it.
        let first = model.forward_slices(rows(&x, 4..5), 1, None).0;
        assert!(max_diff(first.cls_logits, whole.cls_logits.slice_dim(0, 4..5)) < 1e-4);
        // Without an LSTM, slices are independent: the plain forward of any row equals it in a sweep.
        let plain = StarNetConfig::small_car().init(&dev);
        let (sw, none) = plain.forward_slices(x.clone(), 4, None);
        assert!(none.is_none());
        assert!(
            max_diff(
                plain.forward(rows(&x, 5..6)).cls_logits,
                sw.cls_logits.slice_dim(0, 5..6)
            ) < 1e-5
        );
    }

    #[test]
    fn an_untrained_lstm_leaves_the_stateless_model_as_it_is() {
        let dev = default_device();
        let plain_cfg = StarNetConfig::small_car();
        let lstm_cfg = StarNetConfig::small_car().with_lstm_hidden(Some(16));
        // Every weight randomised but the context projection's, as initialised; the stateless
        // model takes the same weights (its loader reads the tensors it has).
        let init = lstm_cfg.init(&dev);
        let fresh = crate::export::named_tensors(&init);
        let mut weights = randomised(&init);
        for t in fresh.into_iter().filter(|t| t.name.starts_with("lstm.out")) {
            assert!(t.data.iter().all(|&v| v == 0.0), "{} starts at zero", t.name);
            weights.insert(t.name.clone(), t);
        }
        let plain = crate::export::load_weights(plain_cfg.init(&dev), &weights).expect("a subset of the layout");
        let lstm = crate::export::load_weights(init, &weights).expect("same layout");
        let x = input(&dev, 4, 5, 8, 6, 9);
        let (a, b) = (
            plain.forward_slices(x.clone(), 2, None).0,
            lstm.forward_slices(x, 2, None).0,
        );
        assert!(max_diff(a.cls_logits.clone(), b.cls_logits) < 1e-6);
        assert!(max_diff(a.box_residuals, b.box_residuals) < 1e-6);
        // Not vacuous: the logits vary across centers.
        assert!(a.cls_logits.clone().max().into_scalar::<f32>() - a.cls_logits.min().into_scalar::<f32>() > 1e-2);
    }
}
