//! Evaluating estimators: scoring an estimate against the truth, the whole
//! harness on one scenario (`run`), the accuracy gates and Monte Carlo
//! studies.
//!
//! # Example
//!
//! Run equation error, then output error from its estimate, on one noisy
//! record, and score both against the truth ([`run::estimate_each`];
//! [`run::run`] does the same for every registered method on every model
//! a scenario names):
//!
//! ```
//! use aeroid_estimation::{registry::Registry, structure::Structure};
//! use aeroid_eval::run::{Outcome, estimate_each};
//! use aeroid_record::recorder::{Profile, record_scenario};
//! use aeroid_sim::scenario::Scenario;
//!
//! let scenario = Scenario::load("attas-elevator-3211")?;
//! let profile = Profile::load("flight-test-25hz", None)?;
//! let (record, truth) = record_scenario(&scenario, &profile)?;
//! let structure = Structure::load("attas-longitudinal")?;
//! let methods = ["ee".to_string(), "oem".to_string()];
//! let outcomes = estimate_each(&Registry::built_in(), &methods, &record, &truth, &structure, &[]);
//!
//! // How many of the 10 coefficients have their truth inside the 95 %
//! // interval: all for output error; equation error, biased by the noise
//! // in its regressors, misses some.
//! let covered: Vec<usize> = outcomes
//!     .iter()
//!     .map(|(_, outcome)| match outcome {
//!         Outcome::Estimated { scores, .. } => {
//!             scores.iter().filter(|s| s.inside_95 == Some(true)).count()
//!         }
//!         _ => 0,
//!     })
//!     .collect();
//! assert!(covered[0] < 10);
//! assert_eq!(covered[1], 10);
//! # Ok::<(), aeroid_eval::Error>(())
//! ```

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
