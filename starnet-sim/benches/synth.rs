//! Simulator speed: frames per second of `synth_frames` (all cores, files written), and the
//! single-thread cost of one frame split into scene building, ray casting and labelling, over
//! all scenes and per kind of street.
//!
//! ```text
//! cargo bench -p starnet-sim --bench synth            # FRAMES=64 by default
//! ```

use starnet_data::kitti::Calib;
use starnet_data::seed::sub_seed;
use starnet_sim::{Street, StreetKind, SynthConfig, World, simulate_frame, synth_frames};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let frames: usize = std::env::var("FRAMES").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    let cfg = SynthConfig::default();
    let calib = Calib::kitti_000000();
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());

    // One thread: world generation vs scan + labels, per frame.
    let (mut world_ms, mut frame_ms, mut points) = (Vec::new(), Vec::new(), 0usize);
    for i in 0..16u64 {
        use rand::SeedableRng;
        let t = Instant::now();
        let world = World::generate(
            &cfg.lidar,
            0.0,
            &mut rand_chacha::ChaCha8Rng::seed_from_u64(sub_seed(1, 0, i)),
        );
        world_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let f = simulate_frame(&world, 0, sub_seed(1, 1, i), &cfg, &calib);
        frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        points += f.points.len();
    }
    println!(
        "1 thread: scene {:.1} ms, scan + labels {:.1} ms per frame (medians of 16), {} points per frame",
        median(world_ms),
        median(frame_ms),
        points / 16
    );

    // One thread, per kind of street: scene building and scan + labels.
    for (kind, _) in StreetKind::SHARES {
        let (mut world_ms, mut frame_ms) = (Vec::new(), Vec::new());
        for i in 0..16u64 {
            use rand::SeedableRng;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(sub_seed(2, 0, i));
            let t = Instant::now();
            let world = World::generate_on(Street::sample_of(kind, &mut rng), &cfg.lidar, 0.0, &mut rng);
            world_ms.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            simulate_frame(&world, 0, sub_seed(2, 1, i), &cfg, &calib);
            frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "1 thread, {kind:?}: scene {:.1} ms, scan + labels {:.1} ms per frame (medians of 16)",
            median(world_ms),
            median(frame_ms)
        );
    }

    // All cores, writing the KITTI layout to a temporary directory.
    let dir = std::env::temp_dir().join(format!("starnet-synth-bench-{}", std::process::id()));
    let t = Instant::now();
    synth_frames(&dir, frames, 1, &cfg, &|| {}).expect("synth");
    let secs = t.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "synth_frames: {frames} frames in {secs:.2} s on {threads} threads = {:.1} frames/s",
        frames as f64 / secs
    );
}
