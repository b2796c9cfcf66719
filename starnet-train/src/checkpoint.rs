//! A checkpoint folder as the commands read it: the model (`model.bpk`, burnpack), the
//! evaluation model with the averaged weights (`ema.bpk`, when the run keeps a weight EMA), the
//! optimizer state (`optim.bpk`) and the training position (`state.json`); a run's
//! `checkpoints/step-NNNNNNNN` folders. Training writes them ([`crate::train::save_checkpoint`]:
//! into a temporary folder, renamed into place, so a crash leaves the previous checkpoint
//! whole) and `--resume` continues from the newest.

use crate::{Result, TrainError};
use burn::module::Module;
use burn::store::ModuleRecord;
use serde::{Deserialize, Serialize};
use starnet_model::nn::StarNet;
use std::path::{Path, PathBuf};

/// Where training stands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainState {
    /// Steps done.
    pub step: u64,
    /// Best validation metric so far (Car 3D AP R40 moderate), if evaluated.
    pub best_metric: Option<f64>,
}

pub(crate) fn ckpt_error(path: &Path, e: impl std::fmt::Display) -> TrainError {
    TrainError::Checkpoint {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Puts back what a kill inside [`crate::train::save_checkpoint`] left in `dir`: a checkpoint moved aside
/// (`.NAME.old`) whose replacement never took its name returns to `NAME`; unfinished
/// temporary folders are removed.
pub fn recover_checkpoints(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name().to_string_lossy().into_owned();
        let path = entry.path();
        if let Some(name) = file_name.strip_prefix('.').and_then(|n| n.strip_suffix(".old")) {
            let target = dir.join(name);
            if target.exists() {
                std::fs::remove_dir_all(&path).map_err(|e| ckpt_error(&path, e))?;
            } else {
                std::fs::rename(&path, &target).map_err(|e| ckpt_error(&target, e))?;
            }
        } else if file_name.starts_with('.') && file_name.ends_with(".tmp") {
            std::fs::remove_dir_all(&path).map_err(|e| ckpt_error(&path, e))?;
        }
    }
    Ok(())
}

/// Loads the evaluation model of a checkpoint folder into `model`: its `ema.bpk` (averaged
/// weights) when the run kept one, else its `model.bpk`; or the given `.bpk` file.
pub fn load_model(path: &Path, model: StarNet) -> Result<StarNet> {
    let file = if path.is_dir() {
        Some(path.join("ema.bpk"))
            .filter(|f| f.is_file())
            .unwrap_or_else(|| path.join("model.bpk"))
    } else {
        path.to_path_buf()
    };
    if !file.is_file() {
        return Err(ckpt_error(
            &file,
            "no such checkpoint (expected a checkpoint folder or a model.bpk file)",
        ));
    }
    let bytes = std::fs::read(&file).map_err(|e| ckpt_error(&file, e))?;
    model_from_bytes(bytes, model, &file)
}

/// Loads the burnpack `bytes` of `file` into `model`. A malformed pack, or one of another
/// model (a missing, extra or differently shaped tensor), is an error naming `file`.
pub fn model_from_bytes(bytes: Vec<u8>, model: StarNet, file: &Path) -> Result<StarNet> {
    // The burnpack reader is not hardened against every malformed input: a panic inside it is
    // this file's error, not the program's.
    let loaded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let record = ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes))?;
        model.try_load_record(record)
    }));
    match loaded {
        Ok(Ok(model)) => Ok(model),
        Ok(Err(e)) => Err(ckpt_error(file, format!("cannot load the model: {e}"))),
        Err(_) => Err(ckpt_error(file, "cannot load the model: a malformed burnpack file")),
    }
}

/// Parses a checkpoint's `state.json` (the text of `file`).
pub fn parse_state(text: &str, file: &Path) -> Result<TrainState> {
    serde_json::from_str(text).map_err(|e| ckpt_error(file, e))
}

/// A `step-*` checkpoint of a run.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct StepCheckpoint {
    /// The steps trained when it was written.
    pub step: u64,
    /// Its folder.
    pub path: PathBuf,
}

/// The `step-*` checkpoints in `dir` (a run's `checkpoints/`), oldest first.
pub fn step_checkpoints(dir: &Path) -> Vec<StepCheckpoint> {
    let mut steps: Vec<StepCheckpoint> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| {
            p.file_name()?
                .to_str()?
                .strip_prefix("step-")?
                .parse()
                .ok()
                .map(|step| StepCheckpoint { step, path: p.clone() })
        })
        .collect();
    steps.sort();
    steps
}

/// The newest `step-*` checkpoint in `dir`.
pub fn latest_checkpoint(dir: &Path) -> Option<PathBuf> {
    step_checkpoints(dir).pop().map(|c| c.path)
}

/// Removes the `step-*` checkpoints in `dir` a run no longer needs: all but the newest `keep`
/// taken at epoch ends (multiples of `steps_per_epoch`), and any taken between them (a stopped
/// run's, to resume from) once a newer one exists. What survives a stop and a resume is then
/// what an uninterrupted run leaves.
pub fn prune(dir: &Path, keep: usize, steps_per_epoch: u64) {
    let steps = step_checkpoints(dir);
    let newest = steps.last().map(|c| c.step);
    let (at_epoch_ends, between): (Vec<_>, Vec<_>) = steps
        .into_iter()
        .partition(|c| c.step.is_multiple_of(steps_per_epoch.max(1)));
    let served = between.iter().filter(|c| Some(c.step) != newest);
    let old = at_epoch_ends.iter().take(at_epoch_ends.len().saturating_sub(keep));
    for c in served.chain(old) {
        let _ = std::fs::remove_dir_all(&c.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ExperimentConfig;

    fn model(width: usize) -> StarNet {
        let mut cfg = ExperimentConfig::default();
        cfg.model.blocks = vec![[width, 8]];
        cfg.model.d_fc0 = 8;
        cfg.model.d_offset = 4;
        cfg.model_config().init(&starnet_model::backend::default_device())
    }

    #[test]
    fn a_stopped_runs_checkpoint_goes_once_a_newer_one_exists() {
        let dir = tempfile::tempdir().unwrap();
        let make = |s: u64| std::fs::create_dir_all(dir.path().join(format!("step-{s:08}"))).unwrap();
        let left = || -> Vec<u64> { step_checkpoints(dir.path()).iter().map(|c| c.step).collect() };
        // Epochs of 4 steps, two kept: a stop at step 10 keeps both epoch ends beside it.
        for s in [4, 8, 10] {
            make(s);
        }
        prune(dir.path(), 2, 4);
        assert_eq!(left(), vec![4, 8, 10]);
        // The resumed run's next epoch end: as if it had never stopped.
        make(12);
        prune(dir.path(), 2, 4);
        assert_eq!(left(), vec![8, 12]);
    }

    #[test]
    fn a_checkpoint_moved_aside_by_a_killed_save_is_put_back() {
        let dir = tempfile::tempdir().unwrap();
        // A kill after the old `best` stepped aside, before the new one took its name.
        std::fs::create_dir_all(dir.path().join(".best.old")).unwrap();
        std::fs::write(dir.path().join(".best.old/state.json"), "old").unwrap();
        std::fs::create_dir_all(dir.path().join(".best.tmp")).unwrap();
        // And a kill after the rename: the old one is left aside beside its replacement.
        std::fs::create_dir_all(dir.path().join("step-00000004")).unwrap();
        std::fs::create_dir_all(dir.path().join(".step-00000004.old")).unwrap();
        recover_checkpoints(dir.path()).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("best/state.json")).unwrap(),
            "old"
        );
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["best", "step-00000004"]);
    }

    #[test]
    fn a_truncated_or_foreign_model_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("model.bpk");
        model(8).save_file(&file).unwrap();
        // Another width: the error names the file and the tensor whose shape differs.
        let msg = load_model(&file, model(16)).unwrap_err().to_string();
        assert!(msg.contains("model.bpk"), "{msg}");
        assert!(msg.contains("featurizer"), "no tensor named: {msg}");
        // Truncated: still the file's error, not a panic.
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..bytes.len() / 2]).unwrap();
        let msg = load_model(&file, model(8)).unwrap_err().to_string();
        assert!(msg.contains("model.bpk"), "{msg}");
        // A state.json that is not one.
        let msg = parse_state("{\"step\": -3}", Path::new("ckpt/state.json"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("ckpt/state.json"), "{msg}");
    }
}
