//! What an estimator returns: values with Cramér–Rao standard errors, the
//! covariance and correlation matrices, fit metrics per output (residual RMS,
//! R², Theil's inequality coefficient, Verma & Peyada 2020, Eq. 27), the iteration and
//! cost history, wall time and a status (converged, iteration limit,
//! diverged — never a panic). Serialises to JSON and CSV.

use crate::error::{Error, Result};
use crate::estimation::solver::gauss_newton::{Solution, Status};
use nalgebra::DVector;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterEstimate {
    pub name: String,
    pub value: f64,
    /// Cramér–Rao standard error (corrected for coloured residuals where the method allows).
    pub standard_error: f64,
    pub start: f64,
}

/// How well the fitted model reproduces one output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputFit {
    pub channel: String,
    pub samples: usize,
    pub rms: f64,
    pub r_squared: f64,
    /// Theil's inequality coefficient (Verma & Peyada 2020, Eq. 27): 0 perfect, 1 worst.
    pub theil: f64,
}

impl OutputFit {
    /// Fit metrics of `predicted` against `measured` (dropouts skipped).
    pub fn new(channel: &str, measured: &[f64], predicted: &[f64]) -> OutputFit {
        let pairs: Vec<(f64, f64)> = measured
            .iter()
            .zip(predicted)
            .map(|(&z, &y)| (z, y))
            .filter(|(z, y)| z.is_finite() && y.is_finite())
            .collect();
        let n = pairs.len().max(1) as f64;
        let mean = pairs.iter().map(|(z, _)| z).sum::<f64>() / n;
        let residual_square: f64 = pairs.iter().map(|(z, y)| (z - y).powi(2)).sum();
        let total_square: f64 = pairs.iter().map(|(z, _)| (z - mean).powi(2)).sum();
        let rms = (residual_square / n).sqrt();
        let measured_rms = (pairs.iter().map(|(z, _)| z * z).sum::<f64>() / n).sqrt();
        let predicted_rms = (pairs.iter().map(|(_, y)| y * y).sum::<f64>() / n).sqrt();
        OutputFit {
            channel: channel.to_string(),
            samples: pairs.len(),
            rms,
            r_squared: if total_square > 0.0 {
                1.0 - residual_square / total_square
            } else {
                f64::NAN
            },
            theil: rms / (measured_rms + predicted_rms),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    pub method: String,
    pub model: String,
    pub record: String,
    pub status: Status,
    pub parameters: Vec<ParameterEstimate>,
    /// Covariance of the estimates (rows/columns in `parameters` order).
    pub covariance: Vec<Vec<f64>>,
    pub fits: Vec<OutputFit>,
    pub iterations: usize,
    pub cost_history: Vec<f64>,
    pub wall_time: f64,
    /// Anything the user should know (a channel held constant, an unidentifiable parameter).
    pub notes: Vec<String>,
}

impl Estimate {
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
            method: method.to_string(),
            model,
            record,
            status: solution.status.clone(),
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
            fits: Vec::new(),
            iterations: solution.history.len(),
            cost_history: solution.history.iter().map(|i| i.cost).collect(),
            wall_time: 0.0,
            notes: Vec::new(),
        }
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

    pub fn write_json(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Other(format!("{}: {e}", path.display())))?;
        std::fs::write(path, text).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    pub fn read_json(path: &Path) -> Result<Estimate> {
        let text = crate::error::read_text(path)?;
        serde_json::from_str(&text).map_err(|e| Error::Other(format!("{}: {e}", path.display())))
    }
}
