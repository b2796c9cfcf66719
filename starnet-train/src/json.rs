//! Reading back the JSON files the commands write (`eval.json`, `budget.json`, `stream.json`,
//! `temporal.json`), for replotting and reports.

use crate::{Result, TrainError};
use std::path::Path;

/// Reads a JSON file the commands wrote; errors name the file and line.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| starnet_data::DataError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| TrainError::Log {
        path: path.to_path_buf(),
        line: e.line(),
        message: e.to_string(),
    })
}
