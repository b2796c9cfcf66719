//! StarNet forward and forward + backward (+ Adam) time per frame, with achieved GFLOP/s from
//! the exact multiply-add count (`flops.rs`), for the `paper` and `small` presets.
//!
//! ```text
//! cargo bench -p starnet-model --bench model
//! ```
//! One frame per batch; points, masks and targets are random but shaped as in training
//! (a quarter of the slots padded). Medians of 5 after 2 warm-up runs (`STARNET_BENCH_RUNS=N`
//! for N). The composed rows (`STARNET_BENCH_COMPOSED=1`) compose the blocks and the loss.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::prelude::*;
use burn::tensor::Distribution;
use starnet_model::backend::{backend_name, default_device};
use starnet_model::flops::forward_gflop;
use starnet_model::loss::{LossConfig, LossTargets, starnet_loss};
use starnet_model::nn::{ModelInput, StarNetConfig};
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn median_ms(device: &Device, mut f: impl FnMut()) -> f64 {
    for _ in 0..2 {
        f();
    }
    let n: usize = std::env::var("STARNET_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let mut v: Vec<f64> = (0..n)
        .map(|_| {
            let t = Instant::now();
            f();
            device.sync().expect("sync");
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[n / 2]
}

fn input(c: usize, p: usize, dev: &Device) -> ModelInput {
    let mask = Tensor::<3>::random([1, c, p], Distribution::Uniform(0.0, 1.0), dev)
        .greater_elem(0.25)
        .float();
    ModelInput {
        points: Tensor::random([1, c, p, 4], Distribution::Normal(0.0, 1.0), dev),
        mask,
        center_valid: Tensor::ones([1, c], dev),
    }
}

fn main() {
    // As the binary: the thread that runs the model takes part in its parallel work.
    starnet_model::backend::compute_on_this_thread();
    let dev = default_device();
    // Same inputs every run: the real-slot count sets the work of the packed kernels.
    dev.seed(0);
    println!("backend {}", backend_name());
    println!(
        "| preset | blocks | (C, P) | GFLOP/frame | forward | GFLOP/s | forward + backward + Adam | GFLOP/s (3x forward) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    // `STARNET_BENCH_COMPOSED=1` adds the composed (reference) blocks beside the fused ones.
    let composed = std::env::var_os("STARNET_BENCH_COMPOSED").is_some();
    let kinds: &[bool] = if composed { &[true, false] } else { &[true] };
    // `STARNET_BENCH_ONLY=paper:1024` runs one preset at one center count (for profiling).
    let only = std::env::var("STARNET_BENCH_ONLY").ok();
    for (name, base) in [
        ("paper", StarNetConfig::paper_car()),
        ("small", StarNetConfig::small_car()),
    ] {
        for (&fused, (c, p)) in kinds.iter().flat_map(|k| [(k, (256, 32)), (k, (1024, 64))]) {
            if only.as_ref().is_some_and(|o| *o != format!("{name}:{c}")) {
                continue;
            }
            let mut cfg = base.clone();
            cfg.featurizer.fused = fused;
            let gflop = forward_gflop(&cfg, c, p);
            let model = cfg.init(&dev).valid();
            let x = input(c, p, &dev);
            let fwd = median_ms(&dev, || {
                std::hint::black_box(model.forward(x.clone()));
            });
            let ad = dev.clone().autodiff();
            let mut train = cfg.init(&ad);
            let mut optim = AdamConfig::new().with_epsilon(1e-6).init();
            let xa = input(c, p, &ad);
            let a = cfg.anchors.len();
            let targets = LossTargets {
                classes: Tensor::<4>::random([1, c, a, 1], Distribution::Uniform(0.0, 1.0), &ad)
                    .greater_elem(0.99)
                    .float(),
                cls_weight: Tensor::ones([1, c, a], &ad) / (c as f32),
                residuals: Tensor::random([1, c, a, 7], Distribution::Normal(0.0, 0.3), &ad),
                reg_weight: Tensor::ones([1, c, a], &ad) / (c as f32 * 10.0),
                direction: Tensor::zeros([1, c, a], &ad),
            };
            let loss_cfg = LossConfig::new().with_fused(fused);
            if std::env::var_os("STARNET_BENCH_FORWARD_ONLY").is_some() {
                println!(
                    "| {name} | ({c}, {p}) | {gflop:.2} | {fwd:.0} ms | {:.1} |",
                    gflop / fwd * 1e3
                );
                continue;
            }
            let step = median_ms(&ad, || {
                let loss = starnet_loss(&train.forward(xa.clone()), &targets, &loss_cfg).total;
                let grads = GradientsParams::from_grads(loss.backward(), &train);
                train = optim.step(1e-4, train.clone(), grads);
            });
            println!(
                "| {name} | {} | ({c}, {p}) | {gflop:.2} | {fwd:.0} ms | {:.1} | {step:.0} ms | {:.1} |",
                if fused { "fused" } else { "composed" },
                gflop / fwd * 1e3,
                3.0 * gflop / step * 1e3
            );
        }
    }
}
