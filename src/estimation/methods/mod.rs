//! The estimators, one file each, and the one registry that lists them.
//! Adding a method is one file implementing
//! [`crate::estimation::estimator::Estimator`] and one line in
//! `built_in`; the command line, `run`, `gate`, `study` and the reports
//! find methods only here. A program embedding aeroid (or a test) adds its
//! own with [`register`].

pub mod equation_error;
pub mod output_error;
pub mod stepwise;

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
    ]
}

/// The registry: the built-in estimators, then those registered at run time.
fn registry() -> &'static RwLock<Vec<Arc<dyn Estimator>>> {
    static REGISTRY: OnceLock<RwLock<Vec<Arc<dyn Estimator>>>> = OnceLock::new();
    REGISTRY.get_or_init(|| RwLock::new(built_in()))
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
    all().iter().map(|e| e.info().name.to_string()).collect()
}

/// The estimator named `name`.
pub fn find(name: &str) -> Result<Arc<dyn Estimator>> {
    all()
        .into_iter()
        .find(|e| e.info().name == name)
        .ok_or_else(|| Error::Unknown {
            kind: "method",
            name: name.to_string(),
            known: names(),
        })
}

/// Adds an estimator to the registry; its name must be new.
pub fn register(estimator: Arc<dyn Estimator>) -> Result<()> {
    let name = estimator.info().name;
    let mut registry = registry()
        .write()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if registry.iter().any(|e| e.info().name == name) {
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
    estimator
        .estimate(problem, start)
        .map(|estimate| estimate.assess(&problem.structure))
}
