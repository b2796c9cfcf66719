//! [`TrainedModel`]: a trained network and the experiment config it was trained with, loaded
//! from a checkpoint or an export folder — the one loader every command uses.

use crate::checkpoint::load_model;
use crate::config::{ExperimentConfig, load_config};
use crate::detector::Detector;
use crate::export::load_exported;
use crate::{Result, TrainError};
use starnet_model::nn::StarNet;
use std::path::{Path, PathBuf};

/// A network with its config.
#[derive(Debug, Clone)]
pub struct TrainedModel {
    /// The config it was trained with (with any overrides applied).
    pub config: ExperimentConfig,
    /// The network: a checkpoint's averaged weights when it kept them.
    pub model: StarNet,
}

impl TrainedModel {
    /// Loads `path`: an export folder (holding `model.safetensors`; the config from its
    /// metadata) or a checkpoint folder or `.bpk` file (the config `config`, else the
    /// `config.toml` of the run folder above it). `sets` override config keys as `--set` does.
    pub fn load(path: &Path, config: Option<&Path>, sets: &[String]) -> Result<Self> {
        if path.join("model.safetensors").is_file() {
            let (model, config) = load_exported(path, sets)?;
            return Ok(Self { config, model });
        }
        let config = load_config(&run_config(path, config)?, sets)?;
        let model = load_model(
            path,
            config.model_config().init(&starnet_model::backend::default_device()),
        )?;
        Ok(Self { config, model })
    }

    /// A [`Detector`] at the config's evaluation budget.
    pub fn detector(&self) -> Detector {
        Detector::new(self.model.clone(), &self.config)
    }
}

impl Detector {
    /// An export folder or a checkpoint (folder or `.bpk`, with the `config.toml` of its run),
    /// at its config's evaluation budget; see [`TrainedModel::load`].
    pub fn load(path: &Path) -> Result<Self> {
        Ok(TrainedModel::load(path, None, &[])?.detector())
    }
}

/// The config given, or the `config.toml` of the run folder above `checkpoint`.
pub fn run_config(checkpoint: &Path, given: Option<&Path>) -> Result<PathBuf> {
    if let Some(c) = given {
        return Ok(c.to_path_buf());
    }
    checkpoint
        .ancestors()
        .map(|a| a.join("config.toml"))
        .find(|p| p.is_file())
        .ok_or_else(|| TrainError::Checkpoint {
            path: checkpoint.to_path_buf(),
            message: "no config.toml above the checkpoint; pass the run's config".into(),
        })
}

/// A checkpoint's run name: the folder above `checkpoints/`, else the checkpoint's own.
pub fn run_label(checkpoint: &Path) -> String {
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    checkpoint
        .ancestors()
        .find(|a| a.file_name().is_some_and(|n| n == "checkpoints"))
        .and_then(|a| a.parent().and_then(name))
        .or_else(|| name(checkpoint))
        .unwrap_or_else(|| "model".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_label_is_the_folder_above_checkpoints() {
        assert_eq!(run_label(Path::new("runs/stream-car/checkpoints/best")), "stream-car");
        assert_eq!(run_label(Path::new("runs/x/checkpoints/step-10/model.bpk")), "x");
        assert_eq!(run_label(Path::new("exports/car")), "car");
    }

    #[test]
    fn a_checkpoint_without_a_config_names_itself() {
        let dir = tempfile::tempdir().unwrap();
        let err = TrainedModel::load(&dir.path().join("best"), None, &[]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("best") && msg.contains("config.toml"), "{msg}");
    }
}
