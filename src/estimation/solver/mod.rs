//! The numerical cores every estimator shares: one Gauss–Newton /
//! Levenberg–Marquardt solver and ordinary least squares with its error
//! bounds.

pub mod extended_kalman;
pub mod fourier;
pub mod gauss_newton;
pub mod kalman;
pub mod kept;
pub mod regression;
pub mod unscented_kalman;
