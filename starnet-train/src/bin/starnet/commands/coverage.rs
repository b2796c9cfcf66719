//! `starnet coverage`: measure how many objects (with at least 5 points) the sampled centers reach.

use clap::Args;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::Sampler;
use starnet_train::evaluate::{paper_coverage, run_coverage};
use std::path::PathBuf;

/// Measure how many objects (with at least 5 points) the sampled centers reach: the share
/// with an anchor at BEV IoU > 0.5 around some center, per sampler and center count
/// (the StarNet paper's figure 5). Prints a table and writes a PNG plot.
#[derive(Args)]
pub struct Coverage {
    /// KITTI root.
    #[arg(long)]
    data: PathBuf,
    /// Split to measure (ImageSets/SPLIT.txt); every frame if absent.
    #[arg(long)]
    split: Option<String>,
    /// Center counts.
    #[arg(long, value_delimiter = ',', default_value = "16,32,64,128,256,512,1024")]
    samples: Vec<usize>,
    /// Samplers to compare: fps, random.
    #[arg(long, value_delimiter = ',', default_value = "fps,random")]
    sampler: Vec<Sampler>,
    /// Sample centers all around the sensor, not only in the camera's view.
    #[arg(long)]
    full: bool,
    /// Classes counted, each with its KITTI anchors (cars', pedestrians' or cyclists').
    #[arg(long, value_delimiter = ',', default_value = "Car,Pedestrian,Cyclist", value_parser = crate::parse::parse_class)]
    classes: Vec<ObjectClass>,
    /// Output PNG.
    #[arg(long, default_value = "coverage.png")]
    plot: PathBuf,
    /// Seed for the samplers.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

impl Coverage {
    pub fn run(self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.samples.is_empty() && self.samples.iter().all(|n| *n > 0),
            "--samples needs positive counts"
        );
        let cfg = paper_coverage(&self.samples, &self.sampler, &self.classes, self.full);
        run_coverage(&self.data, self.split.as_deref(), &cfg, &self.plot, self.seed)?;
        Ok(())
    }
}
