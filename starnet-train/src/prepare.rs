//! `starnet prepare`: the ground-truth database the paste augmentation reads.

use crate::Result;
use crate::synth::progress_bar;
use starnet_data::augment::GtDatabase;
use starnet_data::kitti::{KittiDataset, LabelSource};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where `prepare` writes the database of a KITTI root from `labels`: `gt_database.bin` from
/// the camera-view labels, `gt_database_360.bin` from the simulator's all-around ones (whose
/// objects lie all around the sensor, so that an all-around model is pasted objects behind it
/// as well as in front).
pub fn database_path(root: &Path, labels: LabelSource) -> PathBuf {
    root.join(match labels {
        LabelSource::Camera => "gt_database.bin",
        LabelSource::AllAround => "gt_database_360.bin",
    })
}

/// Builds the database from `split` (normally `train`) with `labels` and writes it to
/// [`database_path`].
pub fn run_prepare(root: &Path, split: &str, labels: LabelSource) -> Result<GtDatabase> {
    let ds = KittiDataset::open(root, Some(split))?.with_labels(labels);
    let bar = progress_bar(ds.ids().len() as u64, "prepare");
    let db = GtDatabase::build(&ds, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let path = database_path(root, labels);
    db.write(&path)?;
    let mut per_class: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for e in &db.entries {
        let c = per_class.entry(e.class.to_string()).or_default();
        c.0 += 1;
        c.1 += e.points.len();
    }
    println!(
        "wrote {} ({} objects from {} frames of `{split}`)",
        path.display(),
        db.entries.len(),
        ds.ids().len()
    );
    for (class, (n, pts)) in per_class {
        println!(
            "  {class:<15} {n:>6} objects, {:>6.1} points on average",
            pts as f64 / n as f64
        );
    }
    Ok(db)
}
