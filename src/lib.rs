//! aeroid: a simulation-based validation harness for aircraft aerodynamic
//! parameter estimators. See README.md for the data flow.

pub mod aero;
pub mod aircraft;
pub mod atmosphere;
pub mod catalog;
pub mod check;
pub mod derived;
pub mod dual;
pub mod dynamics;
pub mod engine;
pub mod error;
pub mod estimation;
pub mod gate;
pub mod identifiability;
pub mod import;
pub mod inputs;
pub mod integrator;
#[cfg(feature = "jsbsim")]
pub mod jsbsim;
pub mod linearize;
pub mod modal_fit;
pub mod params;
pub mod pipeline;
pub mod random;
pub mod record;
pub mod recorder;
pub mod scenario;
pub mod sim;
#[macro_use]
mod simd;
pub mod state;
pub mod study;
pub mod trace;
pub mod trim;
pub mod truth;
pub mod units;
pub mod wind;

pub use error::{Error, Result};
