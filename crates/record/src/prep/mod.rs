//! Preparing a record for estimation: smoothing numerical differentiation
//! of recorded channels, geometric angle of attack and sideslip, angular rates from the attitude
//! kinematics, combined control surfaces from split ones, air density
//! from pressure altitude and temperature, and thrust from fuel flow.

pub mod air_data;
pub mod angular_rates;
pub mod derive;
pub mod differentiation;
pub mod flow_angles;
pub mod surfaces;
pub mod thrust;
