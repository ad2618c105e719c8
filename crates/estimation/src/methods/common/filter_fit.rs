//! The filter-error fit, maximum likelihood with a Kalman filter in the
//! loop, that filter error runs on 6-DOF and linear structures and output
//! error runs on linear ones (no process noise: the filter is the exact
//! simulation, `linear_fit`). For flights with process noise
//! (turbulence) as well as measurement noise
//! (Maine & Iliff, "Identification of dynamic systems", NASA RP-1138,
//! 1985, ch. 9; Jategaonkar, "Flight Vehicle System Identification", 2nd
//! ed., ch. 5, the equation numbers as his FVSysID programs `gainmat`,
//! `fcompn` and `kcle1` cite them). The user's reference, with what was
//! measured, is docs/methods.md, "Filter error".
//!
//! **System** (Jategaonkar §5.1): ẋ = f(x, u, θ) + F·w,
//! z_k = h(x_k, u_k, θ) + G·v_k, w and v white with unit intensity, F
//! diagonal with one entry per state driven by noise.
//!
//! **Steady gain** (the default, §5.5): x̃_k = step(x̂_{k−1}), ỹ_k = h(x̃_k),
//! x̂_k = x̃_k + K·(z_k − ỹ_k), K = P·Cᵀ·R⁻¹ (Eq. 5.48), R the innovations'
//! covariance, G·Gᵀ = R − C·P·Cᵀ (§5.3); P solves the discrete Riccati
//! equation P = Φ·(P − P·Cᵀ·R⁻¹·C·P)·Φᵀ + Q_d of the model linearised at
//! the first point (Eqs. 5.50–5.51; Jategaonkar solves its continuous
//! first-order form, Eqs. 5.15–5.17) (`passes`).
//!
//! **Cost and relaxation** (§5.3): ½·Σ_k (ν_kᵀR⁻¹ν_k + ln det R); R =
//! (1/N)·Σ ν·νᵀ (Eq. 5.37; full where the outputs share one time base,
//! fitted from the diagonal R's estimate, `stages`), then F compensated
//! (Eq. 5.41, [`LeastSquaresObjective::compensate`]) and one Gauss–Newton step
//! on θ and F with R held ([`gauss_newton`]), subject to diag(K·C) ≤ 1
//! (§5.3, `kcle1`; an active-set quadratic program with second-order
//! corrections, Nocedal & Wright, "Numerical Optimization", §16.5, §18.3:
//! `active_set`). The Jacobian comes from the filter's own sensitivity
//! equations (§5.5), ∂K by central differences (`jacobian`).
//!
//! **Time-varying gain** (`gain = "time_varying"`): the continuous–discrete
//! extended Kalman filter (§7.2, Eqs. 7.11–7.19), S_k = C_k·P̃_k·C_kᵀ + G·Gᵀ;
//! cost ½·Σ_k (ν_kᵀS_k⁻¹ν_k + ln det S_k) (Eq. 5.16), θ, F and G estimated
//! jointly by Fisher scoring, M = Σ_k (∂νᵀS⁻¹∂ν + ½·tr(S⁻¹∂S·S⁻¹∂S)),
//! G² held at a rounding floor on noise-free data (`noise`).
//!
//! **Start** (`starts`): θ from equation error's estimate (the seed paper
//! 002 starts there), R from the simulation's residuals, F from
//! F_ref,i = (Σ_j C_ji²/R_jj)^{−½}/√Δt times the best of 1, 0.3, 0.1, 0.03,
//! 0.01. Cramér–Rao bounds from M = Σ (∂ν/∂θ)ᵀR⁻¹(∂ν/∂θ); convergence at a
//! predicted decrease below 10⁻⁴, as output error.

use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::input_timing::{self};
use crate::linear_structure::LinearStructure;
use crate::methods::common::coefficient_fit::start_estimate;
use crate::methods::common::refusals::enough_data;
use crate::model::observations::Observations;
use crate::model::state_space::{Jacobians, StateSpaceModel};
use crate::solver::extended_kalman::{self, Discretisation, Keep, Noise};
use crate::structure::ModelStructure;
use aeroid_numerics::gauss_newton::{self, LeastSquaresObjective, Options};
use aeroid_numerics::kalman::{self, Gaussian, SteadyState};
use aeroid_record::FlightRecord;
use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::BTreeMap;

/// Convergence: the Gauss–Newton step's predicted decrease of the whitened
/// cost, ½·ΔθᵀMΔθ ≤ 1e-4, a step under 0.014σ (as output error).
pub(crate) const CONVERGED_DECREASE: f64 = 1e-4;

mod active_set;
mod assemble;
mod fit;
mod gain;
mod innovation;
mod jacobian;
mod least_squares;
mod linear_model;
mod noise;
mod passes;
mod stages;
mod starts;

pub(crate) use assemble::*;
pub use fit::*;
pub use gain::*;
pub use innovation::*;
pub(crate) use linear_model::*;
pub(crate) use noise::*;
pub use passes::*;
pub(crate) use starts::*;
