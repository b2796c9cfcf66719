//! The training loader's work per frame, single-threaded, at the quickstart's settings: read
//! the `.bin`, augment (database paste included), pool, sample 256 centers, gather 32 points
//! each, and assign the anchors' targets. This is what one loader worker does for every
//! training frame, beside the model step (`--bench model`). Medians over 40 simulated frames,
//! each prepared 5 times, pasting from the database of 610 frames (the quickstart's train split).
//!
//! ```text
//! cargo bench -p starnet-model --bench loader
//! ```

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use starnet_data::augment::{AugmentConfig, GtDatabase, Scene, augment as augment_scene};
use starnet_data::kitti::KittiDataset;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::{AnchorGrid, Augmentation, GatherConfig, PipelineConfig, prepare_frame};
use starnet_model::assign::AssignConfig;
use starnet_model::batch::frame_targets;
use starnet_sim::{SynthConfig, synth_frames};
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let dir = std::env::temp_dir().join(format!("starnet-loader-bench-{}", std::process::id()));
    synth_frames(&dir, 610, 4, &SynthConfig::default(), &|| {}).expect("synth");
    let ds = KittiDataset::open(&dir, None).expect("open");
    let frames = &ds.ids()[..40];
    let db = GtDatabase::build(&ds, &|| {}).expect("db");
    let pipeline = PipelineConfig {
        num_centers: 256,
        gather: GatherConfig {
            num_points: 32,
            radius: 3.0,
            metric: Default::default(),
            reflectance: Default::default(),
        },
        ..PipelineConfig::default()
    };
    let augment = AugmentConfig::default();
    let (grid, classes) = (AnchorGrid::kitti_car(), [ObjectClass::Car]);
    let assign = AssignConfig::kitti_car();
    let (mut load, mut augment_only, mut prepare, mut targets) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, id) in frames.iter().cycle().take(5 * frames.len()).enumerate() {
        let t = Instant::now();
        let frame = ds.load(id).expect("load");
        load.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let (boxes, labels) = frame.labelled_boxes().into_iter().map(|(o, b)| (b, o.class)).unzip();
        let mut scene = Scene {
            points: frame.points.clone(),
            boxes,
            classes: labels,
        };
        std::hint::black_box(augment_scene(
            &mut scene,
            &augment,
            Some(&db),
            &mut ChaCha8Rng::seed_from_u64(k as u64),
        ));
        augment_only.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let aug = Augmentation {
            config: &augment,
            database: Some(&db),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(k as u64);
        let p = prepare_frame(&frame, &pipeline, Some(aug), &[], &mut rng);
        prepare.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        std::hint::black_box(frame_targets(&p, &grid, &classes, &assign));
        targets.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let _ = std::fs::remove_dir_all(&dir);
    let total: Vec<f64> = (0..load.len()).map(|i| load[i] + prepare[i] + targets[i]).collect();
    println!("{} database objects; per training frame, medians:", db.entries.len());
    println!("read .bin            {:6.2} ms", median(load));
    println!("augment + prepare    {:6.2} ms", median(prepare));
    println!("  of which augment   {:6.2} ms (timed alone)", median(augment_only));
    println!("anchor targets       {:6.2} ms", median(targets));
    println!("whole frame          {:6.2} ms", median(total));
}
