//! `starnet compare-data`: compare two KITTI-layout folders (the simulator's and real scans, or
//! your own sensor's).

use clap::Args;
use starnet_train::realism::{DataSource, compare_data, write_comparison};
use std::path::PathBuf;

/// Compare two KITTI-layout folders (the simulator's and real scans, or your own sensor's):
/// reflectance and exact-zero share by range and by what was hit, labelled cars' returns,
/// height and viewpoint by distance, how volumetric the background is. Prints the table;
/// with --out also writes realism.md, realism.json and two plots.
#[derive(Args)]
pub struct CompareData {
    /// First root (A).
    a: PathBuf,
    /// Second root (B).
    b: PathBuf,
    /// Split of A to read (ImageSets/{split}.txt); every frame when absent.
    #[arg(long)]
    split_a: Option<String>,
    /// Split of B to read.
    #[arg(long)]
    split_b: Option<String>,
    /// Read at most this many frames of each (the first by id).
    #[arg(long)]
    frames: Option<usize>,
    /// Folder for realism.md, realism.json, reflectance_by_range.png, zero_by_range.png.
    #[arg(long)]
    out: Option<PathBuf>,
}

impl CompareData {
    pub fn run(self) -> anyhow::Result<()> {
        let a = DataSource {
            root: &self.a,
            split: self.split_a.as_deref(),
        };
        let b = DataSource {
            root: &self.b,
            split: self.split_b.as_deref(),
        };
        let cmp = compare_data(a, b, self.frames)?;
        print!("{cmp}");
        if let Some(out) = &self.out {
            write_comparison(out, &cmp)?;
            println!("\nwrote {}", out.display());
        }
        Ok(())
    }
}
