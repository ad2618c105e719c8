//! Evaluating estimators: scoring an estimate against the truth, the whole
//! harness on one scenario (`run`), the accuracy gates and Monte Carlo
//! studies.

pub mod axis;
pub mod error;
pub mod gate;
pub mod histories;
pub mod journal;
pub mod linear_flight;
pub mod report;
pub mod row;
pub mod run;
pub mod score;
pub mod study;
pub mod summary;

pub use error::{Error, Result};
