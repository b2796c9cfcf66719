//! `starnet prepare`: build the ground-truth database for paste augmentation from the train split.

use clap::Args;
use starnet_data::kitti::LabelSource;
use std::path::PathBuf;

/// Build the ground-truth database for paste augmentation from the train split:
/// every labelled object with the points inside its box, written to ROOT/gt_database.bin
/// (ROOT/gt_database_360.bin from the simulator's all-around labels; another split than `train`
/// writes ROOT/gt_database.SPLIT.bin, the file a training on that split reads). A read-only ROOT
/// that holds none gets it in the cache instead: STARNET_CACHE_DIR (else $XDG_CACHE_HOME/starnet,
/// else ~/.cache/starnet)/gt_database/NAME-HASH/, where training finds it.
#[derive(Args)]
pub struct Prepare {
    /// KITTI root.
    #[arg(long)]
    data: PathBuf,
    /// Split to draw objects from.
    #[arg(long, default_value = "train")]
    split: String,
    /// The labels to draw objects from: `label_2` (camera view) or `label_360` (the
    /// simulator's all-around labels, for configs with `data.labels = "label_360"`).
    #[arg(long, default_value = "label_2", value_parser = crate::parse::parse_labels)]
    labels: LabelSource,
}

impl Prepare {
    pub fn run(self) -> anyhow::Result<()> {
        starnet_train::train::prepare_database(&self.data, &self.split, self.labels)?;
        Ok(())
    }
}
