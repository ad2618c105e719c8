//! What ELM-GN and RELM-GN share: their settings (`[methods.elm-gn]`,
//! `[methods.relm-gn]`), the start from equation error's estimate, and the
//! estimation through the restricted flight-dynamic model
//! ([`crate::neural::restricted`]; "Parameter estimation of aircraft using
//! extreme learning machine and Gauss-Newton algorithm", Eqs. 1–22;
//! Verma & Peyada, Aeronautical J. 2020, Eqs. 12–26).

use super::coefficient_fit::{DIFFERENTIATOR_SETTING, EquationErrorOptions, equation_error};
use crate::error::{Error, Result};
use crate::estimate::Estimate;
use crate::estimator::{Settings, parse_settings};
use crate::neural::elm::ElmTrainer;
use crate::neural::restricted::{self, Feedback, RestrictedOptions};
use crate::problem::EstimationProblem;
use crate::reconstruction::ReconstructionOptions;
use aeroid_record::prep::differentiation::Differentiator;
use serde::{Deserialize, Serialize};

/// Where the Gauss–Newton iterations start, as for output error: the
/// model file's values, or equation error's estimates where the structure
/// allows equation error and its fit converges.
pub use super::coefficient_fit::Start;

/// The `[methods.elm-gn]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ElmSettings {
    /// Seed of the random input weights and biases.
    pub seed: u64,
    /// Candidate numbers of hidden neurons (Eq. 6's search).
    pub hidden_sizes: Vec<usize>,
    /// Every this-many-th training pair is held out to choose the size.
    pub validation_stride: usize,
    /// The range inputs and targets are scaled to (Eq. 3).
    pub scaling: [f64; 2],
    pub start: Start,
    /// Gauss–Newton iterations at most.
    pub max_iterations: usize,
    /// The differentiator of the angular rates (moment coefficients) and α.
    pub differentiator: Differentiator,
    /// The motion variables fed to the network during the estimation.
    pub feedback: Feedback,
}

impl Default for ElmSettings {
    fn default() -> Self {
        let trainer = ElmTrainer::default();
        let options = RestrictedOptions::default();
        ElmSettings {
            seed: trainer.seed,
            hidden_sizes: trainer.hidden_sizes,
            validation_stride: trainer.validation_stride,
            scaling: [options.scaling.0, options.scaling.1],
            start: Start::default(),
            max_iterations: options.max_iterations,
            differentiator: options.differentiator,
            feedback: options.feedback,
        }
    }
}

/// The meanings of the settings ELM-GN and RELM-GN share.
pub(crate) const SHARED_SETTINGS: [(&str, &str); 8] = [
    (
        "seed",
        "seed of the network's random input weights and biases",
    ),
    (
        "hidden_sizes",
        "candidate numbers of hidden neurons; the one with the least held-out residual (Eq. 6) is trained on every sample",
    ),
    (
        "validation_stride",
        "every this-many-th training pair is held out to choose the hidden-layer size (the training residual always falls with size)",
    ),
    (
        "scaling",
        "[low, high]: the range inputs and targets are scaled to (Eq. 3)",
    ),
    (
        "start",
        "\"ee\": equation error's estimates where the structure allows it; \"model\": the model file's values",
    ),
    ("max_iterations", "Gauss–Newton iterations at most"),
    DIFFERENTIATOR_SETTING,
    (
        "feedback",
        "motion variables fed to the network in the estimation: \"measured\" (ELM paper Eq. 11, Verma & Peyada Eq. 23) or \"predicted\" (the network's previous prediction, free-running from the first sample)",
    ),
];

impl ElmSettings {
    /// Reads and checks a settings table of `method`.
    pub fn read(method: &str, settings: &Settings) -> Result<ElmSettings> {
        let parsed: ElmSettings = parse_settings(method, settings)?;
        parsed.check(method)?;
        Ok(parsed)
    }

    /// Checks the values of a settings table of `method`.
    pub(crate) fn check(&self, method: &str) -> Result<()> {
        let [low, high] = self.scaling;
        let problem = if self.hidden_sizes.is_empty() || self.hidden_sizes.contains(&0) {
            Some("hidden_sizes must list at least one positive size".to_string())
        } else if self.validation_stride < 2 {
            Some("validation_stride must be at least 2".to_string())
        } else if !(low < high && low.is_finite() && high.is_finite()) {
            Some(format!(
                "scaling must be [low, high] with low < high, is [{low}, {high}]"
            ))
        } else if self.max_iterations == 0 {
            Some("max_iterations must be at least 1".to_string())
        } else {
            self.differentiator.check()
        };
        match problem {
            Some(message) => Err(Error::Settings {
                method: method.to_string(),
                reason: message.to_string(),
            }),
            None => Ok(()),
        }
    }

    /// The trainer of these settings, its report of kind `kind`.
    pub fn trainer(&self, kind: &'static str) -> ElmTrainer {
        ElmTrainer {
            seed: self.seed,
            hidden_sizes: self.hidden_sizes.clone(),
            validation_stride: self.validation_stride,
            kind,
        }
    }

    /// The restricted model's options of these settings.
    pub fn options(&self) -> RestrictedOptions {
        RestrictedOptions {
            scaling: (self.scaling[0], self.scaling[1]),
            max_iterations: self.max_iterations,
            differentiator: self.differentiator,
            feedback: self.feedback,
            ..RestrictedOptions::default()
        }
    }
}

/// Equation error's estimate on the problem's record when the settings ask
/// for it, the structure allows it and it converged; None otherwise.
pub(crate) fn equation_error_start(
    problem: &EstimationProblem,
    settings: &ElmSettings,
) -> Option<Estimate> {
    if settings.start != Start::EquationError {
        return None;
    }
    let structure = problem.structure.six_dof(&problem.method).ok()?;
    let options = EquationErrorOptions {
        reconstruction: ReconstructionOptions {
            differentiator: Some(settings.differentiator),
            ..Default::default()
        },
        ..Default::default()
    };
    equation_error(problem.record(), structure, &options)
        .ok()
        .map(Estimate::assess)
        .filter(|e| e.status.is_success())
}

/// ELM-GN or RELM-GN (`method`, its network reported as `kind`) with its
/// settings: the start chosen (module documentation), the restricted
/// model fitted.
pub(crate) fn estimate_with(
    method: &str,
    kind: &'static str,
    problem: &EstimationProblem,
    settings: &ElmSettings,
    start: Option<&Estimate>,
) -> Result<Estimate> {
    let own = match start {
        Some(_) => None,
        None => equation_error_start(problem, settings),
    };
    let start = start
        .filter(|_| settings.start == Start::EquationError)
        .or(own.as_ref());
    restricted::estimate(
        method,
        problem,
        start,
        &settings.trainer(kind),
        &settings.options(),
    )
}
