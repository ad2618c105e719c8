//! The estimators: each method on data whose answer is known (textbook, ideal, noisy, turbulent), their oracles, model terms, statuses and diagnoses, identifiability and the registry.
//!
//! One test binary for the area (each file a module), so that a fresh
//! `cargo test` links a few binaries rather than one per file.

#[path = "../common/mod.rs"]
mod common;

mod augmented_filters;
mod coefficients_from_accelerations;
mod compatibility;
mod elm_gauss_newton;
mod equation_error;
mod filter_error;
mod frame_skew;
mod frequency_domain;
mod gaps;
mod honest_status;
mod identifiability;
mod joint_fit;
mod kalman_oracle;
mod linear_models;
mod linear_textbook;
mod measured_quantities;
mod model_channels;
mod model_terms;
mod multiple_shooting;
mod neural_gauss_newton;
mod output_error;
mod quantised_inputs;
mod rbf_delta;
mod registry;
mod residual_correlation;
mod smoothed_regression;
