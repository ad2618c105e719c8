//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators. See README.md for the data flow.

pub mod atmosphere;
pub mod error;
pub mod random;
pub mod state;
pub mod units;
pub mod wind;

pub use error::{Error, Result};
