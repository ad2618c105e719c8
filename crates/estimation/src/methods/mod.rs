//! The estimators, one file each. Adding a method is one file implementing
//! the typed [`crate::estimator::Method`] (every `Method` is an
//! [`crate::estimator::Estimator`]) and one line in [`built_in`]; the command
//! line, `run`, `gate` and `study` find methods through a
//! [`crate::registry::Registry`], to which a program embedding aeroid (or a
//! test) adds its own.

pub mod augmented_ekf;
pub mod common;
pub mod elm_gauss_newton;
pub mod equation_error;
pub mod filter_error;
pub mod frequency_output_error;
pub mod frequency_regression;
pub mod neural_gauss_newton;
pub mod output_error;
pub mod rbf_delta;
pub(crate) mod recurrent_elm;
pub mod smoothed_regression;
pub mod stepwise;
pub mod unscented;

use crate::estimator::Estimator;
use std::sync::Arc;

/// The built-in estimators, in the order `aeroid run` runs them.
pub fn built_in() -> Vec<Arc<dyn Estimator>> {
    vec![
        Arc::new(equation_error::EquationError),
        Arc::new(stepwise::StepwiseRegression),
        Arc::new(output_error::OutputError),
        Arc::new(smoothed_regression::SmoothedRegression),
        Arc::new(filter_error::FilterError),
        Arc::new(augmented_ekf::AugmentedEkf),
        Arc::new(unscented::UnscentedFilter),
        Arc::new(frequency_regression::FrequencyRegression),
        Arc::new(frequency_output_error::FrequencyOutputError),
        Arc::new(elm_gauss_newton::ElmGaussNewton),
        Arc::new(recurrent_elm::RecurrentElm),
        Arc::new(neural_gauss_newton::NeuralGaussNewton),
        Arc::new(rbf_delta::RbfDelta),
    ]
}
