//! The value of each output a driven model compares with the record
//! ([`Observable`], declared with the structure: a flight-path state, a
//! load factor n = f/g (nz positive up), an angular acceleration, Mach, q̄
//! or an aerodynamic coefficient), read from the simulator's evaluation,
//! and how each unknown θ_j enters the model ([`Column`]: the columns of
//! S = ∂x/∂θ and of ∂y/∂θ).

use super::FLIGHT_PATH_SIZE;
use crate::structure::Observable;
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::dual::Real;
use aeroid_sim::dynamics::Evaluation;
use nalgebra::SVector;

impl Observable {
    /// The output's value at a state and its evaluation.
    pub fn value<T: Real>(self, x: &SVector<T, FLIGHT_PATH_SIZE>, evaluation: &Evaluation<T>) -> T {
        let c = &evaluation.coefficients;
        match self {
            Observable::State(i) => x[i],
            Observable::LoadFactor(2) => -evaluation.specific_force.z / STANDARD_GRAVITY,
            Observable::LoadFactor(i) => evaluation.specific_force[i] / STANDARD_GRAVITY,
            Observable::AngularAcceleration(i) => evaluation.angular_acceleration[i],
            Observable::Mach => evaluation.air_data.mach,
            Observable::DynamicPressure => evaluation.air_data.dynamic_pressure,
            Observable::Force(i) => c.force[i],
            Observable::Lift => c.lift,
            Observable::Drag => c.drag,
            Observable::Moment(i) => c.moment[i],
        }
    }
}

/// How one unknown θ_j of a simulation with sensitivities enters the model
/// (the columns of S = ∂x/∂θ and of ∂y/∂θ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Column {
    /// A parameter `{coefficient}_{term}` (index into the aerodynamic
    /// parameters), linear in the coefficient: ∂f/∂θ = ∂f/∂C·regressor.
    Term(usize),
    /// A parameter entering nonlinearly (`e`, the stall parameters).
    Nonlinear(usize),
    /// The initial value of an integrated state (index into x): S(0) = unit column.
    Initial(usize),
    /// Enters no equation (an output bias).
    Unused,
}
