//! The smoother of estimation before modelling and the regression of its
//! histories, which `ebm` and the RBF Δ-method share: the aerodynamic
//! coefficients as third-order Gauss–Markov states of an extended Kalman
//! filter, smoothed by the modified Bryson–Frazier smoother (Wang et al.
//! 2012, "Aerodynamic modeling and parameter estimation from QAR data of
//! an airplane approaching a high-altitude airport", Chinese J.
//! Aeronautics 25, §3.2, Eqs. 7–24; Bierman 1974, 1977), then regressed
//! on the structure's terms ([`super::regression`]; Klein & Morelli 2006,
//! ch. 5).
//!
//! By concern: `settings` (the `[methods.ebm]` table), `inputs` (the
//! record's channels), `smoothed` (the histories), `smoother` (the filter
//! and the smoother), `regression` (the coefficients and their regression).

mod inputs;
mod regression;
mod settings;
mod smoothed;
mod smoother;
#[cfg(test)]
mod tests;

pub(crate) use regression::regression_data;
pub use regression::smooth_and_regress;
pub(crate) use settings::SETTINGS;
pub use settings::SmoothedRegressionSettings;
pub use smoothed::Smoothed;
pub use smoother::{GaussMarkov, SmootherSetup, smooth};

/// The method name the smoother's settings and refusals carry: estimation
/// before modelling's.
pub const METHOD: &str = "ebm";
