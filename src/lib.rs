//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators.
//!
//! The crates follow the data flow, each importing only those before it:
//! `aeroid-core` (errors, refusals, data folders, units), `aeroid-numerics`
//! (dual numbers, solvers, Kalman kernels), `aeroid-sim` flies a scenario
//! and gives its truth, `aeroid-record` turns the truth into what a recorder
//! stores (or imports real data) and prepares recorded channels,
//! `aeroid-estimation` fits postulated models to a record, `aeroid-eval`
//! scores estimates against the truth (runs, gates, studies, reports),
//! `aeroid-analysis` linearises and finds what is identifiable, and
//! `aeroid-jsbsim` (feature `jsbsim`) flies JSBSim's aircraft. This crate
//! re-exports them under one name and holds the `aeroid` command line.

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
