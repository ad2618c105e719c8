//! The estimators, one file each, and the one registry that lists them.
//! Adding a method is one file implementing
//! [`crate::estimation::estimator::Estimator`] and one line in
//! `built_in`; the command line, `run`, `gate` and `study`
//! find methods only here. A program embedding aeroid (or a test) adds its
//! own with [`register`].

pub mod augmented_ekf;
pub mod elm_gauss_newton;
pub mod equation_error;
pub mod filter_error;
pub mod frequency_output_error;
pub mod frequency_regression;
pub mod linear_equation_error;
pub mod neural_gauss_newton;
pub mod output_error;
pub mod rbf_delta;
pub mod recurrent_elm;
pub mod smoothed_regression;
pub mod stepwise;
pub mod unscented;

use crate::error::{Error, Result};
use crate::estimation::estimate::Estimate;
use crate::estimation::estimator::Estimator;
use crate::estimation::problem::EstimationProblem;
use std::sync::{Arc, OnceLock, RwLock};

/// The built-in estimators, in the order `aeroid run` runs them.
fn built_in() -> Vec<Arc<dyn Estimator>> {
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

/// The registry: the built-in estimators, the plug-ins found in the
/// plug-in folders ([`crate::estimation::plugin::discover`]; one named like
/// an earlier method is left out, with a problem), then those registered
/// at run time.
fn registry() -> &'static RwLock<Vec<Arc<dyn Estimator>>> {
    static REGISTRY: OnceLock<RwLock<Vec<Arc<dyn Estimator>>>> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut estimators = built_in();
        let (plugins, mut problems) = crate::estimation::plugin::discover();
        for plugin in plugins {
            if estimators.iter().any(|e| e.name() == plugin.name()) {
                problems.push(Error::Other(format!(
                    "{}: a method named '{}' exists already; the plug-in is left out",
                    plugin.path().display(),
                    plugin.name()
                )));
            } else {
                estimators.push(Arc::new(plugin));
            }
        }
        let _ = PLUGIN_PROBLEMS.set(problems.iter().map(ToString::to_string).collect());
        RwLock::new(estimators)
    })
}

/// Plug-in files that could not be loaded, each with its reason.
static PLUGIN_PROBLEMS: OnceLock<Vec<String>> = OnceLock::new();

/// The plug-in files left out of the registry, and why.
pub fn plugin_problems() -> Vec<String> {
    let _ = registry();
    PLUGIN_PROBLEMS.get().cloned().unwrap_or_default()
}

/// Every estimator, in registry order.
pub fn all() -> Vec<Arc<dyn Estimator>> {
    registry()
        .read()
        .map(|r| r.clone())
        .unwrap_or_else(|poisoned| poisoned.into_inner().clone())
}

/// Every estimator's name, in registry order.
pub fn names() -> Vec<String> {
    all().iter().map(|e| e.name().to_string()).collect()
}

/// The estimator named `name`.
pub fn find(name: &str) -> Result<Arc<dyn Estimator>> {
    all()
        .into_iter()
        .find(|e| e.name() == name)
        .ok_or_else(|| Error::Unknown {
            kind: "method",
            name: name.to_string(),
            known: names(),
        })
}

/// Adds an estimator to the registry; its name must be new.
pub fn register(estimator: Arc<dyn Estimator>) -> Result<()> {
    let name = estimator.name();
    let mut registry = registry()
        .write()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if registry.iter().any(|e| e.name() == name) {
        return Err(Error::Other(format!(
            "an estimator named '{name}' is registered already"
        )));
    }
    registry.push(estimator);
    Ok(())
}

/// Runs the problem's method and judges its result honestly
/// ([`Estimate::assess`]): an estimate with unidentified parameters, a
/// degenerate covariance, no progress or a fit worse than the mean is not
/// "converged", whichever method made it.
pub fn estimate(problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate> {
    let estimator = find(&problem.method)?;
    let mut estimate = estimator.estimate(problem, start)?;
    for note in problem.notes() {
        if !estimate.notes.contains(&note) {
            estimate.notes.push(note);
        }
    }
    Ok(estimate.assess())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::estimator::Settings;

    /// Every registered method is described (paper, equations, needs),
    /// every setting it describes is accepted at its stated default, and a
    /// key it does not have is refused with the key named.
    #[test]
    fn every_method_describes_its_settings_truthfully() {
        let names = names();
        for estimator in all() {
            let (name, info) = (estimator.name(), estimator.info());
            assert_eq!(names.iter().filter(|n| **n == name).count(), 1);
            assert!(!info.paper.is_empty() && !info.equations.is_empty() && !info.needs.is_empty());
            let mut defaults = Settings::new();
            for setting in info.settings.iter().filter(|s| s.default != "(none)") {
                let table: toml::Table = toml::from_str(&format!("value = {}", setting.default))
                    .unwrap_or_else(|e| panic!("{name} {}: {e}", setting.name));
                defaults.insert(
                    setting.name.to_string(),
                    serde_json::to_value(&table["value"]).unwrap(),
                );
            }
            estimator
                .check_settings(&defaults)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let mut unknown = Settings::new();
            unknown.insert("no_such_setting".into(), serde_json::Value::from(1));
            let error = estimator.check_settings(&unknown).unwrap_err().to_string();
            assert!(error.contains("no_such_setting"), "{name}: {error}");
        }
    }

    /// The registry resolves names and refuses an unknown one with the list.
    #[test]
    fn unknown_method_names_the_known_ones() {
        let error = find("no-such-method").err().unwrap().to_string();
        assert!(error.contains("ee") && error.contains("oem"), "{error}");
    }
}
