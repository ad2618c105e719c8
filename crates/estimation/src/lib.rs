//! Parameter estimation: the postulated model structure, the estimation
//! problem, the state-space view of the model, the shared solvers, the
//! estimators (one file each under `methods/`) and what they return.
//!
//! The regression estimators (equation error, stepwise regression) share the
//! coefficient reconstruction (`reconstruction`) and the least-squares
//! solution with its error bounds (`solver::regression`).

pub mod coefficient_channels;
pub mod compatibility;
pub mod diagnosis;
pub mod error;
pub mod estimate;
pub mod estimator;
pub mod fit_quality;
pub mod input_timing;
pub mod linear_structure;
pub mod methods;
pub mod model;
pub mod neural;
pub mod plugin;
pub mod problem;
pub mod reconstruction;
pub mod registry;
pub mod sandbox;
pub mod settings;
pub mod solver;
pub mod structure;

/// Every channel some estimator or the flight-path reconstruction reads
/// (see docs/import.md, "What each estimator reads"). An imported channel
/// not in this list is kept in the record, and the import warns that no
/// estimator uses it.
pub const CHANNELS_READ: &[&str] = &[
    "airspeed",
    "alpha",
    "beta",
    "mach",
    "dynamic_pressure",
    "p",
    "q",
    "r",
    "roll",
    "pitch",
    "yaw",
    "nx",
    "ny",
    "nz",
    "altitude",
    "pressure_altitude",
    "elevator",
    "aileron",
    "rudder",
    "flap",
    "throttle",
    "thrust",
    "density",
    "chi",
];

pub use error::{Error, Result};
