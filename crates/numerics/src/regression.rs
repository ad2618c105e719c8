//! Ordinary least squares `z = X·θ + ε` for the regression estimators
//! (equation error, stepwise regression), following Klein & Morelli,
//! "Aircraft System Identification" (AIAA 2006), ch. 5:
//!
//! - solution `θ̂ = (XᵀX)⁻¹·Xᵀz` (reflex-wing UAV paper, Eq. 27) computed by the SVD of X
//!   with its columns scaled to unit norm (never by forming the normal
//!   equations), directions with singular values below the threshold of
//!   [`pseudo_inverse_or_infinite`] left out and their parameters reported as
//!   unidentifiable (infinite variance);
//! - fit error variance `s² = eᵀe/(N − n)` and the Cramér–Rao bound for
//!   white residuals `Cov θ̂ = s²·(XᵀX)⁻¹` (K&M Eq. 5.25);
//! - the bound corrected for coloured residuals (Morelli & Klein, "Accuracy
//!   of aerodynamic model parameters estimated from flight test data",
//!   J. Guidance 20(1), 1997, Eq. 19; K&M Eq. 5.62):
//!   `Cov θ̂ = (XᵀX)⁻¹·[Σᵢ Σⱼ xᵢ·R_ee(i − j)·xⱼᵀ]·(XᵀX)⁻¹`, with the residual
//!   autocorrelation estimate `R_ee(k) = (1/N)·Σᵢ eᵢ·e_{i+k}`, the double sum
//!   truncated at |i − j| ≤ L (the caller's lag). The truncated sum is not
//!   always positive definite (residuals that are differentiated noise have
//!   almost no power at low frequency, so Σ_k R_ee(k) ≈ 0 and the estimate
//!   can fall below zero); [`LagWindow::Bartlett`] weights lag k by
//!   1 − k/(L + 1) (Newey & West, Econometrica 55, 1987), which guarantees a
//!   positive semi-definite result;
//! - leverages `h_ii = xᵢᵀ(XᵀX)⁻¹xᵢ` (hat-matrix diagonal, from the left
//!   singular vectors) for PRESS = Σ (eᵢ/(1 − h_ii))² (K&M Eq. 5.81).

use crate::gauss_newton::pseudo_inverse_or_infinite;
use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView};

/// Weights of the residual autocorrelation in the coloured-residual bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LagWindow {
    /// Every lag up to L with weight 1 (Morelli & Klein 1997).
    Rectangular,
    /// Lag k weighted by 1 − k/(L + 1): positive semi-definite.
    Bartlett,
}

/// An ordinary least-squares fit.
#[derive(Debug, Clone, PartialEq)]
pub struct LeastSquares {
    pub theta: DVector<f64>,
    pub residuals: DVector<f64>,
    /// (XᵀX)⁻¹, rows/columns of unidentifiable parameters infinite.
    pub inverse_information: DMatrix<f64>,
    /// Columns whose parameters cannot be separated from the others.
    pub unidentifiable: Vec<usize>,
    /// Hat-matrix diagonal h_ii.
    pub leverage: Vec<f64>,
}

impl LeastSquares {
    /// Fits `z ≈ X·θ`.
    pub fn fit(x: &DMatrix<f64>, z: &DVector<f64>) -> LeastSquares {
        let columns = x.ncols();
        let norms: Vec<f64> = x
            .column_iter()
            .map(|c| match c.norm() {
                n if n > 0.0 && n.is_finite() => n,
                _ => 1.0,
            })
            .collect();
        let mut scaled = x.clone();
        for (j, norm) in norms.iter().enumerate() {
            scaled.column_mut(j).unscale_mut(*norm);
        }
        let scaled_inverse = pseudo_inverse_or_infinite(&(scaled.transpose() * &scaled));
        let unidentifiable: Vec<usize> = (0..columns)
            .filter(|&j| !scaled_inverse[(j, j)].is_finite())
            .collect();
        let svd = scaled.svd(true, true);
        let threshold = svd.singular_values.max() * (1e-13 * columns as f64).sqrt();
        let scaled_theta = svd
            .solve(z, threshold)
            .unwrap_or_else(|_| DVector::zeros(columns));
        let theta = DVector::from_fn(columns, |j, _| scaled_theta[j] / norms[j]);
        let inverse_information = DMatrix::from_fn(columns, columns, |i, j| {
            scaled_inverse[(i, j)] / (norms[i] * norms[j])
        });
        let residuals = z - x * &theta;
        let leverage = leverages(&svd, threshold);
        LeastSquares {
            theta,
            residuals,
            inverse_information,
            unidentifiable,
            leverage,
        }
    }

    /// The θ of [`LeastSquares::fit`] alone (same column scaling, same
    /// singular-value threshold, so the same truncated solution up to
    /// rounding), without the covariance, residuals and leverages: for
    /// callers that solve many problems and need only θ. A tall X (more
    /// rows than columns) is reduced by Householder QR, X = Q·R, and the
    /// SVD is that of the small square R (its singular values are X's),
    /// applied to the first columns of Qᵀz (the R-SVD of Golub & Van Loan,
    /// "Matrix Computations", §5.4.5); a wide X is decomposed directly.
    pub fn solve(x: &DMatrix<f64>, z: &DVector<f64>) -> DVector<f64> {
        let columns = x.ncols();
        let mut scaled = x.clone();
        let norms: Vec<f64> = scaled
            .column_iter_mut()
            .map(|mut c| match c.norm() {
                n if n > 0.0 && n.is_finite() => {
                    c.unscale_mut(n);
                    n
                }
                _ => 1.0,
            })
            .collect();
        let (square, rhs) = if x.nrows() > columns {
            let qr = scaled.qr();
            let mut qtz = z.clone();
            qr.q_tr_mul(&mut qtz);
            (qr.r(), qtz.rows(0, columns).into_owned())
        } else {
            (scaled, z.clone())
        };
        let svd = square.svd(true, true);
        let threshold = svd.singular_values.max() * (1e-13 * columns as f64).sqrt();
        let scaled_theta = svd
            .solve(&rhs, threshold)
            .unwrap_or_else(|_| DVector::zeros(columns));
        DVector::from_fn(columns, |j, _| scaled_theta[j] / norms[j])
    }

    /// Residual sum of squares eᵀe.
    pub fn residual_sum_of_squares(&self) -> f64 {
        self.residuals.norm_squared()
    }

    /// s² = eᵀe/(N − n); infinite when there are no degrees of freedom left.
    pub fn residual_variance(&self) -> f64 {
        let freedom = self.residuals.len() as f64 - self.theta.len() as f64;
        if freedom > 0.0 {
            self.residual_sum_of_squares() / freedom
        } else {
            f64::INFINITY
        }
    }

    /// The Cramér–Rao bound for white residuals, s²·(XᵀX)⁻¹.
    pub fn white_covariance(&self) -> DMatrix<f64> {
        &self.inverse_information * self.residual_variance()
    }

    /// The bound corrected for coloured residuals (Morelli & Klein 1997),
    /// autocorrelation summed to lag `lag` (samples) with the given window.
    /// Falls back to the white bound when a parameter is unidentifiable.
    pub fn coloured_covariance(
        &self,
        x: &DMatrix<f64>,
        lag: usize,
        window: LagWindow,
    ) -> DMatrix<f64> {
        if !self.unidentifiable.is_empty() {
            return self.white_covariance();
        }
        sandwich(
            &self.inverse_information,
            &coloured_middle(&[(x.as_view(), self.residuals.as_view())], lag, window),
        )
    }

    /// The bound for independent residuals of unequal variance v_i (row i):
    /// `(XᵀX)⁻¹·(Σᵢ v_i·xᵢxᵢᵀ)·(XᵀX)⁻¹` (the sandwich of White,
    /// Econometrica 48, 1980, with the caller's variance model). Falls back
    /// to the white bound when a parameter is unidentifiable.
    pub fn weighted_covariance(&self, x: &DMatrix<f64>, variances: &[f64]) -> DMatrix<f64> {
        if !self.unidentifiable.is_empty() || variances.len() != x.nrows() {
            return self.white_covariance();
        }
        let mut middle = DMatrix::zeros(x.ncols(), x.ncols());
        for (i, &v) in variances.iter().enumerate() {
            let row = x.row(i);
            middle += row.transpose() * row * v;
        }
        &self.inverse_information * middle * &self.inverse_information
    }

    /// The Morelli–Klein bound with the plain truncated sum, or, when that is
    /// not positive for some parameter, the Bartlett-weighted one; with the
    /// window used.
    pub fn corrected_covariance(&self, x: &DMatrix<f64>, lag: usize) -> (DMatrix<f64>, LagWindow) {
        if !self.unidentifiable.is_empty() {
            return (self.white_covariance(), LagWindow::Rectangular);
        }
        corrected_covariance(
            &self.inverse_information,
            &[(x.as_view(), self.residuals.as_view())],
            lag,
        )
    }

    /// Predicted residual sum of squares, Σ (eᵢ/(1 − h_ii))².
    pub fn press(&self) -> f64 {
        self.residuals
            .iter()
            .zip(&self.leverage)
            .map(|(e, h)| (e / (1.0 - h)).powi(2))
            .sum()
    }
}

/// Rows of a regressor (or sensitivity) matrix and the residuals at them:
/// one stretch of consecutive samples.
pub type Block<'a> = (DMatrixView<'a, f64>, DVectorView<'a, f64>);

/// The middle of the Morelli–Klein bound, Σᵢ Σⱼ xᵢ·R_ee(i − j)·xⱼᵀ over
/// |i − j| ≤ `lag` within each block, R_ee(k) = (1/N)·Σ eᵢ·e_{i+k} the
/// residuals' autocorrelation pooled over the blocks (N their samples in
/// all; a pair never spans two blocks), lag k weighted by the window.
pub fn coloured_middle(blocks: &[Block], lag: usize, window: LagWindow) -> DMatrix<f64> {
    let columns = blocks.first().map_or(0, |(x, _)| x.ncols());
    let count: usize = blocks.iter().map(|(_, e)| e.len()).sum();
    let mut middle = DMatrix::zeros(columns, columns);
    if count == 0 {
        return middle;
    }
    // Σ eᵢ·e_{i+k} over the blocks (each block's own pairs).
    let lagged = |k: usize| {
        blocks
            .iter()
            .filter(|(_, e)| e.len() > k)
            .map(|(_, e)| e.rows(0, e.len() - k).dot(&e.rows(k, e.len() - k)))
            .sum::<f64>()
    };
    let zero = blocks.iter().map(|(_, e)| e.norm_squared()).sum::<f64>() / count as f64;
    for (x, _) in blocks {
        middle += x.tr_mul(x) * zero;
    }
    let longest = blocks.iter().map(|(_, e)| e.len()).max().unwrap_or(0);
    for k in 1..=lag.min(longest.saturating_sub(1)) {
        let weight = match window {
            LagWindow::Rectangular => 1.0,
            LagWindow::Bartlett => 1.0 - k as f64 / (lag as f64 + 1.0),
        };
        let correlation = weight * lagged(k) / count as f64;
        for (x, _) in blocks.iter().filter(|(x, _)| x.nrows() > k) {
            let rows = x.nrows() - k;
            let product = x.rows(0, rows).tr_mul(&x.rows(k, rows));
            middle += (&product + product.transpose()) * correlation;
        }
    }
    middle
}

/// A⁻¹·B·A⁻¹ for the inverse information A⁻¹ and the middle B.
pub fn sandwich(inverse_information: &DMatrix<f64>, middle: &DMatrix<f64>) -> DMatrix<f64> {
    inverse_information * middle * inverse_information
}

/// The Morelli–Klein bound (module documentation) for the inverse
/// information `inverse_information` and the blocks of rows with their
/// residuals: the plain truncated sum, or, when that is not positive for
/// some parameter, the Bartlett-weighted one; with the window used.
pub fn corrected_covariance(
    inverse_information: &DMatrix<f64>,
    blocks: &[Block],
    lag: usize,
) -> (DMatrix<f64>, LagWindow) {
    let plain = sandwich(
        inverse_information,
        &coloured_middle(blocks, lag, LagWindow::Rectangular),
    );
    if plain.diagonal().iter().all(|v| *v > 0.0) {
        (plain, LagWindow::Rectangular)
    } else {
        let weighted = sandwich(
            inverse_information,
            &coloured_middle(blocks, lag, LagWindow::Bartlett),
        );
        (weighted, LagWindow::Bartlett)
    }
}

/// h_ii = Σ_k U_ik² over the retained singular directions.
fn leverages(svd: &nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, threshold: f64) -> Vec<f64> {
    let u = svd.u.as_ref().expect("the SVD was computed with U");
    let kept: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > threshold)
        .collect();
    (0..u.nrows())
        .map(|i| kept.iter().map(|&k| u[(i, k)] * u[(i, k)]).sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line with known coefficients and no noise is recovered exactly, and
    /// the white bound equals s²(XᵀX)⁻¹ computed directly; PRESS equals the
    /// leave-one-out sum computed by refitting N times.
    #[test]
    fn line_fit_bounds_and_press() {
        let n = 40;
        let x = DMatrix::from_fn(n, 2, |i, j| if j == 0 { 1.0 } else { i as f64 * 0.1 });
        let noise = DVector::from_fn(n, |i, _| ((i * 37 % 11) as f64 - 5.0) * 0.01);
        let z = DVector::from_fn(n, |i, _| 0.5 - 2.0 * x[(i, 1)]) + &noise;
        let fit = LeastSquares::fit(&x, &z);
        let direct = (x.transpose() * &x).try_inverse().unwrap();
        let theta = &direct * x.transpose() * &z;
        assert!((&fit.theta - &theta).norm() < 1e-12);
        let s2 = (&z - &x * &theta).norm_squared() / (n as f64 - 2.0);
        assert!((fit.white_covariance() - &direct * s2).norm() < 1e-14);
        let mut leave_one_out = 0.0;
        for i in 0..n {
            let keep: Vec<usize> = (0..n).filter(|&k| k != i).collect();
            let xi = x.select_rows(&keep);
            let zi = z.select_rows(&keep);
            let theta_i = (xi.transpose() * &xi).try_inverse().unwrap() * xi.transpose() * zi;
            leave_one_out += (z[i] - (x.row(i) * theta_i)[0]).powi(2);
        }
        assert!((fit.press() - leave_one_out).abs() < 1e-12 * leave_one_out);
    }

    /// With lag 0 the coloured bound is (XᵀX)⁻¹·R(0)·XᵀX·(XᵀX)⁻¹ = (eᵀe/N)(XᵀX)⁻¹,
    /// i.e. the white bound times (N − n)/N; with strongly positively
    /// correlated residuals (a slow sine) and a lag covering them, it is larger
    /// (Bartlett-weighted: larger than white, smaller than the plain sum).
    #[test]
    fn coloured_bound_reduces_to_white_and_grows_with_correlation() {
        let n = 400;
        let x = DMatrix::from_fn(
            n,
            2,
            |i, j| if j == 0 { 1.0 } else { (i as f64 * 0.37).sin() },
        );
        let z = DVector::from_fn(n, |i, _| 1.0 + 0.2 * (i as f64 * 0.01).sin() + x[(i, 1)]);
        let fit = LeastSquares::fit(&x, &z);
        let white = fit.white_covariance();
        let lag_zero = fit.coloured_covariance(&x, 0, LagWindow::Rectangular);
        let factor = (n as f64 - 2.0) / n as f64;
        assert!((&lag_zero - &white * factor).norm() < 1e-12 * white.norm());
        let coloured = fit.coloured_covariance(&x, 100, LagWindow::Rectangular);
        assert!(
            coloured[(0, 0)] > 5.0 * white[(0, 0)],
            "{coloured} vs {white}"
        );
        let bartlett = fit.coloured_covariance(&x, 100, LagWindow::Bartlett);
        assert!(bartlett[(0, 0)] > 2.0 * white[(0, 0)] && bartlett[(0, 0)] < coloured[(0, 0)]);
    }

    /// Differentiated white noise (first difference) has autocorrelation
    /// R(0) = 2σ², R(1) = −σ², so its long-run variance is 0: the plain
    /// truncated sum can go negative for the constant, the Bartlett-weighted
    /// one cannot.
    #[test]
    fn bartlett_window_keeps_the_bound_positive() {
        let n = 2000;
        let mut rng = aeroid_core::random::stream(7, 0);
        let white: Vec<f64> = (0..=n)
            .map(|_| rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng))
            .collect();
        let x = DMatrix::from_element(n, 1, 1.0);
        let z = DVector::from_fn(n, |i, _| 2.0 + white[i + 1] - white[i]);
        let fit = LeastSquares::fit(&x, &z);
        let window = |w| fit.coloured_covariance(&x, 20, w)[(0, 0)];
        assert!(window(LagWindow::Bartlett) >= 0.0);
        assert!(window(LagWindow::Bartlett) < 0.2 * fit.white_covariance()[(0, 0)]);
        assert!(window(LagWindow::Rectangular) < 0.05 * fit.white_covariance()[(0, 0)]);
    }

    /// [`LeastSquares::solve`] (QR, then the SVD of R) equals the θ of
    /// [`LeastSquares::fit`] (SVD of X) to rounding: on a well-conditioned
    /// tall problem (relative difference below 1e-12), on a
    /// Gaussian design whose smallest singular values fall below the
    /// threshold (the same truncated solution; 1e-6 relative, as the
    /// truncated directions amplify rounding), on dependent columns, and on
    /// a wide X.
    #[test]
    fn solve_equals_the_svd_solution() {
        let n = 300;
        let x = DMatrix::from_fn(n, 5, |i, j| ((i * (j + 3)) as f64 * 0.071).sin() + j as f64);
        let z = DVector::from_fn(n, |i, _| (i as f64 * 0.05).cos());
        let fit = LeastSquares::fit(&x, &z);
        let solved = LeastSquares::solve(&x, &z);
        assert!(
            (&solved - &fit.theta).norm() < 1e-12 * fit.theta.norm(),
            "{solved} vs {}",
            fit.theta
        );
        // Gaussian basis functions far wider than their spacing: nearly
        // dependent columns, several singular values below the threshold.
        let gaussian = DMatrix::from_fn(n, 12, |i, j| {
            let d = i as f64 / n as f64 - j as f64 / 11.0;
            (-d * d / 4.0).exp()
        });
        let svd = gaussian.clone().svd(false, false);
        let kept = svd
            .singular_values
            .iter()
            .filter(|&&s| s > svd.singular_values.max() * 1e-6)
            .count();
        assert!(
            kept < 12,
            "the design is not ill-conditioned: {}",
            svd.singular_values
        );
        let fit = LeastSquares::fit(&gaussian, &z);
        let solved = LeastSquares::solve(&gaussian, &z);
        let (fitted, predicted) = (&gaussian * &fit.theta, &gaussian * &solved);
        assert!(
            (&fitted - &predicted).norm() < 1e-6 * fitted.norm(),
            "{}",
            (&fitted - &predicted).norm()
        );
        assert!((&solved - &fit.theta).norm() < 1e-6 * fit.theta.norm());
        let dependent = DMatrix::from_fn(20, 3, |i, j| match j {
            0 => 1.0,
            1 => i as f64,
            _ => 2.0 * i as f64,
        });
        let line = DVector::from_fn(20, |i, _| 3.0 + i as f64);
        let solved = LeastSquares::solve(&dependent, &line);
        assert!((&solved - &LeastSquares::fit(&dependent, &line).theta).norm() < 1e-12);
        assert!((&dependent * &solved - &line).norm() < 1e-12);
        let wide = DMatrix::from_fn(3, 5, |i, j| ((i + 2 * j) as f64).sin());
        let short = DVector::from_fn(3, |i, _| i as f64);
        let solved = LeastSquares::solve(&wide, &short);
        assert!((&solved - &LeastSquares::fit(&wide, &short).theta).norm() < 1e-12);
    }

    /// A zero column and two proportional columns are reported as unidentifiable, without a panic.
    #[test]
    fn dependent_columns_are_unidentifiable() {
        let n = 20;
        let x = DMatrix::from_fn(n, 4, |i, j| match j {
            0 => 1.0,
            1 => i as f64,
            2 => 2.0 * i as f64,
            _ => 0.0,
        });
        let z = DVector::from_fn(n, |i, _| 3.0 + i as f64);
        let fit = LeastSquares::fit(&x, &z);
        assert_eq!(fit.unidentifiable, vec![1, 2, 3]);
        assert!(fit.residual_sum_of_squares() < 1e-20);
        assert!(fit.coloured_covariance(&x, 3, LagWindow::Rectangular)[(1, 1)].is_infinite());
    }
}
