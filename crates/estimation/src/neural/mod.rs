//! What the neural estimators share: the input/output scaling of the
//! training data, the network's fit metrics and the report an estimate
//! carries of its network.
//!
//! - Scaling to a range (x̄min, x̄max): Verma & Peyada, "Estimation of
//!   aerodynamic parameters near stall using maximum likelihood and extreme
//!   learning machine-based methods", Aeronautical J. 2020, Eq. 16 (the
//!   same as Eq. 3 of "Parameter estimation of aircraft using extreme
//!   learning machine and Gauss-Newton algorithm").
//! - MSE and R² of a network: Verma & Peyada 2020, Eqs. 21–22 (the ELM
//!   paper's Eqs. 9–10 print an equivalent R² with n_y outside the sum).
//! - The log-sigmoid activation g(s) = 1/(1 + e^(−s)) of the ELM paper's
//!   Eq. 4 and Verma & Peyada's Eq. 17.
//!
//! Random weights come from [`aeroid_core::random::stream`]`(seed,
//! NETWORK_WEIGHTS)`: a seed gives the same network, bit for bit, whatever
//! the thread count.

pub mod elm;
pub mod rbf;
pub mod restricted;

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

pub mod feedforward;

/// The log-sigmoid activation.
#[inline]
pub(crate) fn log_sigmoid(s: f64) -> f64 {
    1.0 / (1.0 + (-s).exp())
}

/// Per-column affine scaling of data to `[low, high]` (Eq. 16). A column
/// whose samples are all equal is mapped to the middle of the range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scaling {
    /// Per column: the data's minimum and maximum.
    pub range: Vec<(f64, f64)>,
    pub low: f64,
    pub high: f64,
}

impl Scaling {
    /// The scaling of the columns of `rows` (each row one sample) to
    /// `[low, high]`; an error names the first column that is not finite.
    pub fn fit(rows: &[Vec<f64>], names: &[String], low: f64, high: f64) -> Result<Scaling> {
        let columns = names.len();
        let mut range = vec![(f64::INFINITY, f64::NEG_INFINITY); columns];
        for row in rows {
            for (c, &x) in row.iter().enumerate().take(columns) {
                if !x.is_finite() {
                    return Err(Error::Network {
                        reason: format!(
                            "the network's training data has a non-finite value in '{}'",
                            names[c]
                        ),
                    });
                }
                range[c] = (range[c].0.min(x), range[c].1.max(x));
            }
        }
        if rows.is_empty() {
            return Err(Error::Network {
                reason: "the network has no training data".into(),
            });
        }
        Ok(Scaling { range, low, high })
    }

    /// Scales one sample in place.
    #[inline]
    pub fn apply(&self, x: &mut [f64]) {
        for (x, &(min, max)) in x.iter_mut().zip(&self.range) {
            *x = if max > min {
                self.low + (self.high - self.low) * (*x - min) / (max - min)
            } else {
                0.5 * (self.low + self.high)
            };
        }
    }

    /// Undoes [`Scaling::apply`] in place (a constant column gives its value).
    #[inline]
    pub fn invert(&self, x: &mut [f64]) {
        for (x, &(min, max)) in x.iter_mut().zip(&self.range) {
            *x = if max > min {
                min + (max - min) * (*x - self.low) / (self.high - self.low)
            } else {
                min
            };
        }
    }

    /// d(unscaled)/d(scaled) of column `c`: the factor a derivative taken
    /// through the scaled network is multiplied by (0 for a constant column).
    pub fn unscale_factor(&self, c: usize) -> f64 {
        let (min, max) = self.range[c];
        if max > min {
            (max - min) / (self.high - self.low)
        } else {
            0.0
        }
    }
}

/// How well a network reproduces its targets: MSE and R² (Eqs. 21–22),
/// over `targets` and `predictions` given sample by sample (rows), each
/// row with the same number of outputs. Non-finite pairs are skipped.
pub(crate) fn fit_metrics<R: AsRef<[f64]>>(targets: &[R], predictions: &[R]) -> (f64, f64) {
    let outputs = targets.first().map_or(0, |row| row.as_ref().len());
    if outputs == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mut square = 0.0;
    let mut count = 0usize;
    let mut r_squared = 0.0;
    for k in 0..outputs {
        let pairs = || {
            targets
                .iter()
                .zip(predictions)
                .map(move |(z, y)| (z.as_ref()[k], y.as_ref()[k]))
                .filter(|(z, y)| z.is_finite() && y.is_finite())
        };
        let n = pairs().count();
        if n == 0 {
            return (f64::NAN, f64::NAN);
        }
        let mean = pairs().map(|(z, _)| z).sum::<f64>() / n as f64;
        let residual: f64 = pairs().map(|(z, y)| (z - y).powi(2)).sum();
        let total: f64 = pairs().map(|(z, _)| (z - mean).powi(2)).sum();
        square += residual;
        count += n;
        r_squared += if total > 0.0 {
            1.0 - residual / total
        } else {
            f64::NAN
        };
    }
    (square / count as f64, r_squared / outputs as f64)
}

pub use crate::estimate::NetworkReport;

#[cfg(test)]
mod tests {
    use super::*;

    /// Scaling maps each column's minimum and maximum onto the range ends
    /// and back exactly; a constant column goes to the middle and back.
    #[test]
    fn scaling_round_trips() {
        let rows = vec![
            vec![1.0, 5.0, 2.0],
            vec![3.0, -5.0, 2.0],
            vec![2.0, 0.0, 2.0],
        ];
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let scaling = Scaling::fit(&rows, &names, -1.0, 1.0).unwrap();
        let mut x = rows[0].clone();
        scaling.apply(&mut x);
        assert_eq!(x, vec![-1.0, 1.0, 0.0]);
        scaling.invert(&mut x);
        assert_eq!(x, rows[0]);
        assert_eq!(scaling.unscale_factor(0), 1.0);
        assert_eq!(scaling.unscale_factor(2), 0.0);
        let bad = vec![vec![1.0, f64::NAN, 0.0]];
        let error = Scaling::fit(&bad, &names, 0.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(error.contains("'b'"), "{error}");
    }

    /// A perfect prediction has MSE 0 and R² 1; predicting the mean has R² 0.
    #[test]
    fn metrics_of_perfect_and_mean_predictions() {
        let z = vec![vec![1.0, 10.0], vec![2.0, 20.0], vec![3.0, 30.0]];
        assert_eq!(fit_metrics(&z, &z), (0.0, 1.0));
        let mean = vec![vec![2.0, 20.0]; 3];
        let (mse, r2) = fit_metrics(&z, &mean);
        assert!((mse - (2.0 + 200.0) / 6.0).abs() < 1e-12);
        assert!(r2.abs() < 1e-12);
        assert!((log_sigmoid(0.0) - 0.5).abs() < 1e-15);
    }
}
