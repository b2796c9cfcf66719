//! `starnet synth`: generate the built-in simulator dataset, or print its statistics.

use crate::{Result, TrainError};
use starnet_data::events::{Task, note};
use starnet_data::staging::Outcome;
use starnet_sim::{SynthConfig, dataset_stats, synth_frames, synth_sequences};
use std::path::Path;
use std::time::Instant;

/// What to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SynthJob {
    /// `frames` independent scenes with train/val splits.
    Frames(usize),
    /// `sequences` sequences of `length` frames at 10 Hz.
    Sequences {
        /// Number of sequences.
        sequences: usize,
        /// Frames per sequence.
        length: usize,
    },
}

/// Generates a dataset as `root`, written beside it and renamed into place when complete (an
/// interrupted run of the same command is continued). Refuses a root that already holds
/// something, so frames from an earlier, larger run can never mix with this one.
pub fn run_synth(root: &Path, job: SynthJob, seed: u64, cfg: &SynthConfig) -> Result<()> {
    if root.read_dir().is_ok_and(|mut d| d.next().is_some()) {
        return Err(TrainError::NotEmpty {
            dir: root.to_path_buf(),
        });
    }
    let start = Instant::now();
    let total = match job {
        SynthJob::Frames(n) => n,
        SynthJob::Sequences { sequences, length } => sequences * length,
    };
    let task = Task::begin("synth", total as u64);
    let tick = || task.inc(1);
    let outcome = match job {
        SynthJob::Frames(n) => synth_frames(root, n, seed, cfg, &tick)?,
        SynthJob::Sequences { sequences, length } => synth_sequences(root, sequences, length, seed, cfg, &tick)?,
    };
    drop(task);
    // Another process wrote the root while this one waited for it.
    if outcome == Outcome::AlreadyPresent {
        return Err(TrainError::NotEmpty {
            dir: root.to_path_buf(),
        });
    }
    let secs = start.elapsed().as_secs_f64();
    note(format!(
        "wrote {total} frames to {} in {secs:.1} s ({:.1} frames/s)",
        root.display(),
        total as f64 / secs
    ));
    Ok(())
}

/// Reports the statistics table of a generated set.
pub fn run_stats(root: &Path) -> Result<()> {
    let stats = dataset_stats(root)?.to_string();
    note(stats.strip_suffix('\n').unwrap_or(&stats));
    Ok(())
}
