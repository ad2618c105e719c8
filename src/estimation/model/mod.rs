//! The postulated model as estimators simulate it: driven by the record's
//! inputs and pseudo-controls, with sensitivities to its parameters.

pub mod driven;
pub mod state_space;
