//! The estimators, one file each.

pub mod equation_error;
pub mod output_error;
pub mod stepwise;
