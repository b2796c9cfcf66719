//! Data-parallel training against training alone: the same steps, the same model.

use super::*;
use crate::config::load_config;
use crate::train::{StepLosses, TrainItem, Trainer};
use rand::SeedableRng;
use starnet_data::sampling::prepare_frame;
use starnet_model::batch::frame_targets;
use starnet_model::export::named_tensors;
use starnet_sim::{SynthConfig, simulate_scene_frame};
use std::path::Path;
use std::sync::Arc;

/// Simulated frame `k`, prepared as the loader prepares it (no augmentation).
fn item(cfg: &crate::config::ExperimentConfig, k: u64) -> Vec<TrainItem> {
    let calib = starnet_data::kitti::Calib::kitti_000000();
    let frame = simulate_scene_frame(k, 0, &SynthConfig::default(), &calib).into_frame("000000", calib);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(k);
    let frame = prepare_frame(&frame, &cfg.pipeline, None, &[], &mut rng);
    let targets = frame_targets(&frame, &cfg.model.anchors, &cfg.data.classes, &cfg.assign);
    vec![TrainItem { frame, targets }]
}

/// The relative differences of each reported value of two runs' steps (the total loss, the
/// five terms, the gradient norm).
fn deviations(a: &[StepLosses], b: &[StepLosses]) -> Vec<[f32; 7]> {
    let rel = |x: f32, y: f32| (x - y).abs() / x.abs().max(y.abs()).max(1e-6);
    let values = |l: &StepLosses| {
        let [t, c, lo, d, r, di] = l.terms();
        [t, c, lo, d, r, di, l.grad_norm]
    };
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            let (a, b) = (values(a), values(b));
            std::array::from_fn(|i| rel(a[i], b[i]))
        })
        .collect()
}

/// The distance of two models' weights (every tensor, the running statistics included)
/// relative to the first's norm.
fn weight_deviation(a: &Trainer, b: &Trainer) -> f64 {
    let (a, b) = (named_tensors(a.model()), named_tensors(b.model()));
    let pairs = || a.iter().zip(&b).flat_map(|(x, y)| x.data.iter().zip(&y.data));
    let diff: f64 = pairs().map(|(x, y)| f64::from(x - y).powi(2)).sum();
    let norm: f64 = pairs().map(|(x, _)| f64::from(*x).powi(2)).sum();
    (diff / norm).sqrt()
}

/// A step on each of `batches` from checkpoint `start`, as one trainer (`group` `None`) or
/// as this member of a group.
fn run(start: &Path, batches: &[Vec<Vec<TrainItem>>], group: Option<ThreadGroup>) -> (Vec<StepLosses>, Trainer) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/quickstart.toml");
    let cfg = load_config(&path, &["train.step_threads=1".into()]).unwrap();
    let device = starnet_model::backend::default_device().autodiff();
    let mut trainer = Trainer::start(&cfg, Some(start), &device).unwrap();
    let shard = match &group {
        Some(g) => Shard {
            rank: g.rank(),
            ranks: g.size(),
        },
        None => Shard::whole(),
    };
    if let Some(g) = group {
        trainer = trainer.with_replicas(Arc::new(g)).unwrap();
    }
    let local = batches[0].len() / shard.ranks;
    let losses = batches
        .iter()
        .map(|b| {
            trainer
                .step(&b[shard.rank * local..(shard.rank + 1) * local], 1e-3)
                .unwrap()
        })
        .collect();
    (losses, trainer)
}

#[test]
fn two_replicas_on_halves_of_each_batch_train_as_one_on_the_whole() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/quickstart.toml");
    let cfg = load_config(&path, &[]).unwrap();
    // 20 steps of batch 4 over 8 simulated frames (two alternating batches).
    let frames: Vec<_> = (0..8).map(|k| item(&cfg, k)).collect();
    let batches: Vec<Vec<_>> = (0..20).map(|s| frames[(s % 2) * 4..(s % 2) * 4 + 4].to_vec()).collect();
    // Every run starts from the same weights (as the processes of an MPI run, from one seed).
    let dir = tempfile::tempdir().unwrap();
    let device = starnet_model::backend::default_device().autodiff();
    let start = Trainer::start(&cfg, None, &device)
        .unwrap()
        .save(dir.path(), "start")
        .unwrap();
    let (alone, single) = run(&start, &batches, None);
    // The floor float rounding sets: the one trainer on the same batches in another order,
    // the same sums added in another order (Adam amplifies a step's 1e-6 to ~1e-4 in 20).
    let reordered: Vec<Vec<_>> = batches.iter().map(|b| [&b[2..], &b[..2]].concat()).collect();
    let (floor_steps, floor_model) = run(&start, &reordered, None);
    let floor = deviations(&alone, &floor_steps);
    let members: Vec<_> = ThreadGroup::new(2)
        .into_iter()
        .map(|g| {
            let (batches, start) = (batches.clone(), start.clone());
            std::thread::spawn(move || run(&start, &batches, Some(g)))
        })
        .collect();
    let floor_weights = weight_deviation(&single, &floor_model);
    for m in members {
        let (losses, trainer) = m.join().unwrap();
        let got = deviations(&alone, &losses);
        // The first step's forward is the same sums: equal to rounding.
        assert!(got[0].iter().all(|&d| d < 1e-5), "step 0: {:?}", got[0]);
        let worst_floor: [f32; 7] = std::array::from_fn(|i| floor.iter().map(|f| f[i]).fold(0.0, f32::max));
        for (step, d) in got.iter().enumerate() {
            for (i, (&d, &f)) in d.iter().zip(&worst_floor).enumerate() {
                assert!(d <= (4.0 * f).max(1e-4), "step {step}, value {i}: {d:e} (floor {f:e})");
            }
        }
        let w = weight_deviation(&single, &trainer);
        assert!(
            w <= (4.0 * floor_weights).max(1e-4),
            "weights {w:e} (floor {floor_weights:e})"
        );
    }
}
