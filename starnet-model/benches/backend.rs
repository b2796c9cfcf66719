//! Backend comparison: a StarNet-block-sized MLP training step (forward + backward + Adam) and
//! the raw throughput of its matmuls, on whichever backend this build enables.
//!
//! ```text
//! cargo bench -p starnet-model --bench backend                                             # flex
//! cargo bench -p starnet-model --bench backend --features x86-v4                           # flex + AVX-512
//! cargo bench -p starnet-model --bench backend --no-default-features --features ndarray    # ndarray
//! ```
//! Rows = C·P = 512 · 32 = 16,384 points; block = BN → Linear(128→256) → ReLU → BN →
//! Linear(256→64) → ReLU (the StarNet block's two layers, ARCHITECTURE.md §6). Prints medians.

use burn::module::Module;
use burn::nn::{BatchNorm, BatchNormConfig, Linear, LinearConfig};
use burn::optim::{AdamConfig, GradientsParams};
use burn::prelude::*;
use burn::tensor::Distribution;
use starnet_model::backend::{backend_name, default_device};
use std::time::Instant;

const ROWS: usize = 16_384;
const WIDTHS: [usize; 3] = [128, 256, 64];

#[derive(Module, Debug)]
struct BlockMlp {
    bn1: BatchNorm,
    fc1: Linear,
    bn2: BatchNorm,
    fc2: Linear,
}

impl BlockMlp {
    fn new(device: &Device) -> Self {
        let [a, b, c] = WIDTHS;
        Self {
            bn1: BatchNormConfig::new(a).init(device),
            fc1: LinearConfig::new(a, b).with_bias(false).init(device),
            bn2: BatchNormConfig::new(b).init(device),
            fc2: LinearConfig::new(b, c).with_bias(false).init(device),
        }
    }

    /// `[N, 128] -> [N, 64]`.
    fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let h = burn::tensor::activation::relu(self.fc1.forward(self.bn1.forward(x)));
        burn::tensor::activation::relu(self.fc2.forward(self.bn2.forward(h)))
    }
}

fn median_ms(mut samples: Vec<f64>) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

fn time<F: FnMut()>(warmup: usize, reps: usize, device: &Device, mut f: F) -> f64 {
    for _ in 0..warmup {
        f();
    }
    let samples = (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            device.sync().expect("device sync");
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    median_ms(samples)
}

fn main() {
    // `cargo bench` passes `--bench`; a filter argument is accepted and ignored.
    let reps: usize = std::env::var("BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(9);
    let device = default_device();
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "default".into());
    println!(
        "backend {} | rows {ROWS} | widths {WIDTHS:?} | RAYON_NUM_THREADS={threads} | {reps} reps",
        backend_name()
    );

    let [a, b, c] = WIDTHS;
    let fwd_flop = 2.0 * ROWS as f64 * (a * b + b * c) as f64;

    // Training step: forward, backward, Adam.
    let ad = device.clone().autodiff();
    ad.seed(7);
    let mut model = BlockMlp::new(&ad);
    let mut optim = AdamConfig::new().with_epsilon(1e-6).init();
    let x = Tensor::<2>::random([ROWS, a], Distribution::Normal(0.0, 1.0), &ad);
    let target = Tensor::<2>::random([ROWS, c], Distribution::Normal(0.0, 1.0), &ad);
    let step_ms = time(2, reps, &ad, || {
        let loss = (model.forward(x.clone()) - target.clone()).powi_scalar(2).mean();
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        model = optim.step(1e-3, model.clone(), grads);
    });
    let step_gflops = 3.0 * fwd_flop / (step_ms * 1e6);
    println!(
        "train step (fwd+bwd+Adam)  median {step_ms:8.1} ms  {step_gflops:6.1} GFLOP/s (3 x forward matmul FLOPs)"
    );

    // Inference forward with running statistics.
    let eval = model.valid();
    let xe = x.clone().inner();
    let fwd_ms = time(2, reps, &device, || {
        let _ = eval.forward(xe.clone());
    });
    println!(
        "eval forward               median {fwd_ms:8.1} ms  {:6.1} GFLOP/s",
        fwd_flop / (fwd_ms * 1e6)
    );

    // The block's two matmuls alone.
    for (m, k, n) in [(ROWS, a, b), (ROWS, b, c)] {
        let l = Tensor::<2>::random([m, k], Distribution::Normal(0.0, 1.0), &device);
        let r = Tensor::<2>::random([k, n], Distribution::Normal(0.0, 1.0), &device);
        let ms = time(2, reps, &device, || {
            let _ = l.clone().matmul(r.clone());
        });
        println!(
            "matmul {m}x{k} @ {k}x{n}  median {ms:8.2} ms  {:6.1} GFLOP/s",
            2.0 * (m * k * n) as f64 / (ms * 1e6)
        );
    }
}
