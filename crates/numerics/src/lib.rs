//! The numerical kernels the simulator and the estimators share: dual
//! numbers for exact derivatives, the Gauss–Newton / Levenberg–Marquardt
//! solver, least squares with its error bounds, the Kalman filter and
//! smoother kernels, the finite Fourier transform, and the run-time choice
//! of wider vector instructions.

pub mod dual;
pub mod error;
pub mod fourier;
pub mod gauss_newton;
pub mod kalman;
pub mod regression;
pub mod simd;
pub mod status;

pub use kalman::kept;
pub use status::Status;

pub use error::{Error, Result};
