//! Sigma points of the scaled unscented transform (Wan & van der Merwe,
//! "The unscented Kalman filter for nonlinear estimation", IEEE AS-SPCC
//! 2000, Eq. 15): χ₀ = x̄, χ_{±i} = x̄ ± (√((n + λ)·P))_i,
//! λ = α²·(n + κ) − n, weights W₀ᵐ = λ/(n + λ),
//! W₀ᶜ = W₀ᵐ + 1 − α² + β, Wᵢ = 1/(2(n + λ)).

use crate::error::{Error, Result};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// The scaled unscented transform's parameters (Wan & van der Merwe 2000).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unscented {
    /// Spread of the points about the mean (10⁻³ … 1).
    pub alpha: f64,
    /// Prior knowledge of the distribution (2 for a Gaussian).
    pub beta: f64,
    /// Secondary scaling (0, or 3 − n).
    pub kappa: f64,
}

impl Default for Unscented {
    fn default() -> Self {
        Unscented {
            alpha: 1.0,
            beta: 2.0,
            kappa: 0.0,
        }
    }
}

/// 2n + 1 sigma points with their mean and covariance weights.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaPoints {
    pub points: Vec<DVector<f64>>,
    pub mean_weights: Vec<f64>,
    pub covariance_weights: Vec<f64>,
}

impl Unscented {
    /// The sigma points of (x̄, P); an error when P is not positive definite.
    pub fn points(&self, mean: &DVector<f64>, covariance: &DMatrix<f64>) -> Result<SigmaPoints> {
        let n = mean.len();
        let lambda = self.alpha * self.alpha * (n as f64 + self.kappa) - n as f64;
        let scale = n as f64 + lambda;
        let root = Cholesky::<f64, Dyn>::new(covariance * scale)
            .ok_or_else(|| Error::NotPositiveDefinite {
                what: "the UKF's state covariance".into(),
                why: "",
            })?
            .unpack();
        let mut points = Vec::with_capacity(2 * n + 1);
        points.push(mean.clone());
        for i in 0..n {
            points.push(mean + root.column(i));
        }
        for i in 0..n {
            points.push(mean - root.column(i));
        }
        let weight = 1.0 / (2.0 * scale);
        let mut mean_weights = vec![weight; 2 * n + 1];
        let mut covariance_weights = mean_weights.clone();
        mean_weights[0] = lambda / scale;
        covariance_weights[0] = lambda / scale + 1.0 - self.alpha * self.alpha + self.beta;
        Ok(SigmaPoints {
            points,
            mean_weights,
            covariance_weights,
        })
    }
}

impl SigmaPoints {
    /// The weighted mean of transformed points.
    pub fn mean_of(&self, transformed: &[DVector<f64>]) -> DVector<f64> {
        let mut mean = DVector::zeros(transformed[0].len());
        for (point, &w) in transformed.iter().zip(&self.mean_weights) {
            mean.axpy(w, point, 1.0);
        }
        mean
    }

    /// The weighted cross-covariance Σ W_i·(a_i − ā)(b_i − b̄)ᵀ.
    pub fn cross_covariance(
        &self,
        a: &[DVector<f64>],
        a_mean: &DVector<f64>,
        b: &[DVector<f64>],
        b_mean: &DVector<f64>,
    ) -> DMatrix<f64> {
        let mut result = DMatrix::zeros(a_mean.len(), b_mean.len());
        for ((a, b), &w) in a.iter().zip(b).zip(&self.covariance_weights) {
            let da = a - a_mean;
            let db = b - b_mean;
            result.ger(w, &da, &db, 1.0);
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::testing::assert_close;

    #[test]
    fn sigma_points_reproduce_mean_and_covariance() {
        let mean = DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let covariance =
            DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5]);
        for unscented in [
            Unscented::default(),
            Unscented {
                alpha: 1e-3,
                beta: 2.0,
                kappa: 0.0,
            },
        ] {
            let sigma = unscented.points(&mean, &covariance).unwrap();
            // W₀ᵐ = 1 − n/(α²·(n + κ)): −3·10⁶ at α = 10⁻³, so the mean
            // keeps about 16 − 6.5 digits.
            let m = sigma.mean_of(&sigma.points);
            assert!((&m - &mean).norm() < 1e-8, "{m}");
            let c = sigma.cross_covariance(&sigma.points, &m, &sigma.points, &m);
            assert_close(&c, &covariance, 1e-9, "covariance");
        }
    }
}
