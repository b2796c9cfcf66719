//! The training data: generated when the config asks for the simulator and it is absent, then
//! per item loaded, augmented, sampled, gathered and assigned its targets, in loader threads.
//!
//! Determinism: the data order is a function of (seed, epoch) and item `k`'s randomness of
//! (seed, k), so a resumed run sees exactly the items the uninterrupted one would have.

use super::schedule::Schedule;
use crate::config::ExperimentConfig;
use crate::distributed::Shard;
use crate::{Result, TrainError};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use starnet_data::augment::{GtDatabase, database_location};
use starnet_data::custom::is_custom_layout;
use starnet_data::events::{Task, note};
use starnet_data::kitti::{KittiDataset, LabelSource, ObjectClass};
use starnet_data::loader::Loader;
use starnet_data::sampling::{Augmentation, PreparedFrame, prepare_frame, prepare_sweep};
use starnet_data::seed::sub_seed;
use starnet_model::assign::AnchorTargets;
use starnet_model::batch::frame_targets;
use starnet_sim::{SIMULATOR_VERSION, SynthConfig, generated_version, synth_frames};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

/// One prepared frame (a whole sweep, or one slice of it) with its anchor targets.
#[derive(Debug, Clone)]
pub struct TrainItem {
    /// Centers, neighbourhoods and boxes.
    pub frame: PreparedFrame,
    /// What every anchor should predict.
    pub targets: AnchorTargets,
}

/// Generates the built-in data if the config asks for it and it is absent, and the ground-truth
/// database if the paste augmentation needs it.
pub fn ensure_data(cfg: &ExperimentConfig) -> Result<()> {
    let root = &cfg.data.root;
    if cfg.data.simulate_frames > 0
        && let Some(found) = generated_version(root)?
        && found != SIMULATOR_VERSION
    {
        return Err(TrainError::StaleSimulation {
            root: root.clone(),
            found,
            expected: SIMULATOR_VERSION,
        });
    }
    // A dataset in the custom layout is the user's own: nothing is generated beside it.
    let present = root.join("training/velodyne").is_dir() || is_custom_layout(root);
    if present && cfg.data.simulate_frames > 0 {
        refuse_incomplete(root, &cfg.data.train_split)?;
    }
    if !present && cfg.data.simulate_frames > 0 {
        note(format!(
            "generating {} simulated frames at {}",
            cfg.data.simulate_frames,
            root.display()
        ));
        let task = Task::begin("synth", cfg.data.simulate_frames as u64);
        // Staged: another trainer generating the same root is waited for, and an interrupted
        // generation is continued (`Outcome::AlreadyPresent`: the other trainer wrote it).
        synth_frames(
            root,
            cfg.data.simulate_frames,
            cfg.data.simulate_seed,
            &SynthConfig::default(),
            &|| task.inc(1),
        )?;
    }
    if cfg.augment.db_paste.enabled
        && !GtDatabase::is_current(&database_location(root, cfg.data.labels, &cfg.data.train_split)?)
    {
        prepare_database(root, &cfg.data.train_split, cfg.data.labels)?;
    }
    Ok(())
}

/// Refuses a root with frames but neither the split file nor `synth.json`: what an interrupted
/// generation left before generations were staged, which would otherwise fail with a bare
/// "No such file" on the split.
fn refuse_incomplete(root: &Path, split: &str) -> Result<()> {
    let split_file = root.join("ImageSets").join(format!("{split}.txt"));
    if !split_file.is_file() && !root.join("synth.json").is_file() {
        return Err(TrainError::IncompleteData {
            root: root.to_path_buf(),
            split: split.to_string(),
        });
    }
    Ok(())
}

/// The slice count of step `step` of a streaming config (drawn from `stream.train_slices`, the
/// same for every sweep of the step), `None` when training on whole sweeps.
pub fn slices_at(cfg: &ExperimentConfig, step: u64) -> Option<usize> {
    let choices = &cfg.stream.train_slices;
    (!choices.is_empty()).then(|| choices[(sub_seed(cfg.seed, 33, step) % choices.len() as u64) as usize])
}

/// Builds the database from `split` (normally `train`) with `labels` and writes it to
/// [`database_location`]: into the root, or into the cache for a read-only root.
pub fn prepare_database(root: &Path, split: &str, labels: LabelSource) -> Result<GtDatabase> {
    let ds = KittiDataset::open(root, Some(split))?.with_labels(labels);
    let task = Task::begin("prepare", ds.ids().len() as u64);
    let db = GtDatabase::build(&ds, &|| task.inc(1))?;
    drop(task);
    let path = database_location(root, labels, split)?;
    if let Some(folder) = path.parent() {
        std::fs::create_dir_all(folder).map_err(|e| starnet_data::DataError::io(folder, e))?;
    }
    db.write(&path)?;
    note(format!(
        "wrote {} ({} objects from {} frames of `{split}`)",
        path.display(),
        db.entries.len(),
        ds.ids().len()
    ));
    for (class, tally) in class_tallies(&db) {
        note(format!(
            "  {:<15} {:>6} objects, {:>6.1} points on average",
            class.to_string(),
            tally.objects,
            tally.points as f64 / tally.objects as f64
        ));
    }
    Ok(db)
}

/// Objects of one class in a database, and their points.
#[derive(Debug, Clone, Copy, Default)]
struct ClassTally {
    objects: usize,
    points: usize,
}

/// Each class's tally, in KITTI's class order.
fn class_tallies(db: &GtDatabase) -> BTreeMap<ObjectClass, ClassTally> {
    let mut tallies: BTreeMap<ObjectClass, ClassTally> = BTreeMap::new();
    for e in &db.entries {
        let t = tallies.entry(e.class).or_default();
        t.objects += 1;
        t.points += e.points.len();
    }
    tallies
}

/// The paste augmentation's database, when the config enables it.
pub fn paste_database(cfg: &ExperimentConfig) -> Result<Option<Arc<GtDatabase>>> {
    if !cfg.augment.db_paste.enabled {
        return Ok(None);
    }
    let path = database_location(&cfg.data.root, cfg.data.labels, &cfg.data.train_split)?;
    Ok(Some(Arc::new(GtDatabase::read(&path)?)))
}

/// Item `k` of a run (counting from its first step, `batch` items per step): a frame of
/// `train_set` in the order of its epoch, augmented and prepared as one sweep or as the
/// slices of its step.
pub fn train_item(
    cfg: &ExperimentConfig,
    train_set: &KittiDataset,
    database: Option<&GtDatabase>,
    schedule: &Schedule,
    k: usize,
) -> starnet_data::Result<Vec<TrainItem>> {
    let batch = cfg.train.batch_size;
    let per_epoch = schedule.steps_per_epoch as usize * batch;
    let (epoch, pos) = (k / per_epoch, k % per_epoch);
    let n = train_set.ids().len();
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(sub_seed(cfg.seed, 31, epoch as u64)));
    let frame = train_set.load(&train_set.ids()[order[pos % n]])?;
    let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(cfg.seed, 32, k as u64));
    let aug = Augmentation {
        config: &cfg.augment,
        database,
    };
    // A sweep is a sequence of slices (one, unless streaming), each a frame of its own.
    let slices = match slices_at(cfg, (k / batch) as u64) {
        None => vec![prepare_frame(&frame, &cfg.pipeline, Some(aug), &[], &mut rng)],
        Some(n) => prepare_sweep(&frame, &cfg.pipeline, &cfg.stream.slicing, n, Some(aug), &mut rng),
    };
    Ok(slices
        .into_iter()
        .map(|frame| TrainItem {
            targets: frame_targets(&frame, &cfg.model.anchors, &cfg.data.classes, &cfg.assign),
            frame,
        })
        .collect())
}

/// The items of `shard` in steps `first_step..schedule.end` (`train.batch_size` is the global
/// batch; [`Shard::whole`] loads all of it), prepared ahead in `train.workers` threads.
pub fn train_loader(
    cfg: &ExperimentConfig,
    train_set: &KittiDataset,
    database: Option<Arc<GtDatabase>>,
    schedule: Schedule,
    first_step: u64,
    shard: Shard,
) -> Loader<Vec<TrainItem>> {
    let (ds, cfg) = (train_set.clone(), cfg.clone());
    let batch = cfg.train.batch_size;
    let steps = schedule.end - first_step.min(schedule.end);
    Loader::new(
        steps as usize * (batch / shard.ranks),
        cfg.train.workers,
        cfg.train.prefetch,
        cfg.seed,
        move |i, _| {
            let k = first_step as usize * batch + shard.item(batch, i);
            train_item(&cfg, &ds, database.as_deref(), &schedule, k)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_from_another_simulator_version_is_refused_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        std::fs::create_dir_all(root.join("training/velodyne")).unwrap();
        // A set written before the version field existed: version 1.
        std::fs::write(
            root.join("synth.json"),
            r#"{"generator": "starnet synth", "frames": 2}"#,
        )
        .unwrap();
        let mut cfg = ExperimentConfig::default();
        cfg.data.root = root.clone();
        cfg.data.simulate_frames = 2;
        cfg.augment.db_paste.enabled = false;
        match ensure_data(&cfg) {
            Err(TrainError::StaleSimulation { found, expected, .. }) => {
                assert_eq!((found, expected), (1, SIMULATOR_VERSION));
            }
            other => panic!("expected a stale-simulation error, got {other:?}"),
        }
        assert!(root.join("synth.json").is_file(), "nothing is deleted");
        // Frames without split files or synth.json: what an unstaged, interrupted generation left.
        std::fs::remove_file(root.join("synth.json")).unwrap();
        let err = ensure_data(&cfg).unwrap_err();
        assert!(matches!(err, TrainError::IncompleteData { .. }), "{err:?}");
        assert!(err.to_string().contains("delete"), "the error names the remedy: {err}");
        // A real dataset (split files, no synth.json) is never questioned.
        std::fs::create_dir_all(root.join("ImageSets")).unwrap();
        std::fs::write(root.join("ImageSets/train.txt"), "000000\n").unwrap();
        assert!(ensure_data(&cfg).is_ok());
    }

    #[test]
    fn an_absent_root_is_generated_whole_beside_itself() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        let mut cfg = ExperimentConfig::default();
        cfg.data.root = root.clone();
        cfg.data.simulate_frames = 2;
        cfg.augment.db_paste.enabled = false;
        ensure_data(&cfg).unwrap();
        assert!(root.join("ImageSets/train.txt").is_file() && root.join("synth.json").is_file());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(
            names,
            vec![std::ffi::OsString::from("sim")],
            "only the root is left beside it"
        );
    }
}
