//! The JSON files the commands write (`eval.json`, `budget.json`, `stream.json`,
//! `temporal.json`, …): written pretty and atomically, read back for replotting and reports.

use crate::{Result, TrainError};
use serde::Serialize;
use starnet_data::io::atomic_write;
use std::path::Path;

/// Writes `value` as pretty JSON to `path` (a temporary file, then renamed).
pub fn write_json<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_string_pretty(value).expect("reports serialise");
    Ok(atomic_write(path, json.as_bytes())?)
}

/// Reads a JSON file the commands wrote; errors name the file and line.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| starnet_data::DataError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| TrainError::Log {
        path: path.to_path_buf(),
        line: e.line(),
        message: e.to_string(),
    })
}
