//! Preparing a record for estimation: smoothing numerical differentiation
//! of recorded channels, and flight-path reconstruction (the data
//! compatibility check that estimates sensor biases and scale factors),
//! geometric angle of attack and sideslip.

pub mod compatibility;
pub mod differentiation;
pub mod flow_angles;
