//! The outputs a driven model compares with the record ([`Observable`]:
//! a flight-path state, a load factor n = f/g (nz positive up), an angular
//! acceleration, Mach, q̄ or an aerodynamic coefficient, each read from the
//! simulator's evaluation) and how each unknown θ_j enters the model
//! ([`Column`]: the columns of S = ∂x/∂θ and of ∂y/∂θ).

use super::FLIGHT_PATH_SIZE;
use crate::structure::FLIGHT_PATH_STATES;
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::dual::Real;
use aeroid_sim::dynamics::Evaluation;
use nalgebra::SVector;

/// A model output, resolved once from its record channel name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observable {
    /// A flight-path state (index into x).
    State(usize),
    /// Load factors nx, ny, nz (specific force / g; nz positive up).
    LoadFactor(usize),
    /// ṗ, q̇, ṙ.
    AngularAcceleration(usize),
    Mach,
    DynamicPressure,
    /// CX, CY, CZ.
    Force(usize),
    Lift,
    Drag,
    /// Cl, Cm, Cn.
    Moment(usize),
}

impl Observable {
    /// The outputs other than the flight-path states, by record channel name.
    const NAMED: [(&'static str, Observable); 16] = [
        ("nx", Observable::LoadFactor(0)),
        ("ny", Observable::LoadFactor(1)),
        ("nz", Observable::LoadFactor(2)),
        ("p_dot", Observable::AngularAcceleration(0)),
        ("q_dot", Observable::AngularAcceleration(1)),
        ("r_dot", Observable::AngularAcceleration(2)),
        ("mach", Observable::Mach),
        ("dynamic_pressure", Observable::DynamicPressure),
        ("CX", Observable::Force(0)),
        ("CY", Observable::Force(1)),
        ("CZ", Observable::Force(2)),
        ("CL", Observable::Lift),
        ("CD", Observable::Drag),
        ("Cl", Observable::Moment(0)),
        ("Cm", Observable::Moment(1)),
        ("Cn", Observable::Moment(2)),
    ];

    /// The output a record channel name stands for; None when the model has no such output.
    pub fn parse(name: &str) -> Option<Observable> {
        if let Some(i) = FLIGHT_PATH_STATES.iter().position(|s| *s == name) {
            return Some(Observable::State(i));
        }
        Observable::NAMED
            .iter()
            .find(|(named, _)| *named == name)
            .map(|(_, observable)| *observable)
    }

    /// Every output name a model structure may compare.
    pub fn names() -> impl Iterator<Item = &'static str> {
        FLIGHT_PATH_STATES
            .iter()
            .copied()
            .chain(Observable::NAMED.iter().map(|(name, _)| *name))
    }

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
