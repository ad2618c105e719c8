//! What several methods share, each module under its own name: a method
//! file imports from here and from the rest of the crate, never from a
//! sibling method (tests/house_rules.rs checks).

/// Equation error's name: the method the iterative methods start from
/// (`coefficient_fit::start_estimate`), by regression of the
/// coefficients (six-degree-of-freedom models) or of the state equations
/// (linear models, `linear_regression`).
pub const EQUATION_ERROR: &str = "ee";

pub mod augmented_filter;
pub(crate) mod coefficient_fit;
pub(crate) mod elm_fit;
pub(crate) mod filter_fit;
pub mod frequency_band;
pub mod iterations;
pub(crate) mod linear_data;
pub(crate) mod linear_regression;
pub mod refusals;
pub mod regression;
pub mod smoothing;
