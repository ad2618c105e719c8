//! The exact sensitivities of the linear model's discrete step: with
//! x_{k+1} = Φ·x_k + Γ₀·(u_k, 1) + Γ₁·W·(u_{k+1} − u_k) (module
//! [`super`]), the derivative by a parameter θ_p is
//!
//!   S_{k+1} = Φ·S_k + ∂Φ/∂θ_p·x_k + ∂Γ₀/∂θ_p·(u_k, 1) + ∂Γ₁/∂θ_p·W·(u_{k+1} − u_k),
//!
//! and Φ, Γ₀, Γ₁ are blocks of one exponential e^M of
//! M = [[A·h, [B b]·h, 0], [0, 0, [I; 0]], [0, 0, 0]] (Van Loan, "Computing
//! integrals involving the matrix exponential", IEEE TAC 23, 1978; the
//! last block column only where an input is taken linearly). Their
//! derivatives are the same blocks of ∂e^M/∂θ_p, the upper-right block of
//! exp([[M, ∂M/∂θ_p], [0, M]]) (Van Loan 1978, Theorem 1; Najfeld & Havel,
//! "Derivatives of the matrix exponential and their computation", Adv.
//! Appl. Math. 16, 1995, Eq. 10): exact to rounding, one exponential of
//! twice M's size per parameter that enters the step, computed once per θ.
//! A parameter of C, D or c only does not move the state: its column of S
//! stays Φ·S.

use super::{Cache, LinearStateSpace, Matrix};
use crate::error::Result;
use aeroid_numerics::kalman::exponential;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// ∂Φ/∂θ_p, ∂Γ₀/∂θ_p (of [B b]) and ∂Γ₁/∂θ_p·W for one parameter.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct StepDerivative {
    transition: DMatrix<f64>,
    input: DMatrix<f64>,
    ramp: Option<DMatrix<f64>>,
}

/// Each parameter's [`StepDerivative`]; None for one that enters only the
/// outputs.
pub(super) type StepDerivatives = Vec<Option<StepDerivative>>;

/// The derivatives of the last θ they were computed for.
pub(super) type DerivativeCache = Cache<StepDerivatives>;

impl LinearStateSpace {
    /// The step's derivatives by every parameter at θ, from the cache when
    /// θ is the last one's.
    pub(super) fn step_derivatives(&self, theta: &[f64]) -> Result<Arc<StepDerivatives>> {
        if let Some(cached) = self.derivatives.get(theta) {
            return Ok(cached);
        }
        let matrices = self.matrices(theta)?;
        let (n, m) = matrices.b.shape();
        let ramp = self
            .holds
            .contains(&aeroid_sim::integrator::Interpolation::Linear);
        let size = n + m + 1 + if ramp { m } else { 0 };
        let h = self.step;
        let mut block = DMatrix::zeros(size, size);
        block.view_mut((0, 0), (n, n)).copy_from(&(&matrices.a * h));
        block.view_mut((0, n), (n, m)).copy_from(&(&matrices.b * h));
        block
            .view_mut((0, n + m), (n, 1))
            .copy_from(&(&matrices.state_bias * h));
        if ramp {
            block
                .view_mut((n, n + m + 1), (m, m))
                .copy_from(&DMatrix::identity(m, m));
        }
        let weights = DMatrix::from_diagonal(&self.weights(1.0));
        let derivatives: StepDerivatives = (self.parameters.iter())
            .map(|entries| {
                let mut slope = DMatrix::zeros(size, size);
                for entry in entries {
                    match entry.matrix {
                        Matrix::A => slope[(entry.row, entry.column)] += h,
                        Matrix::B => slope[(entry.row, n + entry.column)] += h,
                        Matrix::StateBias => slope[(entry.row, n + m)] += h,
                        Matrix::C | Matrix::D | Matrix::OutputBias => {}
                    }
                }
                if slope.iter().all(|v| *v == 0.0) {
                    return None;
                }
                let mut doubled = DMatrix::zeros(2 * size, 2 * size);
                doubled.view_mut((0, 0), (size, size)).copy_from(&block);
                doubled
                    .view_mut((size, size), (size, size))
                    .copy_from(&block);
                doubled.view_mut((0, size), (size, size)).copy_from(&slope);
                let derivative = exponential(&doubled)
                    .view((0, size), (n, size))
                    .into_owned();
                Some(StepDerivative {
                    transition: derivative.columns(0, n).into_owned(),
                    input: derivative.columns(n, m + 1).into_owned(),
                    ramp: ramp.then(|| derivative.columns(n + m + 1, m) * &weights),
                })
            })
            .collect();
        Ok(self.derivatives.put(theta, derivatives))
    }

    /// S ← Φ·S + ∂(step)/∂u (module documentation), the unknowns `columns`
    /// (a parameter each, or None for one that does not enter the step).
    pub(super) fn propagate_sensitivity(
        &self,
        k: usize,
        x: &[f64],
        theta: &[f64],
        columns: &[Option<usize>],
        sensitivity: &mut DMatrix<f64>,
    ) -> Result<()> {
        let discrete = self.discrete(theta)?;
        let derivatives = self.step_derivatives(theta)?;
        let u = &self.inputs[k];
        let driven = DVector::from_iterator(u.len() + 1, u.iter().copied().chain([1.0]));
        let change = &self.inputs[k + 1] - u;
        let state = DVector::from_column_slice(x);
        let mut next = &discrete.transition * &*sensitivity;
        for (j, column) in columns.iter().enumerate() {
            let Some(derivative) = column.and_then(|p| derivatives[p].as_ref()) else {
                continue;
            };
            let mut column = next.column_mut(j);
            column.gemv(1.0, &derivative.transition, &state, 1.0);
            column.gemv(1.0, &derivative.input, &driven, 1.0);
            if let Some(ramp) = &derivative.ramp {
                column.gemv(1.0, ramp, &change, 1.0);
            }
        }
        *sensitivity = next;
        Ok(())
    }
}
