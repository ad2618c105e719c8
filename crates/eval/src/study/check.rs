//! Checking a study file field by field: every problem recorded under its
//! field (`sweep.noise_scale[1]`, `methods[0]`, …), and each sweep axis'
//! values turned into the grid's (an empty axis is its one default value).

use super::file::{StudyFile, StudyMethods};
use aeroid_core::error::FieldErrors;
use aeroid_core::limits;
use aeroid_core::units::Quantity;
use aeroid_estimation::estimator::MethodTables;
use aeroid_estimation::registry::Registry;
use aeroid_record::recorder::{Profile, parse_rate};
use std::collections::BTreeMap;
use std::path::Path;

/// The missing-channels axis: `[[]]` (every channel kept) when empty; each
/// entry's channels must be recorded by every profile of the study.
pub(super) fn missing_axis(
    spec: &[Vec<String>],
    profiles: &[Profile],
    problems: &mut FieldErrors,
) -> Vec<Vec<String>> {
    if spec.is_empty() {
        return vec![Vec::new()];
    }
    for (i, missing) in spec.iter().enumerate() {
        for profile in profiles {
            if let Err(message) = profile.without(missing) {
                problems.push(format!("sweep.missing[{i}]"), message.to_string());
            }
        }
    }
    spec.to_vec()
}

/// The per-channel rate axis: `[[]]` when empty; each entry a table of
/// channel → frequency, every channel recorded by every profile.
pub(super) fn channel_rate_axis(
    spec: &[BTreeMap<String, Quantity>],
    profiles: &[Profile],
    problems: &mut FieldErrors,
) -> Vec<Vec<(String, f64)>> {
    if spec.is_empty() {
        return vec![Vec::new()];
    }
    spec.iter()
        .enumerate()
        .map(|(i, table)| {
            let rates: Vec<(String, f64)> = table
                .iter()
                .filter_map(|(channel, quantity)| {
                    let field = format!("sweep.channel_rate[{i}].{channel}");
                    match parse_rate(quantity) {
                        Ok(rate) if rate > aeroid_core::limits::MAX_RATE => {
                            problems.push(field, aeroid_record::recorder::rate_limit_message(rate))
                        }
                        Ok(rate) if rate > 0.0 && rate.is_finite() => {
                            return Some((channel.clone(), rate));
                        }
                        Ok(rate) => problems.push(field, format!("must be positive, is {rate}")),
                        Err(message) => problems.push(field, message),
                    }
                    None
                })
                .collect();
            for profile in profiles {
                if let Err(message) = profile.with_channel_rates(&rates) {
                    problems.push(format!("sweep.channel_rate[{i}]"), message.to_string());
                }
            }
            rates
        })
        .collect()
}

/// The settings axis: `[{}]` when empty; each variant's tables checked as
/// the study's `[methods.NAME]` tables are, problems named
/// `sweep.settings[i].methods.NAME`.
pub(super) fn settings_axis(
    spec: &[MethodTables],
    registry: &Registry,
    problems: &mut FieldErrors,
) -> Vec<MethodTables> {
    if spec.is_empty() {
        return vec![MethodTables::new()];
    }
    for (i, variant) in spec.iter().enumerate() {
        let mut found = FieldErrors::default();
        registry.check_tables(variant, &mut found);
        for problem in found.0 {
            problems.push(
                format!("sweep.settings[{i}].{}", problem.field),
                problem.message,
            );
        }
    }
    spec.to_vec()
}

/// The study's recorder profiles: its `profile`, or every one of `[sweep]
/// profile` — one of the two, each failure recorded under its field.
pub(super) fn study_profiles(
    file: &StudyFile,
    base: &Path,
    problems: &mut FieldErrors,
) -> Option<Vec<Profile>> {
    let load = |reference: &str| Profile::load(reference, Some(base));
    match (&file.profile, file.sweep.profile.is_empty()) {
        (Some(reference), true) => load(reference)
            .map_err(|error| problems.push("profile", error.to_string()))
            .ok()
            .map(|profile| vec![profile]),
        (None, false) => {
            let profiles = load_each("sweep.profile", &file.sweep.profile, problems, load);
            (profiles.len() == file.sweep.profile.len()).then_some(profiles)
        }
        (Some(_), false) => {
            problems.push(
                "sweep.profile",
                "the study names a `profile` too: give one profile, or list several here, not both",
            );
            None
        }
        (None, true) => {
            problems.push(
                "profile",
                "missing: name a recorder profile, or list several under [sweep] profile",
            );
            None
        }
    }
}

/// Loads every reference of a list field, recording each failure under `field[i]`.
pub(super) fn load_each<T, E: std::fmt::Display>(
    field: &str,
    references: &[String],
    problems: &mut FieldErrors,
    load: impl Fn(&str) -> std::result::Result<T, E>,
) -> Vec<T> {
    if references.is_empty() {
        problems.push(field, "must name at least one");
    }
    references
        .iter()
        .enumerate()
        .filter_map(|(i, reference)| {
            load(reference)
                .map_err(|error| problems.push(format!("{field}[{i}]"), error.to_string()))
                .ok()
        })
        .collect()
}

pub(super) fn check_methods(
    methods: &StudyMethods,
    registry: &Registry,
    problems: &mut FieldErrors,
) {
    let names = methods.names(registry);
    if names.is_empty() {
        problems.push("methods", "must name at least one");
    }
    if let StudyMethods::Names(names) = methods {
        for (i, method) in names.iter().enumerate() {
            if let Err(error) = registry.find(method) {
                problems.push(format!("methods[{i}]"), error.to_string());
            }
        }
    }
}

/// What is wrong with a number of runs per sweep point, if it is not
/// within 1..=[`limits::MAX_RUNS`].
pub(super) fn runs_problem(runs: usize) -> Option<String> {
    if runs == 0 {
        Some("must be at least 1".into())
    } else if runs > limits::MAX_RUNS {
        Some(format!(
            "{runs} is above the most runs per sweep point, {} (statistics of a thousand runs are within a few percent; a million runs of a one-second fit take eleven days of one core)",
            limits::MAX_RUNS
        ))
    } else {
        None
    }
}

/// The sample-rate axis in Hz; `[None]` (the profile's rates) when empty.
pub(super) fn sample_rates(spec: &[Quantity], problems: &mut FieldErrors) -> Vec<Option<f64>> {
    if spec.is_empty() {
        return vec![None];
    }
    spec.iter()
        .enumerate()
        .map(|(i, q)| match parse_rate(q) {
            Ok(rate) if rate > aeroid_core::limits::MAX_RATE => {
                problems.push(
                    format!("sweep.sample_rate[{i}]"),
                    aeroid_record::recorder::rate_limit_message(rate),
                );
                None
            }
            Ok(rate) if rate > 0.0 && rate.is_finite() => Some(rate),
            Ok(rate) => {
                problems.push(
                    format!("sweep.sample_rate[{i}]"),
                    format!("must be positive, is {rate}"),
                );
                None
            }
            Err(message) => {
                problems.push(format!("sweep.sample_rate[{i}]"), message);
                None
            }
        })
        .collect()
}

/// A scale axis `sweep.NAME`; `[1]` when empty. Each value finite and
/// ≥ 0 (> 0 when `positive`).
pub(super) fn scale_axis(
    name: &str,
    spec: &[f64],
    positive: bool,
    problems: &mut FieldErrors,
) -> Vec<f64> {
    if spec.is_empty() {
        return vec![1.0];
    }
    for (i, &scale) in spec.iter().enumerate() {
        let valid = scale.is_finite() && if positive { scale > 0.0 } else { scale >= 0.0 };
        if !valid {
            problems.push(
                format!("sweep.{name}[{i}]"),
                format!(
                    "must be a finite number {} 0, is {scale}",
                    if positive { ">" } else { "≥" }
                ),
            );
        }
    }
    spec.to_vec()
}

/// The turbulence axis; `[None]` (the scenarios' own wind) when empty.
pub(super) fn turbulence_axis(spec: &[String], problems: &mut FieldErrors) -> Vec<Option<String>> {
    if spec.is_empty() {
        return vec![None];
    }
    for (i, name) in spec.iter().enumerate() {
        if !TURBULENCE.contains(&name.as_str()) {
            problems.push(
                format!("sweep.turbulence[{i}]"),
                format!(
                    "unknown intensity '{name}'; known: {}",
                    TURBULENCE.join(", ")
                ),
            );
        }
    }
    spec.iter().cloned().map(Some).collect()
}

/// The turbulence axis' values.
pub(super) const TURBULENCE: [&str; 4] = ["none", "light", "moderate", "severe"];
