//! Data-pipeline speed on one ~120 k-point simulated frame, single-threaded: farthest point
//! sampling of 1,024 centers, gathering 1,024 × 64 neighbourhoods, and a whole augmentation
//! (database paste included). Medians of 15 runs.
//!
//! ```text
//! cargo bench -p starnet-data --bench pipeline
//! ```

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use starnet_data::augment::{AugmentConfig, GtDatabase, Scene, augment};
use starnet_data::kitti::{Calib, KittiDataset};
use starnet_data::sampling::{CenterPoolConfig, CenterZ, GatherConfig, Sampler, center_pool, gather, sample_centers};
use starnet_sim::{SynthConfig, simulate_scene_frame, synth_frames};
use std::time::Instant;

fn median_ms(mut f: impl FnMut()) -> f64 {
    let mut v: Vec<f64> = (0..15)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let cfg = SynthConfig::default();
    let calib = Calib::kitti_000000();
    let frame = simulate_scene_frame(3, 0, &cfg, &calib);
    let pts = &frame.points;
    println!("frame: {} points", pts.len());

    let all: Vec<usize> = (0..pts.len()).collect();
    let kitti_pool = center_pool(pts, &CenterPoolConfig::kitti(), Some((&calib, cfg.image)), None);
    for (name, pool) in [
        ("all points", &all),
        ("KITTI pool (camera view, z >= -1.35)", &kitti_pool),
    ] {
        let ms = median_ms(|| {
            let c = sample_centers(
                pts,
                pool,
                1024,
                Sampler::Fps,
                &[],
                CenterZ::Zero,
                &mut ChaCha8Rng::seed_from_u64(1),
            );
            std::hint::black_box(c);
        });
        println!("FPS 1024 centers over {name} ({} points): {ms:.1} ms", pool.len());
    }

    let centers = sample_centers(
        pts,
        &all,
        1024,
        Sampler::Fps,
        &[],
        CenterZ::Point,
        &mut ChaCha8Rng::seed_from_u64(1),
    );
    for radius in [2.0, 3.75] {
        let g = GatherConfig {
            num_points: 64,
            radius,
            metric: Default::default(),
            reflectance: Default::default(),
        };
        let ms = median_ms(|| {
            std::hint::black_box(gather(pts, &centers, &g, &mut ChaCha8Rng::seed_from_u64(2)));
        });
        println!("gather 1024 x 64, R = {radius} m (grid build included): {ms:.1} ms");
    }

    let dir = std::env::temp_dir().join(format!("starnet-pipeline-bench-{}", std::process::id()));
    synth_frames(&dir, 40, 4, &cfg, &|| {}).expect("synth");
    let db = GtDatabase::build(&KittiDataset::open(&dir, None).expect("open"), &|| {}).expect("db");
    let _ = std::fs::remove_dir_all(&dir);
    let scene = Scene {
        points: frame.points.clone(),
        boxes: frame.objects.iter().map(|o| o.b).collect(),
        classes: frame.objects.iter().map(|o| o.class).collect(),
    };
    let aug = AugmentConfig::default();
    let mut pasted = 0;
    let ms = median_ms(|| {
        let mut s = scene.clone();
        pasted = augment(&mut s, &aug, Some(&db), &mut ChaCha8Rng::seed_from_u64(3))
            .pasted
            .len();
        std::hint::black_box(s);
    });
    println!(
        "augmentation, whole frame ({} boxes, {pasted} pasted from {} database objects, clone included): {ms:.1} ms",
        scene.boxes.len(),
        db.entries.len()
    );
}
