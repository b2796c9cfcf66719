//! Where a root's paste database lives: in the root, as OpenPCDet and mmdetection3d keep
//! theirs, unless the root is read-only (a shared dataset mount) and holds none, in which case
//! in the user's cache, in a folder named for the root.

use super::gtdb::{GtDatabase, database_path};
use crate::kitti::LabelSource;
use crate::{DataError, Result};
use std::path::{Path, PathBuf};

/// Whether new files can be created in a folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Writability {
    /// A file can be created there.
    Writable,
    /// It cannot (read-only mount, permissions, an immutable folder).
    ReadOnly,
}

/// Probes `dir` by creating and removing a uniquely named empty file: permission bits do not
/// tell a read-only mount or an immutable folder, nor what the superuser may do.
pub fn writability(dir: &Path) -> Writability {
    let probe = dir.join(format!(".starnet-probe.{}", std::process::id()));
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe); // what is left if this fails is an empty file
            Writability::Writable
        }
        Err(_) => Writability::ReadOnly,
    }
}

/// The folder for caches: `$STARNET_CACHE_DIR`, else `$XDG_CACHE_HOME/starnet`, else
/// `$HOME/.cache/starnet`; `None` where none of them is set.
pub fn cache_dir() -> Option<PathBuf> {
    let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    set("STARNET_CACHE_DIR")
        .or_else(|| set("XDG_CACHE_HOME").map(|d| d.join("starnet")))
        .or_else(|| set("HOME").map(|d| d.join(".cache/starnet")))
}

/// Where the database of `root`'s `split` from `labels` is read and written: [`database_path`]
/// in the root when a current database is there or the root is writable; otherwise the same
/// file name under [`cache_dir`]`/gt_database/NAME-HASH/`, NAME the root's folder name and
/// HASH a digest of its canonical path (so two roots never share a database).
pub fn database_location(root: &Path, labels: LabelSource, split: &str) -> Result<PathBuf> {
    let in_root = database_path(root, labels, split);
    if GtDatabase::is_current(&in_root) || writability(root) == Writability::Writable {
        return Ok(in_root);
    }
    let cache = cache_dir().ok_or_else(|| DataError::NoCacheDir { root: root.into() })?;
    let canonical = root.canonicalize().map_err(|e| DataError::io(root, e))?;
    let file = in_root.file_name().expect("database_path ends in a file name");
    Ok(cache
        .join("gt_database")
        .join(cached_folder_name(&canonical))
        .join(file))
}

/// `NAME-HASH` for a canonical root path: its last component and the FNV-1a 64-bit digest of
/// its bytes, in hex (stable across runs and builds, unlike `std`'s hasher).
fn cached_folder_name(canonical: &Path) -> String {
    let name = canonical.file_name().map_or("root".into(), |n| n.to_string_lossy());
    let digest = canonical
        .as_os_str()
        .as_encoded_bytes()
        .iter()
        .fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
            (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
        });
    format!("{name}-{digest:016x}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_digest_is_fnv_1a() {
        // FNV-1a 64 of "a" is 0xaf63dc4c8601ec8c (the reference test vector).
        assert_eq!(cached_folder_name(Path::new("a")), "a-af63dc4c8601ec8c");
        assert_ne!(
            cached_folder_name(Path::new("/d/kitti")),
            cached_folder_name(Path::new("/e/kitti"))
        );
    }

    #[test]
    fn a_writable_root_keeps_its_database() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(writability(dir.path()), Writability::Writable);
        let at = database_location(dir.path(), LabelSource::Camera, "train").unwrap();
        assert_eq!(at, dir.path().join("gt_database.bin"));
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "the probe leaves nothing"
        );
        assert_eq!(writability(&dir.path().join("absent")), Writability::ReadOnly);
    }
}
