//! The GPU path against the CPU (cargo feature `vulkan`): StarNet's forward, loss, backward and an
//! Adam step on a Vulkan device equal flex's to 1e-4, and a short training run on it converges.
//! Without a GPU, Mesa's lavapipe (Debian `mesa-vulkan-drivers`, a Vulkan on the CPU) is the
//! device and crashes (BENCHMARKS.md); `scripts/gpu_check.sh` runs it on a GPU machine.
#![cfg(feature = "vulkan")]

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::{AdamConfig, GradientsParams};
use burn::prelude::*;
use rand::SeedableRng;
use starnet_data::kitti::{Calib, ObjectClass};
use starnet_data::sampling::{GatherConfig, PipelineConfig, prepare_frame};
use starnet_model::assign::{AnchorTargets, AssignConfig};
use starnet_model::backend::DeviceChoice;
use starnet_model::batch::{StarNetBatch as Batch, frame_targets, make_batch};
use starnet_model::export::named_tensors;
use starnet_model::loss::{LossConfig, LossTerms, starnet_loss};
use starnet_model::nn::{StarNet, StarNetConfig};
use starnet_sim::{SynthConfig, simulate_scene_frame};

fn frame() -> (starnet_data::sampling::PreparedFrame, AnchorTargets) {
    let calib = Calib::kitti_000000();
    let frame = simulate_scene_frame(5, 0, &SynthConfig::default(), &calib).into_frame("000000", calib);
    let cfg = PipelineConfig {
        num_centers: 64,
        gather: GatherConfig {
            num_points: 16,
            radius: 3.0,
            metric: Default::default(),
            reflectance: Default::default(),
        },
        ..Default::default()
    };
    let prepared = prepare_frame(&frame, &cfg, None, &[], &mut rand_chacha::ChaCha8Rng::seed_from_u64(1));
    let targets = frame_targets(
        &prepared,
        &StarNetConfig::small_car().anchors,
        &[ObjectClass::Car],
        &AssignConfig::kitti_car(),
    );
    (prepared, targets)
}

fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data().iter::<f32>().collect()
}

/// The largest difference relative to the largest magnitude of `a`.
fn deviation(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-6);
    a.iter().zip(b).fold(0f32, |m, (x, y)| m.max((x - y).abs())) / scale
}

/// The largest absolute difference.
fn largest_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).fold(0f32, |m, (x, y)| m.max((x - y).abs()))
}

/// Every parameter's gradient, in visiting order.
fn gradients(model: &StarNet, grads: &GradientsParams) -> Vec<Vec<f32>> {
    struct Collect<'a>(&'a GradientsParams, Vec<Vec<f32>>);
    impl ModuleVisitor for Collect<'_> {
        fn visit_float<const D: usize>(&mut self, p: &Param<Tensor<D>>) {
            if let Some(g) = self.0.get::<D>(p.id) {
                self.1.push(host(g));
            }
        }
    }
    let mut c = Collect(grads, Vec::new());
    model.visit(&mut c);
    c.1
}

fn loss(model: &StarNet, batch: &Batch) -> LossTerms {
    // The composed loss on both devices: the fused one is flex's alone.
    let cfg = LossConfig::new().with_fused(false);
    starnet_loss(&model.forward(batch.input.clone()), &batch.targets, &cfg)
}

#[test]
fn vulkan_computes_what_flex_computes_and_trains() {
    let flex = Device::flex().autodiff();
    let gpu = DeviceChoice::Vulkan(None).device().expect("a vulkan build").autodiff();
    let (prepared, targets) = frame();
    let (bf, bg) = (
        make_batch(&[&prepared], &[&targets], 1, &flex),
        make_batch(&[&prepared], &[&targets], 1, &gpu),
    );
    flex.seed(3);
    let on_flex = StarNetConfig::small_car().init(&flex);
    // `fork`, not `to_device`: the copy's parameters are leaves of the GPU's graph (moved with
    // `to_device`, their gradients would flow back to flex's parameters).
    let on_gpu = on_flex.clone().fork(&gpu);
    // Forward and loss.
    let (of, og) = (on_flex.forward(bf.input.clone()), on_gpu.forward(bg.input.clone()));
    let d = deviation(&host(of.cls_logits), &host(og.cls_logits));
    assert!(d < 1e-4, "classification logits differ by {d:e}");
    let (lf, lg) = (loss(&on_flex, &bf), loss(&on_gpu, &bg));
    let (lf_v, lg_v) = (host(lf.total.clone())[0], host(lg.total.clone())[0]);
    assert!((lf_v - lg_v).abs() <= 1e-4 * lf_v.abs(), "loss {lf_v} vs {lg_v}");
    // Backward.
    let (gf, gg) = (
        GradientsParams::from_grads(lf.total.backward(), &on_flex),
        GradientsParams::from_grads(lg.total.backward(), &on_gpu),
    );
    let (hf, hg) = (gradients(&on_flex, &gf), gradients(&on_gpu, &gg));
    assert_eq!(hf.len(), hg.len());
    let mut worst_gradient = 0f32;
    for (i, (a, b)) in hf.iter().zip(&hg).enumerate() {
        let d = deviation(a, b);
        assert!(d < 1e-4, "gradient {i} differs by {d:e}");
        worst_gradient = worst_gradient.max(largest_difference(a, b));
    }
    // One Adam step. Its first update is lr·g / (|g| + ε), whose slope in g is at most lr / ε:
    // the two devices' updates may differ by lr / ε times their gradients' difference, beside
    // the weights' own rounding. With the training's ε (1e-6) that is a thousandfold, and a
    // bias whose gradient is near 0 moves by ±lr on either side of it (seen on an H200: a
    // BatchNorm shift 9 % apart); with ε = 1e-3 the update is smooth in the gradient.
    let (lr, epsilon) = (1e-3, 1e-3);
    let adam = AdamConfig::new().with_epsilon(epsilon);
    let (mut of, mut og) = (adam.init(), adam.init());
    let (on_flex, mut on_gpu) = (of.step(lr, on_flex, gf), og.step(lr, on_gpu, gg));
    let amplified = (lr / epsilon as f64) as f32 * worst_gradient;
    for (a, b) in named_tensors(&on_flex).iter().zip(named_tensors(&on_gpu)) {
        let scale = a.data.iter().fold(0f32, |m, v| m.max(v.abs()));
        let d = largest_difference(&a.data, &b.data);
        assert!(
            d <= 1e-4 * scale + amplified,
            "{} after Adam differs by {d:e} (scale {scale:e}, gradients' worst difference {worst_gradient:e})",
            a.name
        );
    }
    // A short run on the GPU alone converges.
    let first = lg_v;
    for _ in 0..60 {
        let terms = loss(&on_gpu, &bg);
        let grads = GradientsParams::from_grads(terms.total.backward(), &on_gpu);
        on_gpu = og.step(3e-3, on_gpu, grads);
    }
    let last = host(loss(&on_gpu, &bg).total)[0];
    assert!(last < 0.5 * first, "loss {first} -> {last}");
}
