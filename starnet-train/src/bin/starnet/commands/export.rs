//! `starnet export`: export a checkpoint for other runtimes.

use clap::Args;
use starnet_train::trained::TrainedModel;
use std::path::PathBuf;

/// Export a checkpoint for other runtimes: model.safetensors (PyTorch names and layouts, the
/// config in its metadata), model.json (the contract for host code: features, widths, anchors
/// and their order, box coder, classes, NMS, sampling) and golden.safetensors (an input and
/// the outputs it must give).
#[derive(Args)]
pub struct Export {
    /// A checkpoint folder (runs/NAME/checkpoints/best) or its model.bpk.
    #[arg(long)]
    checkpoint: PathBuf,
    /// The run's config (default: the config.toml of the run holding the checkpoint).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

impl Export {
    pub fn run(self) -> anyhow::Result<()> {
        let trained = TrainedModel::load(&self.checkpoint, self.config.as_deref(), &[])?;
        for path in starnet_train::export::export(&trained.model, &trained.config, &self.out)? {
            println!("wrote {}", path.display());
        }
        Ok(())
    }
}
