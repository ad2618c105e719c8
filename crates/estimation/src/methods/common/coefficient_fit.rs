//! Equation error's fit of a 6-DOF structure: the coefficients
//! reconstructed from the measured accelerations and angular accelerations
//! (reflex-wing UAV paper, Eqs. 17–24; [`crate::reconstruction`]), then the
//! least-squares regressions of [`super::regression`] (Eqs. 25–27; Klein &
//! Morelli, "Aircraft System Identification", AIAA 2006, ch. 5). Here too
//! the `[methods.ee]` settings and `start_estimate`, equation error's
//! estimate as the start of the iterative methods (output error, filter
//! error, the augmented filters, the neural Gauss–Newton fits).

use super::linear_regression::linear_equation_error;
use super::regression::{Plan, plans, regress, request};
use crate::error::{Error, Result};
use crate::estimate::{Estimate, Status};
use crate::estimator::{Settings, merge_settings, parse_settings};
use crate::linear_structure::LinearStructure;
use crate::reconstruction::{
    AngularAccelerations, Reconstruction, ReconstructionOptions, check_channels, reconstruct,
};
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;

pub use super::EQUATION_ERROR;

/// Equation error's name ([`EQUATION_ERROR`]).
pub const METHOD: &str = EQUATION_ERROR;

/// Settings of the equation-error estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct EquationErrorOptions {
    pub reconstruction: ReconstructionOptions,
    /// The residual autocorrelation in the coloured-residual bound is summed
    /// to this lag (s). Default 2 s: longer than the correlation the
    /// differentiator puts into the residuals (±0.1 s) and than a
    /// short-period or Dutch-roll half-period of a transport aircraft.
    pub correlation_lag: f64,
}

/// The `[methods.ee]` table.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EquationErrorSettings {
    /// The local polynomial differentiator of the angular rates.
    pub differentiator: Differentiator,
    /// Lag (s) to which the residual autocorrelation is summed in the
    /// coloured-residual bound.
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub correlation_lag: f64,
    /// Where ṗ, q̇, ṙ come from.
    pub angular_accelerations: AngularAccelerations,
}

impl Default for EquationErrorSettings {
    fn default() -> Self {
        let options = EquationErrorOptions::default();
        EquationErrorSettings {
            differentiator: Differentiator::default(),
            correlation_lag: options.correlation_lag,
            angular_accelerations: AngularAccelerations::default(),
        }
    }
}

/// The meaning of each key of [`EquationErrorSettings`], for `aeroid methods`.
pub(crate) const DIFFERENTIATOR_SETTING: (&str, &str) = (
    "differentiator",
    "local polynomial differentiator of the angular rates: { half_width = \"0.1 s\", degree = 4 }; a fast aircraft needs a narrower window",
);
pub(crate) const CORRELATION_LAG_SETTING: (&str, &str) = (
    "correlation_lag",
    "lag (s) to which residual autocorrelation is summed in the coloured-residual Cramér–Rao bound",
);
pub(crate) const ANGULAR_ACCELERATIONS_SETTING: (&str, &str) = (
    "angular_accelerations",
    "where ṗ, q̇, ṙ come from: \"differentiated\" (the rates), \"measured\" (the record's q_dot for Cm, p_dot and r_dot for Cl and Cn) or \"auto\" (measured when the record has those)",
);

impl EquationErrorSettings {
    /// Reads and checks a `[methods.ee]` table.
    pub fn read(settings: &Settings) -> Result<EquationErrorSettings> {
        let parsed: EquationErrorSettings = parse_settings(METHOD, settings)?;
        check_settings(METHOD, &parsed.differentiator, parsed.correlation_lag)?;
        Ok(parsed)
    }

    pub fn options(&self) -> EquationErrorOptions {
        EquationErrorOptions {
            reconstruction: ReconstructionOptions {
                differentiator: Some(self.differentiator),
                angular_accelerations: self.angular_accelerations,
                ..Default::default()
            },
            correlation_lag: self.correlation_lag,
        }
    }
}

/// Checks the settings equation error and stepwise regression share.
pub(crate) fn check_settings(
    method: &str,
    differentiator: &Differentiator,
    correlation_lag: f64,
) -> Result<()> {
    let problem = differentiator.check().or_else(|| {
        (!(correlation_lag >= 0.0 && correlation_lag.is_finite()))
            .then(|| format!("correlation_lag must be at least 0 s, is {correlation_lag} s"))
    });
    match problem {
        Some(message) => Err(Error::Settings {
            method: method.to_string(),
            reason: message.to_string(),
        }),
        None => Ok(()),
    }
}

impl Default for EquationErrorOptions {
    fn default() -> Self {
        EquationErrorOptions {
            reconstruction: ReconstructionOptions::default(),
            correlation_lag: 2.0,
        }
    }
}

/// Where the iterations start of an iterative method: the model file's values or
/// equation error's estimate (`start_estimate`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Start {
    /// The model file's values; initial states first held (two stages).
    #[serde(rename = "model")]
    Model,
    /// Equation error's estimates where the structure allows it and they
    /// fit the record better than the model file's values; otherwise as
    /// the model file's.
    #[default]
    #[serde(rename = "ee")]
    EquationError,
}

/// Equation error's estimate on `record` as the start of an iterative
/// method (output error, filter error, the augmented filters), with the
/// model file's `[methods.ee]` settings and white bounds (a start's bounds
/// are not read). `given`, an estimate already made on the record, is
/// used when it converged. Otherwise the reason the model file's values
/// must serve ("equation error ended …" or "no equation-error start (…)").
///
/// Equation error is not fitted again with the regressors it cannot
/// separate held at the model file's values: on the gusty 1 Hz approach
/// (docs/findings.md) that start left filter error further from the
/// truth than the model file's values did.
pub(crate) fn start_estimate(
    record: &FlightRecord,
    structure: &ModelStructure,
    given: Option<&Estimate>,
) -> crate::Result<Estimate> {
    let table = merge_settings(METHOD, &[&structure.methods]);
    let options = EquationErrorOptions {
        correlation_lag: 0.0,
        ..EquationErrorSettings::read(&table)
            .map(|settings| settings.options())
            .unwrap_or_default()
    };
    let estimate = match given {
        Some(estimate) => estimate.clone(),
        None => equation_error(record, structure, &options)
            .map_err(|error| crate::Error::NoStart(Box::new(error)))?,
    };
    match &estimate.status {
        Status::Converged => Ok(estimate),
        status => Err(crate::Error::StartNotConverged(status.clone())),
    }
}

/// Estimates the free parameters of `structure` from `record` by equation
/// error. Errors: a channel the structure needs is missing, the structure is
/// not linear in its parameters, or it has no free parameter.
pub fn equation_error(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &EquationErrorOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    // Forces and moments are reconstructed separately: only the moments
    // need differentiated rates, whose windows leave out the samples next
    // to a control step, and the force regressions keep those samples.
    let plans = plans(structure, METHOD)?;
    check_channels(record, &structure.aircraft, &request(&plans), METHOD)?;
    let (forces, moments): (Vec<Plan>, Vec<Plan>) = plans
        .into_iter()
        .partition(|plan| plan.coefficient.is_force());
    let mut groups: Vec<(Vec<Plan>, Reconstruction)> = Vec::new();
    for group in [forces, moments]
        .into_iter()
        .filter(|group| !group.is_empty())
    {
        let reconstruction = reconstruct(
            record,
            &structure.aircraft,
            &request(&group),
            &options.reconstruction,
            METHOD,
        )?;
        groups.push((group, reconstruction));
    }
    let mut estimate = regress(record, structure, METHOD, &groups, options.correlation_lag);
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// [`start_estimate`] on a linear structure: equation error's estimate
/// ([`linear_equation_error`]) with the model file's `[methods.ee]`
/// differentiator and white bounds, or the reason there is none.
pub(crate) fn linear_start_estimate(
    record: &FlightRecord,
    structure: &LinearStructure,
    given: Option<&Estimate>,
) -> crate::Result<Estimate> {
    let estimate = match given {
        Some(estimate) => estimate.clone(),
        None => {
            let table = merge_settings(METHOD, &[&structure.methods]);
            let settings = EquationErrorSettings::read(&table).unwrap_or_default();
            linear_equation_error(record, structure, &settings.differentiator, 0.0)
                .map_err(|error| crate::Error::NoStart(Box::new(error)))?
        }
    };
    match &estimate.status {
        Status::Converged => Ok(estimate),
        status => Err(crate::Error::StartNotConverged(status.clone())),
    }
}
