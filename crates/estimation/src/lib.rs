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

/// Every channel an estimator of a 6-DOF model or the flight-path
/// reconstruction reads (see docs/import.md, "What each estimator reads"):
/// the motion, the load factors and angular accelerations, the controls,
/// the measured air data and thrust, and the coefficients a model may take
/// as outputs. An imported channel neither in this list nor read by the
/// derive step is kept in the record with a warning (a linear model may
/// still name it).
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
    "p_dot",
    "q_dot",
    "r_dot",
    "CX",
    "CY",
    "CZ",
    "CL",
    "CD",
    "Cl",
    "Cm",
    "Cn",
];

pub use error::{Error, Result};

#[cfg(test)]
mod tests {
    use super::CHANNELS_READ;
    use crate::{model, structure};

    /// The list holds every channel a model can compare or be driven by:
    /// each output name, each control, each measured quantity and altitude
    /// substitute — so the import never calls one of them unread.
    #[test]
    fn every_channel_a_model_reads_is_listed() {
        let outputs = structure::Observable::names();
        let controls = aeroid_sim::state::Control::ALL.map(|c| c.name());
        let measured = model::driven::MEASURED_QUANTITIES;
        let substitutes = model::driven::ALTITUDE_SUBSTITUTES;
        for name in outputs.chain(controls).chain(measured).chain(substitutes) {
            assert!(CHANNELS_READ.contains(&name), "{name} is not listed");
        }
    }
}
