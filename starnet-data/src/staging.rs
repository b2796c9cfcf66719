//! [`Staging`]: a folder written under a temporary name and renamed into place only when it is
//! complete, with one writer at a time. Every command that writes a dataset (the simulator,
//! `convert`) goes through it, so a kill at any moment leaves either no root or a complete one,
//! and the next run continues the work.
//!
//! ```text
//! PARENT/NAME               the root: absent until complete
//! PARENT/.NAME.partial/     the root being written (files written atomically, one by one)
//! PARENT/.NAME.partial/.job.json   what is being written there (a later run with another job starts over)
//! PARENT/.NAME.lock         the writers' lock (an advisory lock the OS drops with its holder)
//! ```

use crate::events::note;
use crate::io::atomic_write;
use crate::{DataError, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The file in the partial folder that names its job.
const JOB_FILE: &str = ".job.json";

/// What a staged writer did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It wrote the root.
    Written,
    /// The root already held something; nothing was written.
    AlreadyPresent,
}

/// What [`Staging::claim`] found.
#[derive(Debug)]
pub enum Claim {
    /// The root exists and holds something: nothing to write (or a refusal, as the caller sees it).
    Exists,
    /// The root is absent (or an empty folder): write into [`Staging::path`], then
    /// [`Staging::finish`].
    Write(Staging),
}

/// The partial folder of a root, held by this process.
#[derive(Debug)]
pub struct Staging {
    root: PathBuf,
    partial: PathBuf,
    lock_path: PathBuf,
    // Holding the open file holds the lock.
    lock: File,
}

impl Staging {
    /// Takes the lock of `root` (waiting, with a note naming the holder, while another process
    /// writes it), then returns [`Claim::Exists`] when the root holds something, or the
    /// partial folder to write: the one an interrupted run of the same `job` left (its files
    /// kept, the temporary files of its unfinished writes removed), or a new, empty one.
    pub fn claim(root: &Path, job: &serde_json::Value) -> Result<Claim> {
        let name = folder_name(root)?;
        if let Some(parent) = root.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|e| DataError::io(parent, e))?;
        }
        let lock_path = root.with_file_name(format!(".{name}.lock"));
        let lock = lock(&lock_path, root)?;
        if occupied(root)? {
            release(&lock_path, lock);
            return Ok(Claim::Exists);
        }
        let partial = root.with_file_name(format!(".{name}.partial"));
        let text = serde_json::to_string_pretty(job).expect("JSON values serialise") + "\n";
        let same_job = std::fs::read_to_string(partial.join(JOB_FILE)).is_ok_and(|t| t == text);
        if same_job {
            note(format!(
                "continuing the interrupted writing of {} ({})",
                root.display(),
                partial.display()
            ));
            remove_temporaries(&partial)?;
        } else {
            remove_tree(&partial)?;
            atomic_write(&partial.join(JOB_FILE), text.as_bytes())?;
        }
        Ok(Claim::Write(Self {
            root: root.to_path_buf(),
            partial,
            lock_path,
            lock,
        }))
    }

    /// The folder to write into.
    pub fn path(&self) -> &Path {
        &self.partial
    }

    /// Renames the partial folder to the root (an empty root folder is replaced) and releases
    /// the lock.
    pub fn finish(self) -> Result<()> {
        let job = self.partial.join(JOB_FILE);
        std::fs::remove_file(&job).map_err(|e| DataError::io(&job, e))?;
        std::fs::rename(&self.partial, &self.root).map_err(|e| DataError::io(&self.root, e))?;
        release(&self.lock_path, self.lock);
        Ok(())
    }
}

/// The last component of `root`, the folder's name.
fn folder_name(root: &Path) -> Result<String> {
    let name = root.file_name().ok_or_else(|| {
        DataError::io(
            root,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "a dataset root must end in a folder name",
            ),
        )
    })?;
    Ok(name.to_string_lossy().into_owned())
}

/// Takes the advisory lock on `path`, waiting for its holder (named in a note) if there is one.
fn lock(path: &Path, root: &Path) -> Result<File> {
    let io = |e| DataError::io(path, e);
    let mut file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .read(true)
        .write(true)
        .open(path)
        .map_err(io)?;
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            let holder = std::fs::read_to_string(path).unwrap_or_default();
            note(format!(
                "waiting for process {} to finish writing {} (lock {})",
                holder.trim(),
                root.display(),
                path.display()
            ));
            file.lock().map_err(io)?;
        }
        Err(TryLockError::Error(e)) => return Err(io(e)),
    }
    file.set_len(0).map_err(io)?;
    writeln!(file, "{}", std::process::id()).map_err(io)?;
    Ok(file)
}

/// Removes the lock file, then drops the lock. Only once the root is complete: a writer still
/// waiting on the removed file then finds the root there, and a new one locks a new file.
fn release(path: &Path, lock: File) {
    // A lock file left behind (the removal failed) only costs a later writer nothing.
    let _ = std::fs::remove_file(path);
    drop(lock);
}

/// Whether `root` exists as anything but an empty folder.
fn occupied(root: &Path) -> Result<bool> {
    match std::fs::read_dir(root) {
        Ok(mut entries) => Ok(entries.next().is_some()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(_) => Ok(root.exists()),
    }
}

fn remove_tree(dir: &Path) -> Result<()> {
    match std::fs::remove_dir_all(dir) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(DataError::io(dir, e)),
        _ => Ok(()),
    }
}

/// Removes, under `dir`, the temporary files of [`atomic_write`]s a kill interrupted.
fn remove_temporaries(dir: &Path) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))?;
    for entry in entries {
        let path = entry.map_err(|e| DataError::io(dir, e))?.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if path.is_dir() {
            remove_temporaries(&path)?;
        } else if name.starts_with('.') && name.contains(".tmp") {
            std::fs::remove_file(&path).map_err(|e| DataError::io(&path, e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names of the entries of `dir`, in the order the file system lists them.
    fn names(dir: &Path) -> Vec<std::ffi::OsString> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect()
    }

    fn job(n: u64) -> serde_json::Value {
        serde_json::json!({ "frames": n })
    }

    fn write_into(root: &Path, n: u64) -> Staging {
        match Staging::claim(root, &job(n)).unwrap() {
            Claim::Write(s) => s,
            Claim::Exists => panic!("{} should be absent", root.display()),
        }
    }

    #[test]
    fn the_root_appears_only_when_finished() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        let s = write_into(&root, 3);
        atomic_write(&s.path().join("a.txt"), b"a").unwrap();
        assert!(!root.exists());
        s.finish().unwrap();
        assert_eq!(std::fs::read(root.join("a.txt")).unwrap(), b"a");
        assert!(!root.join(JOB_FILE).exists());
        let left = names(dir.path());
        assert_eq!(
            left,
            vec![std::ffi::OsString::from("sim")],
            "the partial folder or the lock file stayed"
        );
        assert!(matches!(Staging::claim(&root, &job(3)).unwrap(), Claim::Exists));
    }

    #[test]
    fn an_interrupted_job_continues_and_another_job_starts_over() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        let s = write_into(&root, 3);
        atomic_write(&s.path().join("done.txt"), b"kept").unwrap();
        // What a kill in the middle of an atomic write leaves.
        std::fs::write(s.path().join(".next.txt.tmp123"), b"half").unwrap();
        drop(s);
        let again = write_into(&root, 3);
        let kept = names(again.path());
        assert_eq!(kept.len(), 2, "{kept:?}");
        assert_eq!(std::fs::read(again.path().join("done.txt")).unwrap(), b"kept");
        drop(again);
        let other = write_into(&root, 4);
        assert!(!other.path().join("done.txt").exists());
    }

    #[test]
    fn an_empty_root_folder_is_written_and_a_full_one_is_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        std::fs::create_dir(&root).unwrap();
        write_into(&root, 1).finish().unwrap();
        assert!(root.is_dir());
        let full = dir.path().join("full");
        std::fs::create_dir(&full).unwrap();
        std::fs::write(full.join("x"), b"x").unwrap();
        assert!(matches!(Staging::claim(&full, &job(1)).unwrap(), Claim::Exists));
    }

    #[test]
    fn a_second_writer_waits_for_the_first() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("sim");
        let first = write_into(&root, 2);
        let (tx, rx) = std::sync::mpsc::channel();
        let waiter = {
            let root = root.clone();
            std::thread::spawn(move || {
                let claim = Staging::claim(&root, &job(2)).unwrap();
                tx.send(matches!(claim, Claim::Exists)).unwrap();
            })
        };
        std::thread::sleep(std::time::Duration::from_millis(200));
        assert!(rx.try_recv().is_err(), "the second writer did not wait");
        atomic_write(&first.path().join("a.txt"), b"a").unwrap();
        first.finish().unwrap();
        assert!(rx.recv().unwrap(), "the second writer should find the root complete");
        waiter.join().unwrap();
    }
}
