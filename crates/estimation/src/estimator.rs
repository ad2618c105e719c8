//! The estimator interface. Every method is one type implementing
//! [`Estimator`] in its own file under `methods/`, registered by one line
//! in [`crate::methods`]; the command line, `run`, `gate`,
//! `study` and the reports find methods only through that registry.
//!
//! A method reads one [`EstimationProblem`] (the record or records, the
//! model structure with its free parameters, start values and bounds, and
//! its own settings, the resolved `[methods.NAME]` table) and returns an
//! [`Estimate`], or refuses with a [`Refusal`] that says, as data, what the
//! record or the model lacks. Settings are plain tables: a method declares
//! each key with its default and meaning ([`MethodInfo::settings`]) and
//! parses the table into its own settings type ([`parse_settings`]).

use crate::estimate::Estimate;
use crate::problem::EstimationProblem;
use aeroid_core::error::{Error, Problems, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

pub use aeroid_core::refusal::{MissingChannel, Refusal, RefusalKind};

/// A method's settings: the merged `[methods.NAME]` table, as JSON values.
pub type Settings = serde_json::Map<String, serde_json::Value>;

/// `[methods.NAME]` tables as a file carries them, keyed by method name.
pub type MethodTables = BTreeMap<String, toml::Table>;

/// What `aeroid methods` shows of an estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodInfo {
    /// What the method is, in a few words.
    pub title: &'static str,
    /// The papers and books it follows (author, title).
    pub paper: &'static str,
    /// The equations it implements, with their numbers in the papers.
    pub equations: &'static str,
    /// The channels and model structures it needs.
    pub needs: &'static str,
    /// Every setting of its `[methods.NAME]` table.
    pub settings: Vec<SettingInfo>,
}

/// One key of a method's settings table.
#[derive(Debug, Clone, PartialEq)]
pub struct SettingInfo {
    pub name: &'static str,
    /// The default, as it would be written in a TOML file.
    pub default: String,
    pub meaning: &'static str,
}

/// An estimation method.
pub trait Estimator: Send + Sync {
    /// The name used on the command line and in files (`ee`, `oem`, …).
    fn name(&self) -> &'static str;

    /// Title, paper, equations, needs and settings.
    fn info(&self) -> MethodInfo;

    /// Checks a settings table: every key known, every value well formed.
    fn check_settings(&self, settings: &Settings) -> Result<()>;

    /// The method whose estimate this one can take as its start (output
    /// error: equation error's). A caller that has that estimate for the
    /// same problem passes it to [`Estimator::estimate`].
    fn starts_from(&self) -> Option<&'static str> {
        None
    }

    /// Whether the method fits a model with parameters tied to others
    /// (`[parameters.NAME] tie`): its model is evaluated through
    /// [`aeroid_sim::aero::AeroModel`], which gives a tied term its value
    /// from its master, and its unknowns are the masters. A model with ties
    /// is refused by a method that does not.
    fn fits_tied_parameters(&self) -> bool {
        false
    }

    /// Whether the method fits a model whose moments are taken about a
    /// point other than the CG (`[aero.moment_reference]`); refused otherwise.
    fn fits_moment_reference(&self) -> bool {
        true
    }

    /// Estimates the problem's parameters, or refuses it
    /// ([`Error::Refused`]) when the record or the model cannot serve.
    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate>;
}

/// A refusal unless the problem has exactly one record, for methods
/// that fit one record at a time.
pub fn one_record(method: &str, problem: &EstimationProblem) -> Result<()> {
    match problem.records.len() {
        1 => Ok(()),
        records => Err(Error::Refused(Refusal::OneRecordOnly {
            method: method.to_string(),
            records,
        })),
    }
}

/// An error naming every key of `settings` among `unsupported` (key,
/// why) that a linear structure `model` does not take, so that a setting
/// is refused, never silently unused; Ok when there is none. `start =
/// "model"` is what a linear fit does, and is accepted.
pub fn refuse_for_linear(
    method: &str,
    settings: &Settings,
    model: &str,
    unsupported: &[(&str, &str)],
) -> Result<()> {
    let refused: Vec<String> = unsupported
        .iter()
        .filter(|(key, _)| {
            settings
                .get(*key)
                .is_some_and(|value| !(*key == "start" && value.as_str() == Some("model")))
        })
        .map(|(key, why)| format!("{key} ({why})"))
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(Error::Other(format!(
        "[methods.{method}]: not for the linear model '{model}': {}",
        refused.join("; ")
    )))
}

/// Parses a settings table into a method's settings type, naming the
/// method and the offending key in the error.
pub fn parse_settings<T: DeserializeOwned>(method: &str, settings: &Settings) -> Result<T> {
    serde_json::from_value(serde_json::Value::Object(settings.clone()))
        .map_err(|error| Error::Other(format!("[methods.{method}]: {error}")))
}

/// The settings list of [`MethodInfo`]: each key named in `meanings` with
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
fn overlay(settings: &mut Settings, table: &toml::Table) {
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

/// Checks a file's `[methods.NAME]` tables: each names a registered method
/// and holds settings that method accepts. Problems are named
/// `methods.NAME`.
pub fn check_method_tables(tables: &MethodTables, problems: &mut Problems) {
    for (name, table) in tables {
        let field = format!("methods.{name}");
        match crate::methods::find(name) {
            Ok(estimator) => {
                let mut settings = Settings::new();
                overlay(&mut settings, table);
                if let Err(error) = estimator.check_settings(&settings) {
                    let message = error.to_string();
                    let prefix = format!("[{field}]: ");
                    problems.push(field, message.trim_start_matches(&prefix).to_string());
                }
            }
            Err(error) => problems.push(field, error.to_string()),
        }
    }
}

/// [`check_method_tables`] for a file read elsewhere (a scenario): an
/// error naming `path` and each table's problem.
pub fn validate_method_tables(tables: &MethodTables, path: &std::path::Path) -> Result<()> {
    let mut problems = Problems::default();
    check_method_tables(tables, &mut problems);
    problems.finish(path, ())
}
