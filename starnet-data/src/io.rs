//! File helpers shared by every writer: nothing is ever left half-written.

use crate::{DataError, Result};
use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary file beside `path` that [`atomic_write`] writes before renaming it over
/// `path`: hidden, in the same directory (so the rename is atomic) and unique to this process.
/// Writers that stream into a file of their own (a Rerun recording) use it the same way.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Writes `bytes` to `path` atomically: into a temporary file in the same directory, flushed
/// to disk, then renamed over `path`. A crash leaves either the old file or the new one.
/// Creates the parent directory if needed.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
    remove_dead_temporaries_once(dir);
    let tmp = temp_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(DataError::io(path, e));
    }
    Ok(())
}

/// The directories this process has already swept of dead writers' temporary files.
static SWEPT: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

/// Removes, the first time this process writes into `dir`, the temporary files of writers
/// killed between writing and renaming ([`temp_path`]'s `.NAME.tmpPID` of a process that no
/// longer runs), so that a command run again after a kill leaves what an uninterrupted run
/// does. Another live process's temporary file is left alone. Best effort: a file that cannot
/// be listed or removed stays, hidden, and nothing reads it.
fn remove_dead_temporaries_once(dir: &Path) {
    let mut swept = SWEPT.lock().unwrap_or_else(|e| e.into_inner());
    if !swept.get_or_insert_with(HashSet::new).insert(dir.to_path_buf()) {
        return;
    }
    drop(swept);
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let writer = name.to_string_lossy().strip_prefix('.').and_then(temp_writer);
        if writer.is_some_and(|pid| pid != std::process::id() && !process_runs(pid)) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// The process id in a temporary file's name (`NAME.tmpPID`, the leading dot removed).
fn temp_writer(name: &str) -> Option<u32> {
    name.rsplit_once(".tmp").and_then(|(_, pid)| pid.parse().ok())
}

/// Whether process `pid` runs (Linux: `/proc/PID` exists; elsewhere assumed to run).
fn process_runs(pid: u32) -> bool {
    !cfg!(target_os = "linux") || Path::new("/proc").join(pid.to_string()).exists()
}

/// Reads a whole file, mapping a missing file and other failures to [`DataError::Io`].
pub fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| DataError::io(path, e))
}

/// Reads a whole UTF-8 text file.
pub fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| DataError::io(path, e))
}

/// The whitespace-separated numbers of `fields` (line `line` of `path`, 1-based); a value that
/// is not a finite number is an error naming the file, line, `field` and the value's position.
pub fn parse_finite_numbers(fields: &str, path: &Path, line: usize, field: &str) -> Result<Vec<f64>> {
    fields
        .split_ascii_whitespace()
        .enumerate()
        .map(|(j, v)| {
            v.parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                DataError::parse(
                    path,
                    line,
                    field,
                    format!("value {} `{v}` is not a finite number", j + 1),
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/a.txt");
        atomic_write(&p, b"one").unwrap();
        atomic_write(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap()).unwrap().collect();
        assert_eq!(names.len(), 1, "a temporary file was left behind");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn a_dead_writers_temporary_file_goes_and_a_live_ones_stays() {
        let dir = tempfile::tempdir().unwrap();
        // Pid 0 runs no user process (no /proc/0); pid 1 runs in every Linux system.
        let dead = dir.path().join(".a.txt.tmp0");
        let live = dir.path().join(".b.txt.tmp1");
        let other = dir.path().join(".notes.tmp.txt");
        for p in [&dead, &live, &other] {
            std::fs::write(p, b"half").unwrap();
        }
        atomic_write(&dir.path().join("a.txt"), b"whole").unwrap();
        assert!(!dead.exists(), "a killed writer's temporary file was left");
        assert!(
            live.exists() && other.exists(),
            "a live writer's or another file was removed"
        );
        assert_eq!(temp_writer("000013.txt.tmp12047"), Some(12047));
        assert_eq!(temp_writer("notes.tmp.txt"), None);
    }

    #[test]
    fn read_missing_file_names_it() {
        let err = read(Path::new("/nonexistent/x.bin")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/x.bin"), "{err}");
    }
}
