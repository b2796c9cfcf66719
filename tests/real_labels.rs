//! Training on real KITTI labels end to end (issue #48): the three frames of `shared/kitti-sample`
//! (their own calibrations; a Truck, Misc, a Pedestrian, a Cyclist and DontCare regions beside the
//! two Cars), a tiny model, a few steps. The location can be overridden with `STARNET_KITTI_SAMPLE`.

mod common;

use common::{TINY_CAR, ok, sample_root};
use starnet_data::augment::{GtDatabase, Writability, database_path, writability};
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_data::sampling::{PipelineConfig, prepare_frame};
use starnet_model::assign::AssignConfig;
use starnet_model::batch::frame_targets;
use starnet_model::nn::StarNetConfig;
use starnet_train::config::load_config;
use starnet_train::train::{TrainOptions, prepare_database, train};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A writable KITTI root over the sample's files: `training/` linked, train and val splits of
/// all three frames (the paste database is written into the root).
fn real_root(dir: &Path) -> PathBuf {
    let root = dir.join("real");
    std::fs::create_dir_all(root.join("ImageSets")).unwrap();
    std::os::unix::fs::symlink(sample_root().join("training"), root.join("training")).unwrap();
    for split in ["train", "val"] {
        std::fs::write(root.join(format!("ImageSets/{split}.txt")), "000000\n000001\n000002\n").unwrap();
    }
    root
}

#[test]
fn a_tiny_model_trains_and_evaluates_on_real_labels() {
    let dir = tempfile::tempdir().unwrap();
    let root = real_root(dir.path());
    let text = TINY_CAR
        .replace("DATA", &root.display().to_string())
        .replace("simulate_frames = 8", "simulate_frames = 0")
        .replace("epochs = 1", "epochs = 3");
    let path = dir.path().join("real.toml");
    std::fs::write(&path, text).unwrap();
    let cfg = load_config(&path, &[]).unwrap();
    let summary = train(&cfg, &dir.path().join("run"), &TrainOptions::default()).unwrap();
    // Three frames at batch 2: one full batch an epoch (the odd frame waits for the next epoch's
    // shuffle).
    assert_eq!(summary.steps, 3);
    assert!(summary.eval.is_some(), "the run evaluates on the real val split");
    let log = std::fs::read_to_string(dir.path().join("run/log.jsonl")).unwrap();
    let losses: Vec<f64> = log
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| v.get("loss").and_then(|l| l.as_f64()))
        .collect();
    assert!(!losses.is_empty() && losses.iter().all(|l| l.is_finite()), "{losses:?}");
    // The paste database was cut from the real labels: their cars and other objects, never a
    // DontCare region.
    let db = GtDatabase::read(&database_path(&root, LabelSource::Camera, "train")).unwrap();
    let cars = db.entries.iter().filter(|e| e.class == ObjectClass::Car).count();
    assert!((1..=2).contains(&cars), "{cars} cars in the database");
    assert!(db.entries.iter().all(|e| e.class != ObjectClass::DontCare));
}

#[test]
fn the_assignment_finds_each_labelled_car_of_a_real_frame() {
    use rand::SeedableRng;
    let ds = KittiDataset::open(sample_root(), None).unwrap();
    let pipeline = PipelineConfig {
        num_centers: 512,
        ..Default::default()
    };
    let model = StarNetConfig::small_car();
    let mut found = 0;
    for id in ds.ids() {
        let frame = ds.load(id).unwrap();
        let prepared = prepare_frame(
            &frame,
            &pipeline,
            None,
            &[],
            &mut rand_chacha::ChaCha8Rng::seed_from_u64(1),
        );
        let targets = frame_targets(
            &prepared,
            &model.anchors,
            &[ObjectClass::Car],
            &AssignConfig::kitti_car(),
        );
        let mut matched: Vec<usize> = targets
            .matched
            .iter()
            .zip(&targets.class)
            .filter_map(|(m, c)| c.and(*m))
            .collect();
        matched.sort_unstable();
        matched.dedup();
        let cars = prepared.classes.iter().filter(|c| **c == ObjectClass::Car).count();
        // DontCare regions (four in the sample) carry no 3D box: dropped, as lingvo and OpenPCDet do.
        assert!(!prepared.classes.contains(&ObjectClass::DontCare), "frame {id}");
        // Every labelled car in the frame has a foreground anchor, and nothing else does (the
        // Truck, the Cyclist and the Pedestrian are not cars).
        assert_eq!(matched.len(), cars, "frame {id}");
        found += matched.len();
    }
    assert_eq!(found, 2, "the sample's two cars");
}

#[test]
fn each_split_pastes_only_its_own_frames() {
    let dir = tempfile::tempdir().unwrap();
    let root = real_root(dir.path());
    std::fs::write(root.join("ImageSets/one.txt"), "000001\n").unwrap();
    let all = prepare_database(&root, "train", LabelSource::Camera).unwrap();
    let one = prepare_database(&root, "one", LabelSource::Camera).unwrap();
    assert!(
        all.entries.iter().any(|e| e.frame != "000001"),
        "the train split spans three frames"
    );
    assert!(!one.entries.is_empty() && one.entries.iter().all(|e| e.frame == "000001"));
    // Two files: building one split's database leaves the other's as it was.
    let read = |split: &str| GtDatabase::read(&database_path(&root, LabelSource::Camera, split)).unwrap();
    assert_eq!(read("train").entries.len(), all.entries.len());
    assert_eq!(read("one").entries.len(), one.entries.len());
    assert_eq!(
        database_path(&root, LabelSource::Camera, "train"),
        root.join("gt_database.bin")
    );
    assert_eq!(
        database_path(&root, LabelSource::AllAround, "one"),
        root.join("gt_database_360.one.bin")
    );
}

/// A folder made read-only for this process, the superuser included (mode 555, else the
/// immutable attribute); writable again on drop, so that the temporary folder can go.
struct ReadOnly(PathBuf);

impl ReadOnly {
    /// `None` where this machine lets neither take effect.
    fn make(dir: &Path) -> Option<Self> {
        use std::os::unix::fs::PermissionsExt;
        let guard = Self(dir.to_path_buf());
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o555)).unwrap();
        if writability(dir) == Writability::Writable {
            let _ = Command::new("chattr").arg("+i").arg(dir).output();
        }
        (writability(dir) == Writability::ReadOnly).then_some(guard)
    }
}

impl Drop for ReadOnly {
    fn drop(&mut self) {
        use std::os::unix::fs::PermissionsExt;
        let _ = Command::new("chattr").arg("-i").arg(&self.0).output();
        let _ = std::fs::set_permissions(&self.0, std::fs::Permissions::from_mode(0o755));
    }
}

/// `starnet ARGS` with the cache folder `cache` (none at all where `None`).
fn starnet_with_cache(args: &[&str], cache: Option<&Path>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_starnet"));
    command
        .args(args)
        .env_remove("XDG_CACHE_HOME")
        .env_remove("STARNET_CACHE_DIR");
    match cache {
        Some(c) => command.env("STARNET_CACHE_DIR", c),
        None => command.env_remove("HOME"),
    };
    command.output().unwrap()
}

#[test]
fn a_read_only_root_keeps_its_paste_database_in_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let root = real_root(dir.path());
    let Some(_read_only) = ReadOnly::make(&root) else {
        // Neither the mode nor the attribute takes here: the root stays the database's home.
        assert_eq!(writability(&root), Writability::Writable);
        eprintln!("this machine cannot make a folder read-only for this process: the cache path is not exercised");
        return;
    };
    let data = root.display().to_string();
    let e = starnet_with_cache(&["prepare", "--data", &data], None);
    let stderr = String::from_utf8_lossy(&e.stderr);
    assert!(
        !e.status.success() && stderr.contains(&data) && stderr.contains("STARNET_CACHE_DIR"),
        "{stderr}"
    );
    let cache = dir.path().join("cache");
    ok(&starnet_with_cache(&["prepare", "--data", &data], Some(&cache)));
    let homes: Vec<PathBuf> = std::fs::read_dir(cache.join("gt_database"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(homes.len(), 1, "{homes:?}");
    assert!(
        homes[0].file_name().unwrap().to_string_lossy().starts_with("real-"),
        "{homes:?}"
    );
    let db = GtDatabase::read(&homes[0].join("gt_database.bin")).unwrap();
    assert!(db.entries.iter().any(|e| e.class == ObjectClass::Car));
    let mut names: Vec<String> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect();
    names.sort();
    assert_eq!(names, ["ImageSets", "training"], "nothing written into the root");
    // Training on the root finds the cached database: no second build.
    let config = dir.path().join("real.toml");
    let text = TINY_CAR
        .replace("DATA", &data)
        .replace("simulate_frames = 8", "simulate_frames = 0");
    std::fs::write(&config, text).unwrap();
    let run = dir.path().join("run").display().to_string();
    let trained = starnet_with_cache(
        &["train", "--config", &config.display().to_string(), "--run", &run],
        Some(&cache),
    );
    ok(&trained);
    assert!(
        !String::from_utf8_lossy(&trained.stderr).contains("wrote"),
        "the database was built again"
    );
}
