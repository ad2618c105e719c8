//! The foundation every aeroid crate stands on: the library's errors and
//! refusals, the data folders and the paths inside them, units, limits on
//! what a file may ask for, the seeded random streams and CSV tables.

pub mod atomic;
pub mod catalog;
pub mod csv_table;
pub mod error;
pub mod limits;
pub mod paths;
pub mod random;
pub mod refusal;
pub mod units;

pub use error::{Error, Result};
