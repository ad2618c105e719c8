//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators. The crates follow the data flow, each importing
//! only those before it: core (errors, units), numerics, sim (flies a
//! scenario and gives its truth), record (what a recorder stores, and
//! preparation), estimation, eval (scores, gates, studies), analysis
//! (linearisation, identifiability) and, with feature `jsbsim`, jsbsim.
//! This crate re-exports them and holds the `aeroid` command line.
//!
//! # Example
//!
//! Fly the bundled ATTAS elevator 3-2-1-1, record it at 25 Hz with sensor
//! noise, fit the longitudinal model by output error and score it:
//!
//! ```
//! use aeroid::estimation::{estimate::Status, registry::Registry, structure::Structure};
//! use aeroid::eval::score;
//! use aeroid::record::recorder::{Profile, record_scenario};
//! use aeroid::sim::scenario::Scenario;
//!
//! // Simulate and record: the record, and the true parameters of the flight.
//! let scenario = Scenario::load("attas-elevator-3211")?;
//! let profile = Profile::load("flight-test-25hz", None)?;
//! let (record, truth) = record_scenario(&scenario, &profile)?;
//!
//! // Estimate with a method of the registry.
//! let registry = Registry::built_in();
//! let structure = Structure::load("attas-longitudinal")?;
//! let problem = registry.problem("oem", vec![record], structure.clone(), &[])?;
//! let estimate = registry.estimate(&problem, None)?;
//! assert_eq!(estimate.status, Status::Converged);
//!
//! // Score: every coefficient within 4 standard errors of the truth (the
//! // initial states estimated beside them have no truth).
//! let scores = score::score(&estimate, Some(&truth), structure.score_kind());
//! println!("{}", score::table(&scores));
//! for row in scores.iter().filter(|row| row.truth.is_some()) {
//!     assert!(row.error_sigma.unwrap().abs() < 4.0, "{}", row.name);
//! }
//! # Ok::<(), aeroid::Error>(())
//! ```

pub mod check;
pub mod error;

pub use aeroid_analysis as analysis;
pub use aeroid_core::{catalog, limits, paths, random, refusal, units};
pub use aeroid_estimation as estimation;
pub use aeroid_eval as eval;
#[cfg(feature = "jsbsim")]
pub use aeroid_jsbsim as jsbsim;
pub use aeroid_numerics as numerics;
pub use aeroid_numerics::dual;
pub use aeroid_record as record;
pub use aeroid_record::prep;
pub use aeroid_sim as sim;
pub use error::{Error, Result};
