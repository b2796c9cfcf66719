//! [`RunLock`]: one trainer writes a run folder at a time. An advisory lock on `train.lock`,
//! held from the start of `train` to its end; the operating system releases it when the
//! process ends, however it ends, so a run killed with `kill -9` still resumes.

use crate::{Result, TrainError};
use starnet_data::DataError;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::Path;

/// The lock file, in the run folder.
pub const LOCK_FILE: &str = "train.lock";

/// A held lock on a run folder; released when dropped.
#[derive(Debug)]
pub struct RunLock {
    // Holding the open file holds the lock.
    _file: File,
}

impl RunLock {
    /// Takes the lock of run folder `dir` (created if absent), or fails with
    /// [`TrainError::RunInUse`] naming the folder and the holder's process as the lock file
    /// says (the previous holder's, in the instant before a new one rewrites it).
    pub fn acquire(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
        let path = dir.join(LOCK_FILE);
        let io = |e| TrainError::from(DataError::io(&path, e));
        // Not truncated on open: the holder's process id stays readable until the lock is ours.
        let mut file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(&path)
            .map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let holder = std::fs::read_to_string(&path).ok().and_then(|s| s.trim().parse().ok());
                return Err(TrainError::RunInUse {
                    dir: dir.to_path_buf(),
                    holder,
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        file.set_len(0).map_err(io)?;
        writeln!(file, "{}", std::process::id()).map_err(io)?;
        Ok(Self { _file: file })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_naming_the_folder_and_the_holder_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let first = RunLock::acquire(dir.path()).unwrap();
        let err = RunLock::acquire(dir.path()).unwrap_err();
        match &err {
            TrainError::RunInUse { dir: d, holder } => {
                assert_eq!(d, dir.path());
                assert_eq!(*holder, Some(std::process::id()));
            }
            other => panic!("expected RunInUse, got {other}"),
        }
        assert!(err.to_string().contains(&dir.path().display().to_string()), "{err}");
        drop(first);
        RunLock::acquire(dir.path()).unwrap();
    }
}
