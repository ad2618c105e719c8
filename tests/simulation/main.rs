//! The simulator, the recorder and the record: trim and rigid-body dynamics, aerodynamic and stall models, modes, parameter changes, the recorder profiles, record files and their quality, import, derived flow angles and rates, limits and bad input.
//!
//! One test binary for the area (each file a module), so that a fresh
//! `cargo test` links a few binaries rather than one per file.

#[path = "../common/mod.rs"]
mod common;

mod air_data;
mod angular_rates;
mod bad_input;
mod flow_angles;
mod import_formats;
mod import_mat;
mod limits;
mod linear_modes;
mod parameter_changes;
mod record_files;
mod record_quality;
mod recorder;
mod stall_model;
mod trim_and_rigid_body;
