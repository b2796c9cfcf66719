//! File helpers shared by every writer: nothing is ever left half-written.

use crate::{DataError, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

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
    fn read_missing_file_names_it() {
        let err = read(Path::new("/nonexistent/x.bin")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/x.bin"), "{err}");
    }
}
