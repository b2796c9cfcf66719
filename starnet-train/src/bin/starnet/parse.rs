//! Parsers of the argument values several subcommands take.

use starnet_data::kitti::{LabelSource, ObjectClass};
use starnet_data::sampling::Sampler;

/// Parses `SAMPLER:COUNT`.
pub fn parse_centers(s: &str) -> Result<(Sampler, usize), String> {
    let (sampler, n) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}`: expected SAMPLER:COUNT, e.g. fps:256"))?;
    let n: usize = n.parse().map_err(|_| format!("`{n}` is not a count"))?;
    Ok((sampler.parse()?, n))
}

/// Parses a KITTI class name (`Car`, `Pedestrian`, …).
pub fn parse_class(s: &str) -> Result<ObjectClass, String> {
    ObjectClass::from_name(s)
        .ok_or_else(|| format!("unknown class `{s}` (KITTI's names: Car, Pedestrian, Cyclist, ...)"))
}

/// Parses which labels to read: `label_2` (camera view) or `label_360` (the simulator's all around).
pub fn parse_labels(s: &str) -> Result<LabelSource, String> {
    serde_json::from_value(serde_json::Value::String(s.into()))
        .map_err(|_| format!("unknown labels `{s}` (expected `label_2` or `label_360`)"))
}
