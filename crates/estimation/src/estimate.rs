//! What an estimator returns: values with Cramér–Rao standard errors, the
//! covariance and correlation matrices, fit metrics per output (residual RMS,
//! R², Theil's inequality coefficient, Verma & Peyada 2020, Eq. 27, the
//! residuals' whiteness), the iteration and
//! cost history, wall time and a status. Serialises to JSON and CSV.
//!
//! The status says how the fit ended, and nothing else
//! ([`Estimate::assess`]): "converged" when its method stopped at an
//! optimum, every estimated parameter has a finite standard error (a
//! singular information matrix leaves the parameters of its null space
//! with infinite ones) and the covariance is finite. Otherwise it says what
//! it is: the iteration limit, no progress short of a minimum, a diverging
//! model, unidentified parameters by name, a degenerate covariance, a
//! recursive estimate still moving.
//!
//! Beside the status, an estimate carries its diagnoses ([`Diagnosis`]):
//! what its residuals, its model or its starts show, each with its
//! measure — an output reproduced worse than by its mean, residuals with a
//! structured part (coloured residuals, [`Estimate::assess_residuals`]),
//! process noise suspected, input timing suspected, an unstable model,
//! innovations inconsistent with their covariance. Process noise is told
//! from coloured sensor noise and from a model error by two signatures of
//! the structured residuals: they move together across outputs (the
//! cross-correlation against Bartlett's bound for independent first-order
//! processes: Box, Jenkins & Reinsel, "Time Series Analysis", Eq. 11.1.7),
//! and they are as large where the predicted motion is quiet as where it
//! is not ([`OutputFit::quiet_share`]). A fit at the optimum of
//! real flight data is converged with its diagnoses: a diagnosis never
//! takes a fit out of a study's statistics or a gate's check, and both
//! count every diagnosis, so that neither a label nor its absence hides a
//! bias.

use crate::diagnosis::process_noise_signature;
pub use crate::diagnosis::{Diagnosis, DiagnosisKind};
use crate::error::{Error, Result};
pub use crate::fit_quality::{CORRELATED_LAG_ONE, OutputFit, STRUCTURED_LIMIT, WHITENESS_LAGS};
use aeroid_numerics::gauss_newton::Solution;
use nalgebra::DVector;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub use aeroid_numerics::Status;

/// One estimated parameter: its value, standard error and the start the
/// estimator began from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterEstimate {
    pub name: String,
    pub value: f64,
    /// Cramér–Rao standard error (corrected for coloured residuals where the method allows).
    pub standard_error: f64,
    pub start: f64,
}

/// What an estimator returns for one model on its records: the parameters
/// with their standard errors and covariance, the fit per output, the
/// status and diagnoses (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub method: String,
    pub model: String,
    pub record: String,
    pub status: Status,
    /// What the residuals, the model or the starts show, beside the status.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub diagnoses: Vec<Diagnosis>,
    pub parameters: Vec<ParameterEstimate>,
    /// Covariance of the estimates (rows/columns in `parameters` order).
    pub covariance: Vec<Vec<f64>>,
    pub fits: Vec<OutputFit>,
    pub iterations: usize,
    pub cost_history: Vec<f64>,
    pub wall_time: f64,
    /// Anything the user should know (a channel held constant, an unidentifiable parameter).
    pub notes: Vec<String>,
    /// The method's own report, as text (stepwise regression: each
    /// coefficient's search); empty when the method has none.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub details: String,
    /// The network a neural method trained: its size, seed, MSE and R².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network: Option<NetworkReport>,
    /// Per parameter, the distribution of its local values over the
    /// record, for methods that estimate a derivative at every sample
    /// (the Delta method); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub distributions: Vec<ParameterDistribution>,
    /// Histories the method estimated along the record (the smoothed
    /// coefficients of estimation before modelling); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub histories: Vec<History>,
}

/// A quantity a method estimated at every point of a grid along the
/// record: its values and, where the method gives them, their standard
/// deviations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct History {
    pub name: String,
    /// Times (s) of the values.
    pub times: Vec<f64>,
    pub values: Vec<f64>,
    /// Standard deviation of each value; empty when the method gives none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sigma: Vec<f64>,
}

/// The spread of a parameter estimated at every sample of a record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterDistribution {
    pub name: String,
    pub samples: usize,
    pub mean: f64,
    pub standard_deviation: f64,
    /// The 5th, 50th and 95th percentiles.
    pub p05: f64,
    pub median: f64,
    pub p95: f64,
    /// The value at the trim point (the record's first sample or the
    /// method's stated reference condition).
    pub at_trim: f64,
}

/// The covariance of uncorrelated estimates with these standard errors:
/// diag(σ²), as the rows of [`Estimate::covariance`].
pub(crate) fn diagonal_covariance(standard_errors: &[f64]) -> Vec<Vec<f64>> {
    let n = standard_errors.len();
    (0..n)
        .map(|i| {
            let mut row = vec![0.0; n];
            row[i] = standard_errors[i].powi(2);
            row
        })
        .collect()
}

impl Estimate {
    /// An estimate of `method` with this status and nothing else: no
    /// parameters, fits, history or notes (the fields the caller fills
    /// follow with `..`).
    pub fn empty(method: &str, model: &str, record: &str, status: Status) -> Estimate {
        Estimate {
            method: method.to_string(),
            model: model.to_string(),
            record: record.to_string(),
            status,
            diagnoses: Vec::new(),
            parameters: Vec::new(),
            covariance: Vec::new(),
            fits: Vec::new(),
            iterations: 0,
            cost_history: Vec::new(),
            wall_time: 0.0,
            notes: Vec::new(),
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        }
    }

    /// The estimate of a Gauss–Newton solution: values with Cramér–Rao
    /// standard errors (√ of the covariance diagonal), the covariance, the
    /// iterations and cost history. Fits, wall time and notes are the caller's.
    pub fn from_solution(
        (method, model, record): (&str, String, String),
        names: &[String],
        start: &DVector<f64>,
        solution: &Solution,
    ) -> Estimate {
        let covariance = solution.covariance();
        Estimate {
            parameters: (0..names.len())
                .map(|j| ParameterEstimate {
                    name: names[j].clone(),
                    value: solution.theta[j],
                    standard_error: covariance[(j, j)].sqrt(),
                    start: start[j],
                })
                .collect(),
            covariance: (0..covariance.nrows())
                .map(|i| covariance.row(i).iter().copied().collect())
                .collect(),
            iterations: solution.history.len(),
            cost_history: solution.history.iter().map(|i| i.cost).collect(),
            ..Estimate::empty(method, &model, &record, solution.status.clone())
        }
    }

    /// The estimate with its status judged honestly and its fits
    /// diagnosed (module documentation): a converged status becomes
    /// unidentified or degenerate where the bounds say so; an output
    /// reproduced worse than by its mean is a [`DiagnosisKind::PoorFit`],
    /// whatever the status.
    pub fn assess(mut self) -> Estimate {
        let poor: Vec<&OutputFit> = self
            .fits
            .iter()
            .filter(|fit| fit.r_squared.is_nan() || fit.r_squared < 0.0 || !fit.rms.is_finite())
            .collect();
        if !poor.is_empty() {
            let diagnosis = Diagnosis {
                kind: DiagnosisKind::PoorFit,
                about: poor.iter().map(|f| f.channel.clone()).collect(),
                measures: poor.iter().map(|f| f.r_squared).collect(),
                advice: "reproduced worse than by the output's mean (R² < 0): the model \
                         structure or the fit's minimum is wrong for these outputs"
                    .into(),
            };
            self.diagnose(diagnosis);
        }
        if self.status != Status::Converged {
            return self;
        }
        let unidentified: Vec<String> = self
            .parameters
            .iter()
            .filter(|p| !p.standard_error.is_finite())
            .map(|p| p.name.clone())
            .collect();
        self.status = if !unidentified.is_empty() {
            Status::Unidentified(unidentified)
        } else if let Some(reason) = self.degenerate() {
            Status::Degenerate(reason)
        } else {
            Status::Converged
        };
        if self.status != Status::Converged {
            self.notes.push(format!(
                "not converged: {} (model '{}')",
                self.status, self.model
            ));
        }
        self
    }

    /// [`Self::assess`], then the residuals diagnosed as a method whose
    /// residuals should be white diagnoses them (output error with sensor
    /// noise: the model reproduces everything but the noise). Outputs
    /// whose residuals are structured ([`OutputFit::is_structured`]) are
    /// [`DiagnosisKind::ColouredResiduals`], measured by their structured
    /// part; residuals correlated but structured below
    /// [`STRUCTURED_LIMIT`] get a note. The status is left as it is.
    pub fn assess_residuals(self) -> Estimate {
        let mut estimate = self.assess();
        let structured: Vec<&OutputFit> =
            estimate.fits.iter().filter(|f| f.is_structured()).collect();
        let correlated: Vec<&OutputFit> = estimate
            .fits
            .iter()
            .filter(|f| f.correlated() && !f.is_structured())
            .collect();
        if !correlated.is_empty() {
            let text = correlated
                .iter()
                .map(|f| f.whiteness_text())
                .collect::<Vec<_>>()
                .join("; ");
            estimate.notes.push(format!(
                "residuals correlated but their structured part below {STRUCTURED_LIMIT} of the output's variation (a small model error, input timing or coloured noise): {text}"
            ));
        }
        if !structured.is_empty() {
            let diagnosis = Diagnosis {
                kind: DiagnosisKind::ColouredResiduals,
                about: structured.iter().map(|f| f.channel.clone()).collect(),
                measures: structured.iter().map(|f| f.structured).collect(),
                advice: format!(
                    "structured residual beyond {STRUCTURED_LIMIT} of the output's variation: \
                     a structure lacking a term, a wrong minimum, process noise the method \
                     does not model, or the small model errors of real flight data; the \
                     bounds assume white residuals"
                ),
            };
            let noisy = process_noise_signature(&structured);
            estimate.diagnose(diagnosis);
            if !noisy.is_empty() {
                estimate.diagnose(Diagnosis {
                    kind: DiagnosisKind::ProcessNoise,
                    about: noisy.iter().map(|(c, _)| c.clone()).collect(),
                    measures: noisy.iter().map(|(_, share)| *share).collect(),
                    advice: "the structured residuals of these outputs move together, and are \
                             as large where the predicted motion is quiet as where it is not: \
                             the response to process noise (turbulence), which output error \
                             does not model; filter error (fem) and the augmented EKF are \
                             built for it (measure: the quiet share)"
                        .into(),
                });
            }
        }
        estimate
    }

    /// Adds a diagnosis (replacing one of the same kind).
    pub fn diagnose(&mut self, diagnosis: Diagnosis) {
        self.diagnoses.retain(|d| d.kind != diagnosis.kind);
        self.diagnoses.push(diagnosis);
    }

    /// The diagnosis of this kind, if the estimate carries one.
    pub fn diagnosis(&self, kind: DiagnosisKind) -> Option<&Diagnosis> {
        self.diagnoses.iter().find(|d| d.kind == kind)
    }

    /// Why the covariance cannot be used, if it cannot: missing, or
    /// holding non-finite entries although every standard error is finite.
    /// (A singular information matrix shows as infinite standard errors of
    /// the parameters in its null space: unidentified, above. A covariance
    /// corrected for coloured residuals need not be positive definite where
    /// the residuals are rounding noise, as on noise-free data, so
    /// definiteness is not asked of it.)
    fn degenerate(&self) -> Option<String> {
        if self.covariance.is_empty() {
            return (!self.parameters.is_empty()).then(|| "no covariance was computed".to_string());
        }
        let square = self
            .covariance
            .iter()
            .all(|row| row.len() == self.covariance.len());
        if !square || self.covariance.len() != self.parameters.len() {
            return Some("the covariance does not match the parameters".into());
        }
        self.covariance
            .iter()
            .flatten()
            .any(|v| !v.is_finite())
            .then(|| "the covariance holds non-finite entries".to_string())
    }

    pub fn parameter(&self, name: &str) -> Option<&ParameterEstimate> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Correlation matrix from the covariance.
    pub fn correlation(&self) -> Vec<Vec<f64>> {
        let c = &self.covariance;
        (0..c.len())
            .map(|i| {
                (0..c.len())
                    .map(|j| c[i][j] / (c[i][i] * c[j][j]).sqrt())
                    .collect()
            })
            .collect()
    }

    /// The parameter most correlated with parameter `index` and
    /// |correlation|; None without a finite covariance.
    pub fn strongest_correlation(&self, index: usize) -> Option<(&str, f64)> {
        let correlation = self.correlation();
        let row = correlation.get(index)?;
        row.iter()
            .enumerate()
            .filter(|&(j, r)| j != index && r.is_finite())
            .map(|(j, r)| {
                (
                    self.parameters.get(j).map_or("", |p| p.name.as_str()),
                    r.abs(),
                )
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The condition number of the correlation matrix (the information
    /// matrix with every parameter scaled to unit variance): how close the
    /// parameters are to being inseparable, independent of their units.
    /// None without a finite covariance.
    pub fn correlation_condition(&self) -> Option<f64> {
        let correlation = self.correlation();
        let n = correlation.len();
        if n == 0 || correlation.iter().flatten().any(|r| !r.is_finite()) {
            return None;
        }
        let matrix = nalgebra::DMatrix::from_fn(n, n, |i, j| correlation[i][j]);
        let eigenvalues = matrix.symmetric_eigenvalues();
        let largest = eigenvalues.max();
        let smallest = eigenvalues.min();
        (smallest > 0.0)
            .then(|| largest / smallest)
            .or(Some(f64::INFINITY))
    }

    pub fn write_json(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::File {
            reason: format!("{}: {e}", path.display()),
        })?;
        Ok(aeroid_core::atomic::write_text(path, &text)?)
    }

    pub fn read_json(path: &Path) -> Result<Estimate> {
        let text = aeroid_core::error::read_text(path)?;
        serde_json::from_str(&text).map_err(|e| Error::File {
            reason: format!("{}: {e}", path.display()),
        })
    }
}

/// What an estimate records of the network a neural method trained
/// (issue: MSE, R², hidden-layer size and seed in every estimate).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetworkReport {
    /// The kind of network: "elm", "recurrent-elm", "feed-forward", "rbf".
    pub kind: String,
    /// Its input and output channels, in order.
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    /// Neurons in the hidden layer (RBF: the number of centres).
    pub hidden: usize,
    /// The seed of its random weights (0 for a network without any).
    pub seed: u64,
    pub training_samples: usize,
    /// MSE and R² of the trained network on its training data (Eqs. 21–22),
    /// in scaled units.
    pub mse: f64,
    pub r_squared: f64,
    /// Anything else worth knowing (RBF: the cluster radius and width factor).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub settings: Vec<(String, f64)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A converged two-parameter estimate with the given covariance and
    /// one output fit of R² `r_squared`.
    fn estimate(covariance: [[f64; 2]; 2], r_squared: f64) -> Estimate {
        Estimate {
            parameters: ["a", "b"]
                .iter()
                .enumerate()
                .map(|(i, name)| ParameterEstimate {
                    name: name.to_string(),
                    value: 1.0,
                    standard_error: covariance[i][i].sqrt(),
                    start: 0.0,
                })
                .collect(),
            covariance: covariance.iter().map(|row| row.to_vec()).collect(),
            fits: vec![OutputFit {
                channel: "nz".into(),
                samples: 100,
                rms: 0.1,
                r_squared,
                theil: 0.1,
                lag_one: 0.0,
                outside_band: 0.05,
                structured: 0.0,
                quiet_share: f64::NAN,
                residuals: Vec::new(),
            }],
            iterations: 3,
            cost_history: vec![3.0, 2.0, 1.0],
            ..Estimate::empty("test", "m", "r", Status::Converged)
        }
    }

    /// Each way an estimate is not converged, built on purpose: an infinite
    /// σ names the parameter; finite σ with a NaN covariance entry is
    /// degenerate. R² < 0 and a NaN R² leave the status converged with a
    /// poor-fit diagnosis naming the output. A sound estimate stays
    /// converged without diagnoses, and a status that is already not
    /// converged is kept (its poor fit diagnosed all the same).
    #[test]
    fn assessment_says_what_an_estimate_is() {
        let sound = estimate([[1.0, 0.5], [0.5, 1.0]], 0.9);
        assert_eq!(sound.assess().status, Status::Converged);

        let infinite = estimate([[1.0, 0.0], [0.0, f64::INFINITY]], 0.9);
        let assessed = infinite.assess();
        assert_eq!(assessed.status, Status::Unidentified(vec!["b".into()]));
        assert!(assessed.notes.iter().any(|n| n.contains("unidentified: b")));

        let degenerate = estimate([[1.0, f64::NAN], [f64::NAN, 1.0]], 0.9);
        assert!(matches!(degenerate.assess().status, Status::Degenerate(_)));

        let sound = estimate([[1.0, 0.5], [0.5, 1.0]], 0.9).assess();
        assert!(sound.diagnoses.is_empty());

        for r_squared in [-0.3, f64::NAN] {
            let poor = estimate([[1.0, 0.0], [0.0, 1.0]], r_squared).assess();
            assert_eq!(poor.status, Status::Converged);
            let diagnosis = poor.diagnosis(DiagnosisKind::PoorFit).unwrap();
            assert_eq!(diagnosis.about, vec!["nz".to_string()]);
            assert_eq!(diagnosis.measures.len(), 1);
        }

        let mut limited = estimate([[1.0, 0.0], [0.0, f64::INFINITY]], -0.3);
        limited.status = Status::IterationLimit;
        let limited = limited.assess();
        assert_eq!(limited.status, Status::IterationLimit);
        assert!(limited.diagnosis(DiagnosisKind::PoorFit).is_some());
        assert!(!Status::IterationLimit.is_success());
    }
}
