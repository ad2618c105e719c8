//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators. See README.md for the data flow.

pub mod atmosphere;
pub mod error;
pub mod inputs;
pub mod random;
pub mod state;
pub mod units;

pub use error::{Error, Result};
