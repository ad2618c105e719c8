//! The steady filter's innovation covariance R (Jategaonkar Eq. 5.37,
//! R = (1/N)·Σ ν·νᵀ), full or diagonal, and the whitening of the
//! innovations by it (L⁻¹·ν, R = L·Lᵀ).

use super::*;

/// The steady-state filter's innovation covariance R (Jategaonkar
/// Eq. 5.37, R = (1/N)·Σ ν·νᵀ): a full matrix where every grid point with
/// a measurement measures every output (one time base; the innovations of
/// outputs that share a state's prediction error are correlated: β and
/// n_y through β), else its diagonal (outputs on different time bases,
/// each correcting alone).
#[derive(Debug, Clone, PartialEq)]
pub struct InnovationCovariance {
    pub(crate) matrix: DMatrix<f64>,
    /// L⁻¹ (R = L·Lᵀ) and ln det R of a full R; None for a diagonal one.
    pub(crate) whitening: Option<(DMatrix<f64>, f64)>,
}

impl InnovationCovariance {
    /// R = diag(`variances`).
    pub fn diagonal(variances: &DVector<f64>) -> InnovationCovariance {
        InnovationCovariance {
            matrix: DMatrix::from_diagonal(variances),
            whitening: None,
        }
    }

    /// A full R; an error when it is not positive definite.
    pub fn full(matrix: DMatrix<f64>) -> Result<InnovationCovariance> {
        let (root, log_det) = lower_root(matrix.as_view())?;
        let n = root.nrows();
        let inverse = root
            .solve_lower_triangular(&DMatrix::identity(n, n))
            .ok_or_else(|| Error::Numerical {
                reason: "a singular innovation covariance".into(),
            })?;
        Ok(InnovationCovariance {
            matrix,
            whitening: Some((inverse, log_det)),
        })
    }

    /// R.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.matrix
    }

    /// R's diagonal, each output's innovation variance.
    pub fn variances(&self) -> DVector<f64> {
        self.matrix.diagonal()
    }

    /// Rows in the observations' order (one per measurement) whitened in
    /// place: each grid point's block by L⁻¹ where R is full and the point
    /// measures every output, else each row by 1/√R_oo. ½ of the squared
    /// sum of whitened innovations is ½·Σ νᵀR⁻¹ν.
    pub(crate) fn whiten(&self, observations: &Observations, rows: &mut DMatrix<f64>) {
        let outputs = self.matrix.nrows();
        let mut row = 0;
        for present in &observations.at {
            match &self.whitening {
                Some((inverse, _)) if present.len() == outputs => {
                    // The block in the outputs' order, whitened, put back.
                    let mut block = DMatrix::zeros(outputs, rows.ncols());
                    for (i, &(o, _)) in present.iter().enumerate() {
                        block.row_mut(o).copy_from(&rows.row(row + i));
                    }
                    let whitened = inverse * block;
                    for (i, &(o, _)) in present.iter().enumerate() {
                        rows.row_mut(row + i).copy_from(&whitened.row(o));
                    }
                }
                _ => {
                    for (i, &(o, _)) in present.iter().enumerate() {
                        let scale = 1.0 / self.matrix[(o, o)].sqrt();
                        rows.row_mut(row + i).scale_mut(scale);
                    }
                }
            }
            row += present.len();
        }
    }
}

/// L of S = L·Lᵀ and ln det S; an error when S is not positive definite.
pub(crate) fn lower_root(covariance: DMatrixView<'_, f64>) -> Result<(DMatrix<f64>, f64)> {
    let root = covariance
        .clone_owned()
        .cholesky()
        .ok_or_else(|| Error::Numerical {
            reason: "an innovation covariance is not positive definite".into(),
        })?
        .unpack();
    let log_det = 2.0 * root.diagonal().iter().map(|d| d.ln()).sum::<f64>();
    Ok((root, log_det))
}

/// R's diagonal and, where it is full, the whole R.
pub(crate) type Relaxed = (DVector<f64>, Option<InnovationCovariance>);
