//! Why an estimator cannot run on a problem, as data a program can read:
//! a refusal is an outcome, not a failure (a method that needs channels a
//! record lacks says which). A leaf: the error type and every layer that
//! runs estimators name it without depending on the estimators.

use serde::{Deserialize, Serialize};
use std::fmt;

/// Why an estimator cannot run on a problem, as data a program can read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Refusal {
    /// The record lacks channels the method needs.
    MissingChannels {
        method: String,
        channels: Vec<MissingChannel>,
        /// The channels the record has.
        present: Vec<String>,
    },
    /// The method fits only models linear in their parameters.
    NotLinearInParameters {
        method: String,
        model: String,
        /// The model's kind (`stall`, …).
        model_kind: String,
    },
    /// The model leaves the method nothing to estimate.
    NothingToEstimate { method: String, model: String },
    /// Fewer data than unknowns: no estimate can be determined.
    TooFewData {
        method: String,
        data: usize,
        unknowns: usize,
    },
    /// The model cannot be fitted by this method as it is stated (no
    /// output to compare, an output that is fed in from the record).
    UnsuitableModel {
        method: String,
        model: String,
        reason: String,
    },
    /// The method fits only another kind of model structure (the 6-DOF
    /// equations), and was given one of kind `kind` (`linear`).
    StructureKind {
        method: String,
        model: String,
        /// The structure's kind (`linear`).
        structure: String,
        /// What the method fits.
        needs: String,
    },
    /// The method fits one record at a time and was given several.
    OneRecordOnly {
        method: String,
        /// How many records it was given.
        records: usize,
        /// Where the records came from when one record was split at its
        /// gaps (the problem's note).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gaps: Option<String>,
    },
}

/// A needed channel and what it is needed for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissingChannel {
    pub name: String,
    pub purpose: String,
}

/// The kind of a [`Refusal`], as gate files and tests name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RefusalKind {
    MissingChannels,
    NotLinearInParameters,
    NothingToEstimate,
    TooFewData,
    UnsuitableModel,
    StructureKind,
    OneRecordOnly,
}

impl Refusal {
    pub fn kind(&self) -> RefusalKind {
        match self {
            Refusal::MissingChannels { .. } => RefusalKind::MissingChannels,
            Refusal::NotLinearInParameters { .. } => RefusalKind::NotLinearInParameters,
            Refusal::NothingToEstimate { .. } => RefusalKind::NothingToEstimate,
            Refusal::TooFewData { .. } => RefusalKind::TooFewData,
            Refusal::UnsuitableModel { .. } => RefusalKind::UnsuitableModel,
            Refusal::StructureKind { .. } => RefusalKind::StructureKind,
            Refusal::OneRecordOnly { .. } => RefusalKind::OneRecordOnly,
        }
    }

    /// The names of the missing channels (empty for other kinds).
    pub fn missing_channels(&self) -> Vec<&str> {
        match self {
            Refusal::MissingChannels { channels, .. } => {
                channels.iter().map(|c| c.name.as_str()).collect()
            }
            _ => Vec::new(),
        }
    }

    /// A refusal for missing channels, or None when nothing is missing.
    pub fn missing(
        method: &str,
        missing: Vec<MissingChannel>,
        present: Vec<String>,
    ) -> Option<Self> {
        (!missing.is_empty()).then(|| Refusal::MissingChannels {
            method: method.to_string(),
            channels: missing,
            present,
        })
    }
}

impl fmt::Display for RefusalKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = serde_json::to_value(self)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        f.write_str(&text)
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::MissingChannels {
                method,
                channels,
                present,
            } => write!(
                f,
                "{method} needs channel{} {} that the record does not have; channels present: {}",
                if channels.len() > 1 { "s" } else { "" },
                channels
                    .iter()
                    .map(|c| format!("'{}' (for {})", c.name, c.purpose))
                    .collect::<Vec<_>>()
                    .join(", "),
                present.join(", ")
            ),
            Refusal::NotLinearInParameters {
                method,
                model,
                model_kind,
            } => write!(
                f,
                "{method} fits models that are linear in their parameters; {model} is a {model_kind} model (χ is not measured): use output error"
            ),
            Refusal::NothingToEstimate { method, model } => {
                write!(
                    f,
                    "{method}: the model '{model}' has no free parameter to estimate"
                )
            }
            Refusal::TooFewData {
                method,
                data,
                unknowns,
            } => write!(
                f,
                "{method}: {data} data for {unknowns} unknowns; at least as many data as unknowns are needed"
            ),
            Refusal::UnsuitableModel {
                method,
                model,
                reason,
            } => write!(f, "{method} cannot fit the model '{model}': {reason}"),
            Refusal::StructureKind {
                method,
                model,
                structure,
                needs,
            } => write!(
                f,
                "{method} fits {needs}; '{model}' is a {structure} model structure: fit it with a method that serves linear structures (ee, oem, fem, ekf, ukf, fdee, fdoe)"
            ),
            Refusal::OneRecordOnly {
                method,
                records,
                gaps,
            } => {
                write!(
                    f,
                    "{method} fits one record at a time, and was given {records}: \
                     run it on each record, or fit them jointly with output error (oem)"
                )?;
                match gaps {
                    Some(gaps) => write!(f, " ({gaps})"),
                    None => Ok(()),
                }
            }
        }
    }
}
