//! Parameter estimation: the postulated model structure, the estimation
//! problem, the state-space view of the model, the shared solvers, the
//! estimators (one file each under `methods/`) and what they return.
//!
//! The regression estimators (equation error, stepwise regression) share the
//! coefficient reconstruction (`reconstruction`) and the least-squares
//! solution with its error bounds (`solver::regression`).

pub mod estimate;
pub mod estimator;
pub mod methods;
pub mod model;
pub mod plugin;
pub mod problem;
pub mod reconstruction;
pub mod solver;
pub mod structure;
