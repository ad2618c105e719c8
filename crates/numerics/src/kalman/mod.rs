//! The Kalman-filtering core every filter method shares: discretisation,
//! time and measurement updates, the steady-state gain, the
//! Rauch–Tung–Striebel and modified Bryson–Frazier smoothers, and sigma
//! points. Methods hold the model (`aeroid_estimation::model`); this
//! module holds only the linear algebra, one concern a file, each child
//! importing only the ones listed before it:
//!
//! - `dense`: shapes kept in their storage, symmetric parts, small
//!   products, the register-blocked column sums;
//! - `exp`: the matrix exponential (Moler & Van Loan);
//! - `sparse`: a matrix by its non-zeros, [`SparseRows`];
//! - `discretise`: Φ, Γ and Q_d over a step (Van Loan);
//! - `predict`: the time update P⁻ = Φ·P⁺·Φᵀ + Q_d;
//! - `update`: the measurement update (Joseph's form, by S's Cholesky
//!   root; sequential scalar updates after Bierman) and the estimates a
//!   pass keeps ([`Gaussian`], [`Measured`]);
//! - `riccati`: the steady-state gain (structured doubling);
//! - [`kept`]: a pass's buffers, kept between passes on a thread;
//! - `smoother`: the RTS and modified Bryson–Frazier smoothers;
//! - `sigma`: the scaled unscented transform's sigma points;
//! - `residual`: Mehra's residual correlations and a whiteness test.

mod dense;
mod discretise;
mod exp;
pub mod kept;
mod predict;
mod residual;
mod riccati;
mod sigma;
mod smoother;
mod sparse;
#[cfg(test)]
mod testing;
mod update;

pub use dense::{multiply, resize, resize_vector, symmetrise};
pub use discretise::{Discrete, ProcessNoise, discretise, discretise_first_order_hold};
pub use exp::{Exponential, exponential};
pub use predict::{predict_covariance, predict_covariance_from};
pub use residual::{ResidualCorrelation, residual_correlation, whiteness};
pub use riccati::{SteadyState, steady_state, steady_state_for_innovation};
pub use sigma::{SigmaPoints, Unscented};
pub use smoother::{
    SmootherScratch, SmootherUpdates, Transitions, mbf_smooth, mbf_smooth_variances, rts_smooth,
};
pub use sparse::SparseRows;
pub use update::{
    Gaussian, Measured, SequentialWorkspace, Update, UpdateWorkspace, sequential_update_with,
    update, update_from,
};
