//! Writing a training checkpoint (the model, its weight EMA, Adam's moments, the position)
//! and restoring one to resume: the folder layout is [`crate::checkpoint`]'s.

use super::ema::WeightEma;
use crate::Result;
use crate::checkpoint::{TrainState, ckpt_error, load_model, parse_state};
use burn::module::Module;
use burn::optim::{AdamConfig, ModuleOptimizer};
use starnet_model::nn::StarNet;
use std::path::{Path, PathBuf};

/// Writes `{dir}/{name}/` atomically (temp folder + rename).
pub fn save_checkpoint(
    dir: &Path,
    name: &str,
    model: &StarNet,
    optim: &ModuleOptimizer,
    ema: Option<&WeightEma>,
    state: &TrainState,
) -> Result<PathBuf> {
    let target = dir.join(name);
    let tmp = dir.join(format!(".{name}.tmp"));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| ckpt_error(&tmp, e))?;
    model
        .clone()
        .save_file(tmp.join("model.bpk"))
        .map_err(|e| ckpt_error(&tmp.join("model.bpk"), e))?;
    if let Some(ema) = ema {
        ema.apply(model)
            .save_file(tmp.join("ema.bpk"))
            .map_err(|e| ckpt_error(&tmp.join("ema.bpk"), e))?;
    }
    optim
        .save(tmp.join("optim.bpk"))
        .map_err(|e| ckpt_error(&tmp.join("optim.bpk"), e))?;
    let json = serde_json::to_string_pretty(state).expect("state serialises");
    std::fs::write(tmp.join("state.json"), json).map_err(|e| ckpt_error(&tmp.join("state.json"), e))?;
    // The old checkpoint steps aside before the new one takes its name, so a kill between the
    // two renames leaves a whole checkpoint that `recover_checkpoints` puts back.
    let old = dir.join(format!(".{name}.old"));
    let _ = std::fs::remove_dir_all(&old);
    if target.exists() {
        std::fs::rename(&target, &old).map_err(|e| ckpt_error(&target, e))?;
    }
    std::fs::rename(&tmp, &target).map_err(|e| ckpt_error(&target, e))?;
    let _ = std::fs::remove_dir_all(&old);
    Ok(target)
}

/// What a checkpoint restores.
pub struct Restored {
    /// The trained model.
    pub model: StarNet,
    /// Adam's moments.
    pub optim: ModuleOptimizer,
    /// The weight EMA, when `ema_decay` is given: from `ema.bpk`, or started at the model when
    /// the checkpoint has none.
    pub ema: Option<WeightEma>,
    /// The training position.
    pub state: TrainState,
}

/// Loads a whole checkpoint folder for resuming into models made by `init`; `ema_decay` > 0
/// restores the weight EMA.
pub fn load_checkpoint(dir: &Path, init: impl Fn() -> StarNet, adam: &AdamConfig, ema_decay: f64) -> Result<Restored> {
    let model = load_model(&dir.join("model.bpk"), init())?;
    let ema = (ema_decay > 0.0)
        .then(|| -> Result<WeightEma> {
            let file = dir.join("ema.bpk");
            let averaged = if file.is_file() {
                // A module of its own: loading into a clone of `model` would share its
                // not-yet-initialised parameters.
                load_model(&file, init())?
            } else {
                model.clone()
            };
            Ok(WeightEma::new(ema_decay, &averaged))
        })
        .transpose()?;
    let optim = adam
        .init()
        .load(dir.join("optim.bpk"))
        .map_err(|e| ckpt_error(&dir.join("optim.bpk"), e))?;
    let state_file = dir.join("state.json");
    let text = std::fs::read_to_string(&state_file).map_err(|e| ckpt_error(&state_file, e))?;
    let state = parse_state(&text, &state_file)?;
    Ok(Restored {
        model,
        optim,
        ema,
        state,
    })
}
