//! Simulation of a postulated model driven by a flight record, in
//! flight-path coordinates x = [V, α, β, p, q, r, φ, θ, ψ, h, χ] (named as
//! record channels). A chosen subset of x is integrated; the others are
//! measured pseudo-controls read from the record at every stage — the
//! decoupled longitudinal and lateral-directional models of the reflex-wing UAV paper
//! (Eqs. 1–8) are the subsets {V, α, q, θ} and {β, p, r, φ}; the full
//! 6-DOF integrates them all. The equations are the simulator's own
//! ([`FlightModel::evaluate_kinematics`](aeroid_sim::dynamics::FlightModel::evaluate_kinematics),
//! no wind: estimation models the air-relative motion, so air data are
//! V, α, β themselves and the attitude is the Euler angles' rotation),
//! converted to flight-path rates:
//! `V̇ = V·V̇_b/V`, α̇ and β̇ from the state derivative,
//! `φ̇ = p + tan θ·(q sin φ + r cos φ)`, `θ̇ = q cos φ − r sin φ`,
//! `ψ̇ = (q sin φ + r cos φ)/cos θ`, `ḣ = −ḋ`.
//! The air is the ISA's at the altitude, with the density the record's
//! `density` channel when it has one; the thrust is the record's `thrust`
//! channel (N, along the thrust line) when it has one, else the throttle
//! and engine model ([`Ambient`]).
//! Controls and pseudo-controls are sampled on the integration grid and
//! taken inside a step through the one RK4 integrator: each control held
//! or linear as the `interpolation` setting chooses for it
//! ([`crate::input_timing`]: by default from its samples), the measured
//! pseudo-controls linear. Each step is a function of its start state
//! alone (`DrivenSimulation::step_from`, the caches restarted at every
//! grid point), the step of the state-space view
//! ([`super::state_space::DrivenStateSpace`]) that filters propagate with.
//!
//! By concern: `observables` (the outputs and the unknowns' columns),
//! `measured` (what the record measures in place of the model),
//! `kinematics` (the flight-path rates, over f64 and dual numbers),
//! `memo` (the angles and air kept between evaluations), `directions`
//! and `linearise` (∂f/∂x, ∂f/∂θ, ∂g/∂x, ∂g/∂θ), `simulation` (the
//! integration and its sensitivity equations) and `record` (the grid
//! sampled from a flight record).

mod directions;
mod kinematics;
mod linearise;
mod measured;
mod memo;
mod observables;
mod record;
mod simulation;
#[cfg(test)]
mod tests;

pub use crate::structure::Observable;
pub use kinematics::PseudoRates;
pub(super) use linearise::{LinearisationBuffers, evaluate, evaluate_into, linearise_with};
pub use measured::{ALTITUDE_SUBSTITUTES, Ambient, MEASURED_QUANTITIES};
pub(super) use memo::PointMemo;
pub use observables::Column;
pub(super) use simulation::check_departure;
pub use simulation::{DrivenSimulation, Linearise};

use nalgebra::SVector;

pub const FLIGHT_PATH_SIZE: usize = 11;
/// A flight-path state x = [V, α, β, p, q, r, φ, θ, ψ, h, χ] (SI, angles in rad).
pub(crate) type FlightPathState = SVector<f64, FLIGHT_PATH_SIZE>;

pub(super) const AIRSPEED: usize = 0;
const ALPHA: usize = 1;
pub(super) const BETA: usize = 2;
const P: usize = 3;
const ROLL: usize = 6;
const PITCH: usize = 7;
const ALTITUDE: usize = 9;
const CHI: usize = 10;
