//! Scoring an estimate against the truth of the run that made the record:
//! per parameter the error in absolute, relative and σ units, and whether the
//! truth lies inside the 95 % interval (±1.96σ). The truth kind (exact, or
//! the truth model's local derivative at the trim point) is carried into
//! every row so that a report says what it was scored against.

use crate::error::Result;
use aeroid_estimation::estimate::Estimate;
use aeroid_sim::aero::ModelKind;
use aeroid_sim::truth::{RunTruth, TruthKind};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The half-width of a two-sided 95 % Gaussian interval, in σ.
pub(crate) const Z_95: f64 = 1.959_963_984_540_054;

/// One estimated parameter scored against the truth (a row of [`score`]):
/// its error in absolute, relative and σ units and whether the 95 % interval holds the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterScore {
    pub name: String,
    pub estimate: f64,
    pub standard_error: f64,
    /// None for unknowns with no truth (initial states, output biases) or an imported record.
    pub truth: Option<f64>,
    pub truth_kind: Option<TruthKind>,
    pub error: Option<f64>,
    pub relative_error: Option<f64>,
    /// Error in units of the estimate's standard error.
    pub error_sigma: Option<f64>,
    pub inside_95: Option<bool>,
}

/// Scores every parameter of `estimate`, a fit of a postulated model of
/// `kind`; `truth` is None for real flight data. Exact truth when the
/// postulate's kind equals the truth model's, else the local derivative.
pub fn score(
    estimate: &Estimate,
    truth: Option<&RunTruth>,
    kind: ModelKind,
) -> Vec<ParameterScore> {
    estimate
        .parameters
        .iter()
        .map(|p| {
            let found = truth.and_then(|t| t.value_for(&p.name, kind));
            let truth_value = found.map(|(v, _)| v);
            let error = truth_value.map(|t| p.value - t);
            ParameterScore {
                name: p.name.clone(),
                estimate: p.value,
                standard_error: p.standard_error,
                truth: truth_value,
                truth_kind: found.map(|(_, k)| k),
                error,
                relative_error: error.zip(truth_value).map(|(e, t)| e / t.abs()),
                error_sigma: error.map(|e| e / p.standard_error),
                // An infinite or non-finite σ says nothing: never inside.
                inside_95: error
                    .map(|e| p.standard_error.is_finite() && e.abs() <= Z_95 * p.standard_error),
            }
        })
        .collect()
}

fn optional(value: Option<f64>) -> String {
    value.map_or(String::new(), |v| v.to_string())
}

/// Writes the scored table as CSV (a spreadsheet opens it directly).
pub fn write_csv(scores: &[ParameterScore], path: &Path) -> Result<()> {
    let io_error = |e: csv::Error| aeroid_core::error::write_error(path, e);
    let mut writer = csv::Writer::from_path(path).map_err(io_error)?;
    writer
        .write_record([
            "parameter",
            "estimate",
            "standard_error",
            "truth",
            "truth_kind",
            "error",
            "relative_error",
            "error_sigma",
            "inside_95",
        ])
        .map_err(io_error)?;
    for s in scores {
        writer
            .write_record([
                s.name.clone(),
                s.estimate.to_string(),
                s.standard_error.to_string(),
                optional(s.truth),
                s.truth_kind.map_or(String::new(), |k| format!("{k:?}")),
                optional(s.error),
                optional(s.relative_error),
                optional(s.error_sigma),
                s.inside_95.map_or(String::new(), |b| b.to_string()),
            ])
            .map_err(io_error)?;
    }
    writer
        .flush()
        .map_err(|e| aeroid_core::error::write_error(path, e).into())
}

/// A fixed-width table for the terminal.
pub fn table(scores: &[ParameterScore]) -> String {
    let mut text = format!(
        "{:<18} {:>13} {:>11} {:>13} {:>11} {:>8} {:>4}\n",
        "parameter", "estimate", "σ (CRB)", "truth", "error", "err/σ", "95%"
    );
    for s in scores {
        let truth = s.truth.map_or("-".into(), |t| format!("{t:.6}"));
        let error = s.error.map_or("-".into(), |e| format!("{e:.3e}"));
        let sigma = s.error_sigma.map_or("-".into(), |e| format!("{e:+.2}"));
        let inside = s.inside_95.map_or("-", |b| if b { "yes" } else { "NO" });
        text += &format!(
            "{:<18} {:>13.6} {:>11.3e} {:>13} {:>11} {:>8} {:>4}\n",
            s.name, s.estimate, s.standard_error, truth, error, sigma, inside
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_estimation::estimate::ParameterEstimate;
    use aeroid_estimation::estimate::Status;

    #[test]
    fn errors_in_sigma_units_and_interval_coverage() {
        let estimate = Estimate {
            method: "oem".into(),
            model: "m".into(),
            record: "r".into(),
            diagnoses: Vec::new(),
            status: Status::Converged,
            parameters: vec![
                ParameterEstimate {
                    name: "Cm_q".into(),
                    value: -12.0,
                    standard_error: 0.1,
                    start: -10.0,
                },
                ParameterEstimate {
                    name: "Cm_alpha".into(),
                    value: -0.5,
                    standard_error: 0.01,
                    start: -0.4,
                },
                ParameterEstimate {
                    name: "bias.nz".into(),
                    value: 0.01,
                    standard_error: 0.001,
                    start: 0.0,
                },
            ],
            covariance: vec![],
            fits: vec![],
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
            iterations: 3,
            cost_history: vec![],
            wall_time: 0.0,
            notes: vec![],
        };
        let truth = RunTruth {
            kind: TruthKind::Exact,
            scenario: "s".into(),
            seed: 1,
            aircraft: "a".into(),
            trim: aeroid_sim::truth::TrimPoint {
                airspeed: 100.0,
                altitude: 1000.0,
                flight_path_angle: 0.0,
                heading: 0.0,
                alpha: 0.05,
                beta: 0.0,
                pitch: 0.05,
                controls: Default::default(),
            },
            model: ModelKind::Linear,
            parameters: [
                ("Cm_q".to_string(), -12.15),
                ("Cm_alpha".to_string(), -0.52),
            ]
            .into(),
            local_derivatives: [("Cm_q".to_string(), -99.0)].into(),
            parameter_changes: vec![],
        };
        let scores = score(&estimate, Some(&truth), ModelKind::Linear);
        let stall_postulate = score(&estimate, Some(&truth), ModelKind::Stall);
        assert_eq!(stall_postulate[0].truth, Some(-99.0));
        assert_eq!(
            stall_postulate[0].truth_kind,
            Some(TruthKind::LocalDerivative)
        );
        assert!(
            (scores[0].error_sigma.unwrap() - 1.5).abs() < 1e-12
                && scores[0].inside_95 == Some(true)
        );
        assert!(
            (scores[1].error_sigma.unwrap() - 2.0).abs() < 1e-12
                && scores[1].inside_95 == Some(false)
        );
        assert!((scores[1].relative_error.unwrap() - 0.02 / 0.52).abs() < 1e-12);
        assert_eq!(scores[2].truth, None);
        assert!(table(&scores).contains("NO"));
    }
}
