//! The estimators, one file each, and the one registry that lists them.
//! Adding a method is one file implementing
//! [`crate::estimator::Estimator`] and one line in
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

use crate::estimate::Estimate;
use crate::estimator::{Estimator, Refusal};
use crate::problem::EstimationProblem;
use crate::structure::{ModelStructure, Structure};
use aeroid_core::error::{Error, Result};
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
/// plug-in folders ([`crate::plugin::discover`]; one named like
/// an earlier method is left out, with a problem), then those registered
/// at run time.
fn registry() -> &'static RwLock<Vec<Arc<dyn Estimator>>> {
    static REGISTRY: OnceLock<RwLock<Vec<Arc<dyn Estimator>>>> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut estimators = built_in();
        let (plugins, mut problems) = crate::plugin::discover();
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
    if let Structure::SixDof(structure) = &problem.structure {
        check_model_features(estimator.as_ref(), structure)?;
    }
    let mut estimate = estimator.estimate(problem, start)?;
    if let Structure::SixDof(structure) = &problem.structure {
        estimate.notes.extend(tied_notes(structure, &estimate));
    }
    for note in problem.notes() {
        if !estimate.notes.contains(&note) {
            estimate.notes.push(note);
        }
    }
    Ok(estimate.assess())
}

/// Refuses a model that uses a feature the method does not fit (tied
/// parameters, a moment reference point off the CG).
fn check_model_features(estimator: &dyn Estimator, structure: &ModelStructure) -> Result<()> {
    let aero = &structure.aircraft.aero;
    let reason = if aero.has_ties() && !estimator.fits_tied_parameters() {
        "it has tied parameters ([parameters.NAME] tie), which this method does not fit"
    } else if aero.moment_reference != nalgebra::Vector3::zeros()
        && !estimator.fits_moment_reference()
    {
        "its moments are taken about a point other than the CG ([aero.moment_reference]), which this method does not fit"
    } else {
        return Ok(());
    };
    Err(Error::Refused(Refusal::UnsuitableModel {
        method: estimator.name().to_string(),
        model: structure.name.clone(),
        reason: reason.into(),
    }))
}

/// A note per tied parameter: its relation, and its value and standard
/// error from its master's estimate (σ = |c|·σ_master). A tied parameter
/// is not in the estimate's parameters, so it is not scored as if it had
/// been estimated independently (as a fixed one is not).
pub fn tied_notes(structure: &ModelStructure, estimate: &Estimate) -> Vec<String> {
    let aero = &structure.aircraft.aero;
    let names = aero.parameters.names();
    (0..names.len())
        .filter_map(|i| aero.tie_of(i).map(|tie| (i, tie)))
        .map(|(i, tie)| {
            let master = &names[tie.master];
            let relation = format!(
                "{} is tied: {} = {}·{master} + {}",
                names[i], names[i], tie.factor, tie.offset
            );
            match estimate.parameter(master) {
                Some(p) => format!(
                    "{relation} = {:.6e} ± {:.3e} (from {master}'s estimate; not estimated independently)",
                    tie.factor * p.value + tie.offset,
                    tie.factor.abs() * p.standard_error
                ),
                None => format!(
                    "{relation} = {:.6e} ({master} not estimated)",
                    aero.parameters.values()[i]
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::Settings;

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
