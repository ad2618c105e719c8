//! Parameter estimation: the shared Gauss–Newton / Levenberg–Marquardt core,
//! the postulated model structure, the estimators and what they return.
//!
//! The regression estimators (equation error, stepwise regression) share the
//! coefficient reconstruction (`reconstruction`, with `differentiation`) and
//! the least-squares solution with its error bounds (`regression`).

pub mod compatibility;
pub mod differentiation;
pub mod driven;
pub mod equation_error;
pub mod estimate;
pub mod gauss_newton;
pub mod output_error;
pub mod reconstruction;
pub mod regression;
pub mod score;
pub mod stepwise;
pub mod structure;
