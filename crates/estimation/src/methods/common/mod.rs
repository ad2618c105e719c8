//! What several methods share, each module under its own name: a method
//! file imports from here and from the rest of the crate, never from a
//! sibling method (tests/house_rules.rs checks).

pub mod augmented_filter;
pub mod coefficient_fit;
pub mod elm_fit;
pub mod filter_fit;
pub mod frequency_band;
pub mod iterations;
pub mod linear_data;
pub mod linear_regression;
pub mod refusals;
pub mod regression;
pub mod smoothing;
