//! `ImageSets/{train,val,test}.txt`: one frame id per line (`000000`), `\n`-terminated.

use crate::io::{atomic_write, read_text};
use crate::{DataError, Result};
use std::path::Path;

/// Parses a split file held in memory. A blank line or a line that is not all ASCII digits is
/// an error (OpenPCDet turns a blank line into the id `''` and crashes later).
pub fn parse_split(text: &str, path: &Path) -> Result<Vec<String>> {
    let body = text.strip_suffix('\n').unwrap_or(text);
    if body.is_empty() {
        return Ok(Vec::new());
    }
    body.split('\n')
        .enumerate()
        .map(|(i, raw)| {
            let id = raw.strip_suffix('\r').unwrap_or(raw).trim();
            if id.is_empty() {
                Err(DataError::parse(
                    path,
                    i + 1,
                    "id",
                    "blank line (expected a frame id such as 000123)",
                ))
            } else if !id.bytes().all(|b| b.is_ascii_digit()) {
                Err(DataError::parse(
                    path,
                    i + 1,
                    "id",
                    format!("`{id}` is not a frame id (expected digits such as 000123)"),
                ))
            } else {
                Ok(id.to_string())
            }
        })
        .collect()
}

/// Reads a split file.
pub fn read_split(path: &Path) -> Result<Vec<String>> {
    parse_split(&read_text(path)?, path)
}

/// Writes a split file atomically, one id per line.
pub fn write_split(path: &Path, ids: &[String]) -> Result<()> {
    let text: String = ids.iter().map(|id| format!("{id}\n")).collect();
    atomic_write(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_ids_and_round_trips() {
        let ids = parse_split("000000\n000003\n007480\n", Path::new("s")).unwrap();
        assert_eq!(ids, ["000000", "000003", "007480"]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("ImageSets/train.txt");
        write_split(&p, &ids).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "000000\n000003\n007480\n");
    }

    #[test]
    fn blank_line_is_rejected_with_its_number() {
        let err = parse_split("000000\n\n000002\n", Path::new("ImageSets/val.txt")).unwrap_err();
        assert!(
            err.to_string().starts_with("ImageSets/val.txt:2: id: blank line"),
            "{err}"
        );
    }

    #[test]
    fn non_id_line_is_rejected() {
        let err = parse_split("000000\nframe_1\n", Path::new("s.txt")).unwrap_err();
        assert!(matches!(err, DataError::Parse { line: 2, .. }), "{err:?}");
        assert!(err.to_string().contains("`frame_1`"));
    }
}
