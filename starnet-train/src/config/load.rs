//! Reading an experiment: the `base =` chain, merging, `--set`, key and type checks, renamed
//! keys, number widening.

use super::experiment::ExperimentConfig;
use crate::{Result, TrainError};
use std::path::Path;
use toml::{Table, Value};

/// Keys whose tables are maps with free keys (class names), not structs.
const OPEN_TABLES: [&str; 2] = ["augment.db_paste.max_per_class", "augment.db_paste.min_points"];

fn read_table(path: &Path) -> Result<Table> {
    let text = std::fs::read_to_string(path).map_err(|e| starnet_data::DataError::io(path, e))?;
    text.parse::<Table>().map_err(|e| TrainError::Config {
        file: path.into(),
        key: "(syntax)".into(),
        message: e.to_string().trim().to_string(),
    })
}

/// Reads `path` and its `base` chain, merged (at most 16 levels, so a cycle is an error).
fn read_with_bases(path: &Path, depth: usize) -> Result<Table> {
    if depth > 16 {
        return Err(TrainError::Config {
            file: path.into(),
            key: "base".into(),
            message: "more than 16 nested bases (a cycle?)".into(),
        });
    }
    let mut table = read_table(path)?;
    match table.remove("base") {
        None => Ok(table),
        Some(Value::String(base)) => {
            let base_path = path.parent().unwrap_or(Path::new(".")).join(base);
            let mut merged = read_with_bases(&base_path, depth + 1)?;
            merge(&mut merged, table);
            Ok(merged)
        }
        Some(other) => Err(TrainError::Config {
            file: path.into(),
            key: "base".into(),
            message: format!("expected a file name, found {}", other.type_str()),
        }),
    }
}

/// Recursively merges `top` into `bottom` (tables merge, everything else is replaced).
fn merge(bottom: &mut Table, top: Table) {
    for (k, v) in top {
        match (bottom.get_mut(&k), v) {
            (Some(Value::Table(b)), Value::Table(t)) => merge(b, t),
            (_, v) => {
                bottom.insert(k, v);
            }
        }
    }
}

/// Applies `key.path=value` overrides.
fn apply_sets(table: &mut Table, sets: &[String]) -> Result<()> {
    for s in sets {
        let err = |m: &str| TrainError::Config {
            file: "--set".into(),
            key: s.clone(),
            message: m.into(),
        };
        let (key, raw) = s
            .split_once('=')
            .ok_or_else(|| err("expected KEY=VALUE, e.g. train.epochs=5"))?;
        let value = format!("v = {raw}")
            .parse::<Table>()
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| Value::String(raw.to_string()));
        let parts: Vec<&str> = key.trim().split('.').collect();
        let mut at = &mut *table;
        for p in &parts[..parts.len() - 1] {
            let next = at.entry(p.to_string()).or_insert_with(|| Value::Table(Table::new()));
            at = next
                .as_table_mut()
                .ok_or_else(|| err("a parent of this key is not a table"))?;
        }
        at.insert(parts[parts.len() - 1].to_string(), value);
    }
    Ok(())
}

/// `defaults` with the tables a config may add that are absent by default (an `Option` section
/// is `None` unless the file names it), each holding its defaults, so that their keys are checked
/// and their numbers widened like any other.
fn with_optional_tables(defaults: &Table) -> Table {
    let mut schema = defaults.clone();
    let ground = Table::try_from(starnet_data::geometry::GroundConfig::default()).expect("the defaults serialise");
    if let Some(Value::Table(pipeline)) = schema.get_mut("pipeline") {
        pipeline.insert("ground".into(), Value::Table(ground));
    }
    schema
}

/// Every key of `user` must exist in `defaults` with a compatible type.
fn check_keys(user: &Table, defaults: &Table, prefix: &str, file: &Path) -> Result<()> {
    for (k, v) in user {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        let Some(d) = defaults.get(k) else {
            let known: Vec<&str> = defaults.keys().map(String::as_str).collect();
            return Err(TrainError::Config {
                file: file.into(),
                key,
                message: format!("unknown key (expected one of: {})", known.join(", ")),
            });
        };
        let compatible = matches!((d, v), (Value::Float(_), Value::Integer(_)))
            || std::mem::discriminant(d) == std::mem::discriminant(v);
        if !compatible {
            return Err(TrainError::Config {
                file: file.into(),
                key,
                message: format!("expected {}, found {}", d.type_str(), v.type_str()),
            });
        }
        if let (Value::Table(dt), Value::Table(ut)) = (d, v)
            && !OPEN_TABLES.contains(&key.as_str())
        {
            check_keys(ut, dt, &key, file)?;
        }
    }
    Ok(())
}

/// Integers given where the defaults have floats become floats, so serde accepts `lr = 1`.
fn widen_numbers(user: &mut Table, defaults: &Table) {
    for (k, v) in user.iter_mut() {
        match (defaults.get(k), &mut *v) {
            (Some(Value::Float(_)), Value::Integer(i)) => {
                let f = *i as f64;
                *v = Value::Float(f);
            }
            (Some(Value::Table(d)), Value::Table(u)) => widen_numbers(u, d),
            _ => {}
        }
    }
}

/// Loads an experiment: `path` (with its bases), then `sets`, over the defaults.
pub fn load_config(path: &Path, sets: &[String]) -> Result<ExperimentConfig> {
    resolve(read_with_bases(path, 0)?, sets, path)
}

/// Reads an experiment from TOML text (e.g. the config embedded in an export), then `sets`,
/// over the defaults; errors name `origin`.
pub fn parse_config(text: &str, origin: &Path, sets: &[String]) -> Result<ExperimentConfig> {
    let user = text.parse::<Table>().map_err(|e| TrainError::Config {
        file: origin.into(),
        key: "(syntax)".into(),
        message: e.to_string().trim().to_string(),
    })?;
    resolve(user, sets, origin)
}

/// A key an earlier release spelled otherwise: the table holding it, its old leaf name, and how
/// an old value reads in the new spelling.
pub struct RenamedKey {
    /// The dotted path of the table holding the key, e.g. `stream.slicing`.
    pub table: &'static str,
    /// The key's old name in that table.
    pub old: &'static str,
    /// The key's new name in that table.
    pub new: &'static str,
    /// The new value for an old one; `None` for an old value that was never valid.
    pub translate: fn(&Value) -> Option<Value>,
}

/// Every renamed key. `stream.slicing.gather_previous` (a bool, until issue #51) became
/// `stream.slicing.context`: `true` reads the previous slice (`"previous"`), `false` only the
/// slice's own points (`"own"`).
pub const RENAMED: &[RenamedKey] = &[RenamedKey {
    table: "stream.slicing",
    old: "gather_previous",
    new: "context",
    translate: |v| {
        v.as_bool()
            .map(|b| Value::String(if b { "previous" } else { "own" }.into()))
    },
}];

/// `user` with every old spelling of [`RENAMED`] replaced by the new one. Both spellings at once,
/// or an old value that was never valid, is an error naming the old key.
fn upgrade_renamed(user: &mut Table, file: &Path) -> Result<()> {
    for rename in RENAMED {
        let Some(table) = table_at_mut(user, rename.table) else {
            continue;
        };
        let Some(old) = table.remove(rename.old) else {
            continue;
        };
        let key = format!("{}.{}", rename.table, rename.old);
        let error = |message: String| TrainError::Config {
            file: file.into(),
            key: key.clone(),
            message,
        };
        if table.contains_key(rename.new) {
            return Err(error(format!("renamed to {}; give only the new key", rename.new)));
        }
        let new = (rename.translate)(&old)
            .ok_or_else(|| error(format!("renamed to {}; {old} has no meaning there", rename.new)))?;
        table.insert(rename.new.into(), new);
    }
    Ok(())
}

/// The table at the dotted `path` inside `root`, if every step of it is a table.
fn table_at_mut<'a>(root: &'a mut Table, path: &str) -> Option<&'a mut Table> {
    path.split('.')
        .try_fold(root, |at, part| at.get_mut(part)?.as_table_mut())
}

/// `user` with `sets` applied, key-checked and merged over the defaults, validated.
fn resolve(mut user: Table, sets: &[String], path: &Path) -> Result<ExperimentConfig> {
    apply_sets(&mut user, sets)?;
    upgrade_renamed(&mut user, path)?;
    let mut defaults = Table::try_from(ExperimentConfig::default()).expect("the defaults serialise");
    let schema = with_optional_tables(&defaults);
    check_keys(&user, &schema, "", path)?;
    widen_numbers(&mut user, &schema);
    let pristine = defaults.clone();
    merge(&mut defaults, user.clone());
    let cfg: ExperimentConfig = Value::Table(defaults)
        .try_into()
        .map_err(|e: toml::de::Error| TrainError::Config {
            file: path.into(),
            key: failing_key(&user, &pristine, "").unwrap_or_else(|| "(value)".into()),
            message: e.message().to_string(),
        })?;
    cfg.validate(path)?;
    Ok(cfg)
}

/// The first leaf key of `user` that alone, over `defaults`, fails to deserialise (a value of
/// the right TOML type that the setting does not accept, such as an unknown enum variant): serde's
/// error does not say where it is.
fn failing_key(user: &Table, defaults: &Table, prefix: &str) -> Option<String> {
    user.iter().find_map(|(k, v)| {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(t) if !OPEN_TABLES.contains(&key.as_str()) => failing_key(t, defaults, &key),
            _ => {
                let mut one = Table::new();
                let mut at = &mut one;
                let parts: Vec<&str> = key.split('.').collect();
                for p in &parts[..parts.len() - 1] {
                    at = at
                        .entry(p.to_string())
                        .or_insert_with(|| Value::Table(Table::new()))
                        .as_table_mut()
                        .expect("just inserted a table");
                }
                at.insert(parts[parts.len() - 1].to_string(), v.clone());
                let mut merged = defaults.clone();
                merge(&mut merged, one);
                Value::Table(merged)
                    .try_into::<ExperimentConfig>()
                    .is_err()
                    .then_some(key)
            }
        }
    })
}

/// The resolved config as TOML (written beside each run).
pub fn to_toml(cfg: &ExperimentConfig) -> String {
    toml::to_string(cfg).expect("configs serialise")
}
