//! The fused block's matrix products at the paper preset's shapes (C = 1024, P = 64: 65,536
//! rows; d = 64, H = 256), GFLOP/s of the `gemm` crate as the block calls it, and of
//! the weight gradient's product cut into row chunks (`matmul_tn`). Medians of 5.
//!
//! ```text
//! cargo bench -p starnet-model --bench gemm
//! ```

use starnet_model::nn::fused::{Mat, Op, Write, matmul, matmul_tn};
use std::time::Instant;

fn median_ms(mut f: impl FnMut()) -> f64 {
    f();
    let mut v: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[2]
}

/// The product's reading of a matrix named by the bench's `(ta, tb)` flags.
fn op(transposed: bool) -> Op {
    if transposed { Op::T } else { Op::N }
}

fn main() {
    let (r, d, h) = (65_536, 64, 256);
    let x: Vec<f32> = (0..r * h).map(|i| ((i % 97) as f32) * 0.01).collect();
    let w: Vec<f32> = (0..h * h).map(|i| ((i % 89) as f32) * 0.01).collect();
    println!("| product | (m, k, n) | ms | GFLOP/s |");
    println!("|---|---|---|---|");
    // (name, m, k, n, transpose a, transpose b)
    let shapes = [
        ("x · W (fc1 forward)", r, d, h, false, false),
        ("h · W (fc2 forward)", r, h, d, false, false),
        ("xᵀ · dz (fc1 weight grad)", d, r, h, true, false),
        ("dz · Wᵀ (fc1 input grad)", r, h, d, false, true),
    ];
    for (name, m, k, n, ta, tb) in shapes {
        let a = if ta {
            Mat::new(&x[..k * m], k, m)
        } else {
            Mat::new(&x[..m * k], m, k)
        };
        let src = if k * n > w.len() { &x } else { &w };
        let b = if tb {
            Mat::new(&src[..n * k], n, k)
        } else {
            Mat::new(&src[..k * n], k, n)
        };
        let mut c = vec![0.0; m * n];
        let ms = median_ms(|| matmul(&mut c, a, op(ta), b, op(tb), Write::Overwrite));
        let gflop = 2.0 * (m * k * n) as f64 / 1e9;
        println!("| {name} | ({m}, {k}, {n}) | {ms:.1} | {:.1} |", gflop / ms * 1e3);
        if ta && !tb {
            let ms = median_ms(|| {
                std::hint::black_box(matmul_tn(a, b));
            });
            println!(
                "| {name}, row chunks (`matmul_tn`) | ({m}, {k}, {n}) | {ms:.1} | {:.1} |",
                gflop / ms * 1e3
            );
        }
    }
}
