//! The numerical cores every estimator shares: one Gauss–Newton /
//! Levenberg–Marquardt solver and ordinary least squares with its error
//! bounds.

pub mod extended_kalman;
pub mod unscented_kalman;
