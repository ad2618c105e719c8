//! Analyses of an aircraft before any estimator runs: numerical
//! linearisation and dynamic modes, the eigensystem realisation fit of a
//! response, and a-priori identifiability.

pub mod error;
pub mod identifiability;
pub mod linear_model;
pub mod linearize;
pub mod modal_fit;

pub use error::{Error, Result};
