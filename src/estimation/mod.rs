//! Parameter estimation: the shared Gauss–Newton / Levenberg–Marquardt core,
//! the postulated model structure, the estimators and what they return.

pub mod driven;
pub mod estimate;
pub mod gauss_newton;
pub mod output_error;
pub mod score;
pub mod structure;
