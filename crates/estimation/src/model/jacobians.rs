//! The Jacobians of a state-space model at one point (t, x, θ):
//! ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ of ẋ = f(t, x, u, θ), y = h(t, x, u, θ)
//! (Jategaonkar, "Flight Vehicle System Identification", §4.6: what the
//! sensitivity equations integrate and an extended Kalman filter
//! linearises). The models compute them ([`super::driven`],
//! [`super::linear`], ...); [`super::state_space::StateSpaceModel`] hands
//! them out; the shape every sensitivity step checks is here too.

use crate::error::{Error, Result};
use nalgebra::DMatrix;

/// The Jacobians of a state-space model at one point (t, x, θ).
#[derive(Debug, Clone, PartialEq)]
pub struct Jacobians {
    /// ∂f/∂x (states × states).
    pub rates_by_state: DMatrix<f64>,
    /// ∂f/∂θ (states × parameters).
    pub rates_by_parameter: DMatrix<f64>,
    /// ∂h/∂x (outputs × states).
    pub outputs_by_state: DMatrix<f64>,
    /// ∂h/∂θ (outputs × parameters).
    pub outputs_by_parameter: DMatrix<f64>,
}

impl Jacobians {
    /// Four empty matrices: buffers for
    /// [`StateSpaceModel::jacobians_into`](super::state_space::StateSpaceModel::jacobians_into) to grow.
    pub fn empty() -> Jacobians {
        Jacobians {
            rates_by_state: DMatrix::zeros(0, 0),
            rates_by_parameter: DMatrix::zeros(0, 0),
            outputs_by_state: DMatrix::zeros(0, 0),
            outputs_by_parameter: DMatrix::zeros(0, 0),
        }
    }
}

/// An error unless `sensitivity` is n × (one column per unknown) and every
/// unknown that is a parameter indexes one of `parameters`.
pub(crate) fn check_sensitivity_shape(
    sensitivity: &DMatrix<f64>,
    n: usize,
    columns: &[Option<usize>],
    parameters: usize,
) -> Result<()> {
    let m = columns.len();
    if sensitivity.shape() != (n, m) || columns.iter().flatten().any(|&p| p >= parameters) {
        return Err(Error::Shape {
            reason: format!(
                "the sensitivities are {:?} for {n} states and {m} unknowns",
                sensitivity.shape()
            ),
        });
    }
    Ok(())
}
