//! `starnet config`: print an experiment's resolved config (its bases, overrides and every default)
//! as TOML; without --config, the defaults, which document every key.

use clap::Args;
use std::path::PathBuf;

/// Print an experiment's resolved config (its bases, overrides and every default) as TOML;
/// without --config, the defaults, which document every key.
#[derive(Args)]
pub struct Config {
    /// Experiment file.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override a config key (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
}

impl Config {
    pub fn run(self) -> anyhow::Result<()> {
        let cfg = match &self.config {
            Some(c) => starnet_train::config::load_config(c, &self.sets)?,
            None => starnet_train::config::ExperimentConfig::default(),
        };
        print!("{}", starnet_train::config::to_toml(&cfg));
        Ok(())
    }
}
