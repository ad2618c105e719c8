//! The postulated model as estimators simulate and filter it: driven by
//! the record's inputs and pseudo-controls ([`driven`]: the whole-trajectory
//! simulation with sensitivities to its parameters), and as a state-space
//! system ẋ = f(t, x, u, θ), y = h(t, x, u, θ) with its Jacobians and one
//! integration step from any state ([`state_space`]), the view every method
//! that simulates or filters shares; how each recorded input is taken
//! between its samples ([`crate::input_timing`]).

pub mod augmented;
pub mod coefficient_states;
pub mod driven;
pub mod jacobians;
pub mod linear;
pub mod modes;
pub mod observations;
pub mod points;
pub mod state_space;
pub mod transfer;
