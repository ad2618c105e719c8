//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators.
//!
//! The folders follow the data flow: `sim` flies a scenario and gives its
//! truth, `record` turns the truth into what a recorder stores (or imports
//! real data), `prep` differentiates and reconstructs recorded channels,
//! `estimation` fits postulated models to a record, `eval` scores estimates
//! against the truth (runs, gates, studies), `analysis` linearises and
//! finds what is identifiable. `catalog` owns the data folders.

pub mod analysis;
pub mod catalog;
pub mod check;
pub(crate) mod csv_table;
pub mod dual;
pub mod error;
pub mod estimation;
pub mod eval;
#[cfg(feature = "jsbsim")]
pub mod jsbsim;
pub mod limits;
pub mod paths;
pub mod prep;
pub mod random;
pub mod record;
pub mod refusal;
pub mod sim;
#[macro_use]
mod simd;
pub mod units;

pub use error::{Error, Result};
