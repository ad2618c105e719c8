//! A method's settings as files carry them: the `[methods.NAME]` tables of
//! a model, a scenario, a study or a gate case, merged key by key (later
//! layers override earlier ones), parsed once into the method's own
//! settings type ([`parse_settings`], which names the method and the
//! offending key), and described for `aeroid methods` ([`setting_infos`]).

use crate::error::{Error, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// A method's settings: the merged `[methods.NAME]` table, as JSON values.
pub type Settings = serde_json::Map<String, serde_json::Value>;

/// `[methods.NAME]` tables as a file carries them, keyed by method name.
pub type MethodTables = BTreeMap<String, toml::Table>;

/// One key of a method's settings table.
#[derive(Debug, Clone, PartialEq)]
pub struct SettingInfo {
    pub name: &'static str,
    /// The default, as it would be written in a TOML file.
    pub default: String,
    pub meaning: &'static str,
}

/// Parses a settings table into a method's settings type, naming the
/// method and the offending key in the error.
pub fn parse_settings<T: DeserializeOwned>(method: &str, settings: &Settings) -> Result<T> {
    serde_json::from_value(serde_json::Value::Object(settings.clone())).map_err(|error| {
        Error::Settings {
            method: method.to_string(),
            reason: error.to_string(),
        }
    })
}

/// The settings list of [`crate::estimator::MethodInfo`]: each key named in `meanings` with
/// its default from `defaults` (a method's default settings, serialised;
/// "(none)" where the default is no value). The registry's tests check
/// that every described key, at its default, is accepted.
pub fn setting_infos<T: Serialize>(
    defaults: &T,
    meanings: &[(&'static str, &'static str)],
) -> Vec<SettingInfo> {
    let values = serde_json::to_value(defaults).unwrap_or_default();
    meanings
        .iter()
        .map(|&(name, meaning)| SettingInfo {
            name,
            default: values
                .get(name)
                .map_or_else(|| "(none)".to_string(), toml_text),
            meaning,
        })
        .collect()
}

/// A JSON value written the way a TOML file would write it.
fn toml_text(value: &serde_json::Value) -> String {
    toml::Value::try_from(value).map_or_else(|_| "(none)".to_string(), |v| v.to_string())
}

/// Adds a table's keys to `settings`, replacing those it has.
pub(crate) fn overlay(settings: &mut Settings, table: &toml::Table) {
    for (key, value) in table {
        let value = serde_json::to_value(value).unwrap_or(serde_json::Value::Null);
        settings.insert(key.clone(), value);
    }
}

/// Merges `[methods.NAME]` tables key by key: later layers override
/// earlier ones (model file, then scenario, then study or gate case).
pub fn merge_settings(method: &str, layers: &[&MethodTables]) -> Settings {
    let mut merged = Settings::new();
    for table in layers.iter().filter_map(|layer| layer.get(method)) {
        overlay(&mut merged, table);
    }
    merged
}
