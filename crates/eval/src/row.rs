//! One row of a study's `runs.csv` and `journal.jsonl`: one parameter of
//! one fit of one case, or the fit's failure, with how the fit ended
//! ([`RowStatus`]). Numbers are written so that NaN and infinities survive
//! CSV and JSON (`float_text`).

use crate::axis::AxisValues;
use aeroid_numerics::Status;
use serde::{Deserialize, Serialize};

/// How a row's fit ended: an estimator's [`Status`], or `refused` (the
/// estimator refused the record) or `failed` (the recording or the estimate
/// could not be made at all). Only `converged` rows enter the statistics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RowStatus {
    Converged,
    IterationLimit,
    Diverged,
    NoProgress,
    Unidentified,
    Degenerate,
    Unsettled,
    Refused,
    Failed,
}

impl RowStatus {
    /// The status of a fit and its reason (the unidentified parameters'
    /// names, a divergence's cause), as a row holds them.
    pub fn of(status: &Status) -> (RowStatus, String) {
        match status {
            Status::Converged => (RowStatus::Converged, String::new()),
            Status::IterationLimit => (RowStatus::IterationLimit, String::new()),
            Status::Diverged(reason) => (RowStatus::Diverged, reason.clone()),
            Status::NoProgress => (RowStatus::NoProgress, String::new()),
            Status::Unidentified(names) => (RowStatus::Unidentified, names.join(" ")),
            Status::Degenerate(reason) => (RowStatus::Degenerate, reason.clone()),
            Status::Unsettled(reason) => (RowStatus::Unsettled, reason.clone()),
        }
    }

    /// The name `runs.csv` writes.
    pub fn name(self) -> &'static str {
        match self {
            RowStatus::Converged => "converged",
            RowStatus::IterationLimit => "iteration_limit",
            RowStatus::Diverged => "diverged",
            RowStatus::NoProgress => "no_progress",
            RowStatus::Unidentified => "unidentified",
            RowStatus::Degenerate => "degenerate",
            RowStatus::Unsettled => "unsettled",
            RowStatus::Refused => "refused",
            RowStatus::Failed => "failed",
        }
    }

    /// A fit that ended without converging and was neither refused nor
    /// failed, nor stopped by the iteration limit or a divergence.
    pub fn is_not_converged(self) -> bool {
        matches!(
            self,
            RowStatus::NoProgress
                | RowStatus::Unidentified
                | RowStatus::Degenerate
                | RowStatus::Unsettled
        )
    }
}

impl std::fmt::Display for RowStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One parameter of one fit of one case (or the fit's failure): a plain row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub point: usize,
    pub scenario: String,
    /// The recorder profile (before the sweep's rate, noise and resolution).
    #[serde(default)]
    pub profile: String,
    /// The turbulence intensity; empty for the scenario's own wind.
    pub turbulence: String,
    pub input_scale: f64,
    /// Every channel's rate (Hz); empty for the profile's own.
    pub sample_rate: Option<f64>,
    pub noise_scale: f64,
    pub resolution_scale: f64,
    /// Channels left out of the record, comma-separated.
    #[serde(default)]
    pub missing: String,
    /// Channels at their own rate, `channel:rate Hz` comma-separated.
    #[serde(default)]
    pub channel_rates: String,
    /// The settings variant, `method.key=value` comma-separated.
    #[serde(default)]
    pub settings: String,
    pub run: usize,
    pub turbulence_seed: u64,
    pub recorder_seed: u64,
    pub model: String,
    pub method: String,
    pub status: RowStatus,
    pub reason: String,
    /// The fit's diagnoses (poor_fit, coloured_residuals, process_noise,
    /// …: [`aeroid_estimation::estimate::DiagnosisKind`]), space-separated;
    /// empty when it has none.
    #[serde(default)]
    pub diagnoses: String,
    /// Empty when the fit failed.
    pub parameter: String,
    #[serde(with = "float_text")]
    pub estimate: f64,
    /// Cramér–Rao standard error of the estimate.
    #[serde(with = "float_text")]
    pub standard_error: f64,
    /// None for unknowns without a truth (initial states, output biases).
    #[serde(with = "float_text::option")]
    pub truth: Option<f64>,
    #[serde(with = "float_text::option")]
    pub error: Option<f64>,
    pub inside_95: Option<bool>,
    /// The estimated parameter most correlated with this one, and
    /// |correlation|.
    pub correlated_with: String,
    #[serde(with = "float_text::option")]
    pub max_correlation: Option<f64>,
    /// The fit's correlation-matrix condition number.
    #[serde(with = "float_text::option")]
    pub condition_number: Option<f64>,
}

impl Row {
    /// A fit's row at sweep point `point` with its axis values, run and
    /// seeds: failed, no model, method or parameter yet.
    pub fn template(
        point: usize,
        axes: AxisValues,
        run: usize,
        turbulence_seed: u64,
        recorder_seed: u64,
    ) -> Row {
        let AxisValues {
            scenario,
            profile,
            turbulence,
            input_scale,
            sample_rate,
            noise_scale,
            resolution_scale,
            missing,
            channel_rates,
            settings,
        } = axes;
        Row {
            point,
            scenario,
            profile,
            turbulence,
            input_scale,
            sample_rate,
            noise_scale,
            resolution_scale,
            missing,
            channel_rates,
            settings,
            run,
            turbulence_seed,
            recorder_seed,
            model: String::new(),
            method: String::new(),
            status: RowStatus::Failed,
            reason: String::new(),
            diagnoses: String::new(),
            parameter: String::new(),
            estimate: f64::NAN,
            standard_error: f64::NAN,
            truth: None,
            error: None,
            inside_95: None,
            correlated_with: String::new(),
            max_correlation: None,
            condition_number: None,
        }
    }

    /// The row's sweep-point values.
    pub fn axes(&self) -> AxisValues {
        AxisValues {
            scenario: self.scenario.clone(),
            profile: self.profile.clone(),
            turbulence: self.turbulence.clone(),
            input_scale: self.input_scale,
            sample_rate: self.sample_rate,
            noise_scale: self.noise_scale,
            resolution_scale: self.resolution_scale,
            missing: self.missing.clone(),
            channel_rates: self.channel_rates.clone(),
            settings: self.settings.clone(),
        }
    }
}

/// Serde for numbers that may be non-finite: finite ones as JSON numbers,
/// NaN and ±∞ as the strings "NaN", "inf", "-inf" (CSV writes the same
/// text either way).
pub(crate) mod float_text {
    use serde::{Deserialize, Deserializer, Serializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Text {
        Number(f64),
        Text(String),
    }

    fn to_f64<E: serde::de::Error>(text: Text) -> Result<f64, E> {
        match text {
            Text::Number(value) => Ok(value),
            Text::Text(text) => match text.as_str() {
                "NaN" => Ok(f64::NAN),
                "inf" => Ok(f64::INFINITY),
                "-inf" => Ok(f64::NEG_INFINITY),
                other => Err(E::custom(format!("'{other}' is not a number"))),
            },
        }
    }

    fn write<S: Serializer>(value: f64, serializer: S) -> Result<S::Ok, S::Error> {
        if value.is_finite() {
            serializer.serialize_f64(value)
        } else if value.is_nan() {
            serializer.serialize_str("NaN")
        } else if value > 0.0 {
            serializer.serialize_str("inf")
        } else {
            serializer.serialize_str("-inf")
        }
    }

    pub fn serialize<S: Serializer>(value: &f64, serializer: S) -> Result<S::Ok, S::Error> {
        write(*value, serializer)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
        to_f64(Text::deserialize(deserializer)?)
    }

    /// The same for an optional number (None: null, or empty in CSV).
    pub mod option {
        use super::*;

        pub fn serialize<S: Serializer>(
            value: &Option<f64>,
            serializer: S,
        ) -> Result<S::Ok, S::Error> {
            match value {
                Some(value) => write(*value, serializer),
                None => serializer.serialize_none(),
            }
        }

        pub fn deserialize<'de, D: Deserializer<'de>>(
            deserializer: D,
        ) -> Result<Option<f64>, D::Error> {
            Option::<Text>::deserialize(deserializer)?
                .map(to_f64)
                .transpose()
        }
    }
}
