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

/// Single-threaded medians over 16 scenes: building the scene, then scanning and labelling it,
/// and the mean points per frame.
struct SceneTimes {
    scene_ms: f64,
    frame_ms: f64,
    points: usize,
}

/// Times 16 scenes built by `build` from seeds of stream `stream`.
fn time_scenes(
    cfg: &SynthConfig,
    calib: &Calib,
    stream: u64,
    build: impl Fn(&mut rand_chacha::ChaCha8Rng) -> World,
) -> SceneTimes {
    use rand::SeedableRng;
    let (mut scene_ms, mut frame_ms, mut points) = (Vec::new(), Vec::new(), 0usize);
    for i in 0..16u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(sub_seed(stream, 0, i));
        let t = Instant::now();
        let world = build(&mut rng);
        scene_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let f = simulate_frame(&world, 0, sub_seed(stream, 1, i), cfg, calib);
        frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        points += f.points.len();
    }
    SceneTimes {
        scene_ms: median(scene_ms),
        frame_ms: median(frame_ms),
        points: points / 16,
    }
}

fn main() {
    let frames: usize = std::env::var("FRAMES").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    let cfg = SynthConfig::default();
    let calib = Calib::kitti_000000();
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());

    // One thread: world generation vs scan + labels, per frame; over all scenes, then per kind.
    let all = time_scenes(&cfg, &calib, 1, |rng| World::generate(&cfg.lidar, 0.0, rng));
    println!(
        "1 thread: scene {:.1} ms, scan + labels {:.1} ms per frame (medians of 16), {} points per frame",
        all.scene_ms, all.frame_ms, all.points
    );
    for (kind, _) in StreetKind::SHARES {
        let t = time_scenes(&cfg, &calib, 2, |rng| {
            World::generate_on(Street::sample_of(kind, rng), &cfg.lidar, 0.0, rng)
        });
        println!(
            "1 thread, {kind:?}: scene {:.1} ms, scan + labels {:.1} ms per frame (medians of 16)",
            t.scene_ms, t.frame_ms
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
