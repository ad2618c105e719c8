//! The unscented Kalman filter with the aerodynamic parameters as augmented
//! states (Wan & van der Merwe, "The unscented Kalman filter for nonlinear
//! estimation", IEEE AS-SPCC 2000; Julier & Uhlmann, SPIE 3068, 1997).
//! Method `ukf`; settings `[methods.ukf]`: those of the EKF
//! ([`FilterSettings`]) and the sigma points' `alpha`, `beta`, `kappa`.
//!
//! The augmented model, the start, the prior, the Fourier R, the
//! residual-correlation passes, the estimate, its status and the parameter
//! histories are the EKF's ([`super::augmented_ekf`], one routine:
//! [`augmented_estimate`]); only the pass differs: sigma points
//! propagated through the model's own integration step and its outputs,
//! additive process and measurement noise, in the square-root form that
//! carries a Cholesky factor of the covariance
//! ([`crate::solver::unscented_kalman`]; van der Merwe & Wan,
//! "The square-root unscented Kalman filter for state and parameter
//! estimation", ICASSP 2001, Algorithm 3.1; sigma points Wan & van der
//! Merwe 2000, Eq. 15). It needs no Jacobian of the model, and its mean
//! and covariance are exact to second order in the state's spread where
//! the EKF's are to first.

use crate::estimate::Estimate;
use crate::estimator::{
    Capabilities, Estimator, MethodInfo, SettingInfo, Settings, parse_settings, setting_infos,
};
use crate::methods::augmented_ekf::{self, FILTER_SETTINGS, FilterSettings, augmented_estimate};
use crate::methods::equation_error;
use crate::problem::EstimationProblem;
use crate::solver::unscented_kalman;
use aeroid_core::error::{Error, Result};
use aeroid_numerics::kalman::Unscented;
use serde::{Deserialize, Serialize};

/// Method name in estimates.
pub const METHOD: &str = "ukf";

/// The sigma-point keys of `[methods.ukf]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SigmaSettings {
    pub alpha: f64,
    pub beta: f64,
    pub kappa: f64,
}

/// α = 0.5: the points at ±√(n/4)·σ instead of ±√n·σ (n = 17 to 22
/// augmented states here, 4σ), where α = 1 took the stall model's
/// break-point parameters so far from the mean that the sigma points'
/// spread stopped describing the filter's error (docs/findings.md).
impl Default for SigmaSettings {
    fn default() -> Self {
        SigmaSettings {
            alpha: 0.5,
            beta: 2.0,
            kappa: 0.0,
        }
    }
}

const SIGMA_KEYS: [(&str, &str); 3] = [
    (
        "alpha",
        "spread of the sigma points about the mean, 0 < α ≤ 1 (Wan & van der Merwe Eq. 15)",
    ),
    (
        "beta",
        "prior knowledge of the distribution (2 for a Gaussian)",
    ),
    ("kappa", "secondary scaling, ≥ 0"),
];

/// Reads a `[methods.ukf]` table: the sigma-point keys, then the rest as
/// the EKF's settings (a key neither knows is refused by name).
pub fn read(settings: &Settings) -> Result<(FilterSettings, Unscented)> {
    let mut filter = settings.clone();
    let mut sigma = Settings::new();
    for (key, _) in SIGMA_KEYS {
        if let Some(value) = filter.remove(key) {
            sigma.insert(key.to_string(), value);
        }
    }
    let sigma: SigmaSettings = parse_settings(METHOD, &sigma)?;
    let filter = FilterSettings::read(METHOD, &filter)?;
    if !(sigma.alpha > 0.0 && sigma.alpha <= 1.0) {
        return Err(Error::Other(format!(
            "[methods.{METHOD}] alpha: must be in (0, 1], is {}",
            sigma.alpha
        )));
    }
    if !(sigma.beta >= 0.0 && sigma.beta.is_finite()) {
        return Err(Error::Other(format!(
            "[methods.{METHOD}] beta: must be at least 0, is {}",
            sigma.beta
        )));
    }
    if !(sigma.kappa >= 0.0 && sigma.kappa.is_finite()) {
        return Err(Error::Other(format!(
            "[methods.{METHOD}] kappa: must be at least 0, is {}",
            sigma.kappa
        )));
    }
    Ok((
        filter,
        Unscented {
            alpha: sigma.alpha,
            beta: sigma.beta,
            kappa: sigma.kappa,
        },
    ))
}

/// The augmented-state UKF as a registered method.
pub struct UnscentedFilter;

impl Estimator for UnscentedFilter {
    fn name(&self) -> &'static str {
        METHOD
    }

    fn info(&self) -> MethodInfo {
        let mut settings: Vec<SettingInfo> =
            setting_infos(&FilterSettings::default(), &FILTER_SETTINGS);
        settings.extend(setting_infos(&SigmaSettings::default(), &SIGMA_KEYS));
        MethodInfo {
            title: "square-root unscented Kalman filter with the parameters as augmented states, pseudonoise, Fourier R and residual-correlation tuning",
            paper: "van der Merwe & Wan, \"The square-root unscented Kalman filter for state and parameter estimation\", ICASSP 2001; Wan & van der Merwe, \"The unscented Kalman filter for nonlinear estimation\", IEEE AS-SPCC 2000; Julier & Uhlmann, SPIE 3068, 1997; the X-31/F-18 HARV EKF note",
            equations: "scaled sigma points (Wan & van der Merwe 2000, Eq. 15), the square-root UKF with additive noise (van der Merwe & Wan 2001, Algorithm 3.1: QR of the compound matrix, Cholesky update/downdate); augmented state and noise tuning as the EKF's (note Eqs. 1–3, Mehra 1970)",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls); on a linear structure, its input and output channels",
            settings,
        }
    }

    fn check_settings(&self, settings: &Settings) -> Result<()> {
        read(settings).map(|_| ())
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            six_dof: true,
            linear: true,
            several_records: false,
            tied_parameters: true,
            moment_reference: true,
            starts_from: Some(equation_error::METHOD),
        }
    }

    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate> {
        let (settings, unscented) = read(&problem.settings)?;
        crate::estimator::one_record(METHOD, problem)?;
        augmented_ekf::refuse_for_linear(METHOD, problem)?;
        let run = augmented_estimate(
            METHOD,
            problem.record(),
            &problem.structure,
            &settings,
            start,
            &|model, initial, noise, observations| {
                unscented_kalman::filter(model, &[], initial, noise, observations, &unscented)
            },
        )?;
        if let Some(path) = &settings.history {
            run.history.write_csv(path)?;
        }
        Ok(run.estimate)
    }
}
