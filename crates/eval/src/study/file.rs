//! A study file as written (`studies/*.toml`): its names, methods, runs,
//! seed and the `[sweep]` axes' values before they are checked.

use aeroid_core::units::Quantity;
use aeroid_estimation::estimator::MethodTables;
use aeroid_estimation::registry::Registry;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A study file (`studies/*.toml`) as written, before its names are resolved
/// and its axes checked ([`super::Study::from_file`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub scenarios: Vec<String>,
    /// The recorder profile; absent when `[sweep] profile` lists several.
    #[serde(default)]
    pub profile: Option<String>,
    pub models: Vec<String>,
    pub methods: StudyMethods,
    pub runs: usize,
    pub seed: u64,
    #[serde(default)]
    pub sweep: SweepSpec,
    /// The derive step on the records of the named profiles (all when none
    /// is named) before the estimators: for recorders that lack channels
    /// the estimators need (the QAR).
    #[serde(default)]
    pub derive: Option<aeroid_record::prep::derive::DeriveTable>,
}

/// A study's methods: a list of names (`methods = ["ee", "oem"]`), or one
/// settings table per method (`[methods.oem]`), run in registry order.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum StudyMethods {
    Names(Vec<String>),
    Tables(MethodTables),
}

impl<'de> Deserialize<'de> for StudyMethods {
    fn deserialize<D: serde::Deserializer<'de>>(
        deserializer: D,
    ) -> std::result::Result<Self, D::Error> {
        let expected = "a list of method names (methods = [\"ee\", \"oem\"]) or one [methods.NAME] settings table per method";
        match toml::Value::deserialize(deserializer)? {
            toml::Value::Array(names) => names
                .into_iter()
                .map(|name| match name {
                    toml::Value::String(name) => Ok(name),
                    other => Err(serde::de::Error::custom(format!(
                        "{other} is not a method name; expected {expected}"
                    ))),
                })
                .collect::<std::result::Result<_, _>>()
                .map(StudyMethods::Names),
            toml::Value::Table(tables) => tables
                .into_iter()
                .map(|(name, table)| match table {
                    toml::Value::Table(table) => Ok((name, table)),
                    other => Err(serde::de::Error::custom(format!(
                        "methods.{name} = {other}: expected {expected}"
                    ))),
                })
                .collect::<std::result::Result<_, _>>()
                .map(StudyMethods::Tables),
            other => Err(serde::de::Error::custom(format!(
                "{other}: expected {expected}"
            ))),
        }
    }
}

impl StudyMethods {
    /// The method names, in the order they run (for tables, the
    /// registry's order, then the names it does not know).
    pub fn names(&self, registry: &Registry) -> Vec<String> {
        match self {
            StudyMethods::Names(names) => names.clone(),
            StudyMethods::Tables(tables) => registry
                .names()
                .into_iter()
                .filter(|name| tables.contains_key(name))
                .chain(
                    tables
                        .keys()
                        .filter(|name| registry.find(name).is_err())
                        .cloned(),
                )
                .collect(),
        }
    }

    /// The settings tables (none for a list).
    pub fn tables(&self) -> MethodTables {
        match self {
            StudyMethods::Names(_) => MethodTables::new(),
            StudyMethods::Tables(tables) => tables.clone(),
        }
    }
}

/// The sweep axes; an empty axis leaves the profile as it is.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Recorder profiles (bundled names or paths), in place of the study's `profile`.
    #[serde(default)]
    pub profile: Vec<String>,
    /// Dryden turbulence: `none`, `light`, `moderate`, `severe`.
    #[serde(default)]
    pub turbulence: Vec<String>,
    /// Every input's deviation from trim times this.
    #[serde(default)]
    pub input_scale: Vec<f64>,
    #[serde(default)]
    pub sample_rate: Vec<Quantity>,
    #[serde(default)]
    pub noise_scale: Vec<f64>,
    /// Every quantized channel's resolution (LSB) times this.
    #[serde(default)]
    pub resolution_scale: Vec<f64>,
    /// Channels left out of the record: each entry a list of channel names.
    #[serde(default)]
    pub missing: Vec<Vec<String>>,
    /// Per-channel sample rates: each entry a table channel → frequency.
    #[serde(default)]
    pub channel_rate: Vec<BTreeMap<String, Quantity>>,
    /// Method settings: each entry `{ NAME = { key = value } }`, over the
    /// study's `[methods.NAME]` tables.
    #[serde(default)]
    pub settings: Vec<MethodTables>,
}
