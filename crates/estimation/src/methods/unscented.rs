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

use crate::error::{Error, Result};
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method, Settings, parse_settings};
use crate::methods::common::augmented_filter::{
    self, FILTER_SETTINGS, FilterSettings, augmented_estimate,
};
use crate::methods::common::coefficient_fit::EQUATION_ERROR;
use crate::problem::EstimationProblem;
use crate::solver::unscented_kalman;
use aeroid_numerics::kalman::Unscented;
use serde::{Deserialize, Serialize};

/// Method name in estimates.
pub const METHOD: &str = "ukf";

/// The sigma-point keys of `[methods.ukf]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct SigmaSettings {
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

/// The `[methods.ukf]` table: the sigma-point keys (`alpha`, `beta`, `kappa`), the
/// rest the EKF's settings (a key neither knows is refused by name).
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct UnscentedSettings {
    pub filter: FilterSettings,
    pub sigma: SigmaSettings,
}

impl Serialize for UnscentedSettings {
    /// One table: the EKF's keys and the sigma points'.
    fn serialize<S: serde::Serializer>(
        &self,
        serializer: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::Error as _;
        let mut table = Settings::new();
        for part in [
            serde_json::to_value(&self.filter).map_err(S::Error::custom)?,
            serde_json::to_value(self.sigma).map_err(S::Error::custom)?,
        ] {
            if let serde_json::Value::Object(keys) = part {
                table.extend(keys);
            }
        }
        table.serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for UnscentedSettings {
    /// The sigma-point keys, then the rest as the EKF's settings.
    fn deserialize<D: serde::Deserializer<'de>>(
        deserializer: D,
    ) -> std::result::Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut filter = Settings::deserialize(deserializer)?;
        let mut sigma = Settings::new();
        for (key, _) in SIGMA_KEYS {
            if let Some(value) = filter.remove(key) {
                sigma.insert(key.to_string(), value);
            }
        }
        let sigma =
            serde_json::from_value(serde_json::Value::Object(sigma)).map_err(D::Error::custom)?;
        let filter =
            serde_json::from_value(serde_json::Value::Object(filter)).map_err(D::Error::custom)?;
        Ok(UnscentedSettings { filter, sigma })
    }
}

impl UnscentedSettings {
    /// The sigma points' parameters.
    pub fn unscented(&self) -> Unscented {
        Unscented {
            alpha: self.sigma.alpha,
            beta: self.sigma.beta,
            kappa: self.sigma.kappa,
        }
    }
}

/// Reads and checks a `[methods.ukf]` table: the EKF's settings and the
/// sigma points.
pub fn read(settings: &Settings) -> Result<(FilterSettings, Unscented)> {
    let parsed: UnscentedSettings = parse_settings(METHOD, settings)?;
    UnscentedFilter::validate(&parsed)?;
    let unscented = parsed.unscented();
    Ok((parsed.filter, unscented))
}

/// The augmented-state UKF as a registered method.
pub(crate) struct UnscentedFilter;

impl Method for UnscentedFilter {
    const NAME: &'static str = METHOD;
    type Settings = UnscentedSettings;

    fn describe() -> Description {
        Description {
            title: "square-root unscented Kalman filter with the parameters as augmented states, pseudonoise, Fourier R and residual-correlation tuning",
            paper: "van der Merwe & Wan, \"The square-root unscented Kalman filter for state and parameter estimation\", ICASSP 2001; Wan & van der Merwe, \"The unscented Kalman filter for nonlinear estimation\", IEEE AS-SPCC 2000; Julier & Uhlmann, SPIE 3068, 1997; the X-31/F-18 HARV EKF note",
            equations: "scaled sigma points (Wan & van der Merwe 2000, Eq. 15), the square-root UKF with additive noise (van der Merwe & Wan 2001, Algorithm 3.1: QR of the compound matrix, Cholesky update/downdate); augmented state and noise tuning as the EKF's (note Eqs. 1–3, Mehra 1970)",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls); on a linear structure, its input and output channels",
            settings: FILTER_SETTINGS.into_iter().chain(SIGMA_KEYS).collect(),
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            tied_parameters: true,
            starts_from: Some(EQUATION_ERROR),
            ..Capabilities::default()
        }
    }

    fn validate(settings: &UnscentedSettings) -> Result<()> {
        settings.filter.check(METHOD)?;
        let sigma = &settings.sigma;
        if !(sigma.alpha > 0.0 && sigma.alpha <= 1.0) {
            return Err(Error::Setting {
                method: METHOD.to_string(),
                reason: format!("alpha: must be in (0, 1], is {}", sigma.alpha),
            });
        }
        if !(sigma.beta >= 0.0 && sigma.beta.is_finite()) {
            return Err(Error::Setting {
                method: METHOD.to_string(),
                reason: format!("beta: must be at least 0, is {}", sigma.beta),
            });
        }
        if !(sigma.kappa >= 0.0 && sigma.kappa.is_finite()) {
            return Err(Error::Setting {
                method: METHOD.to_string(),
                reason: format!("kappa: must be at least 0, is {}", sigma.kappa),
            });
        }
        Ok(())
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &UnscentedSettings,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        augmented_filter::refuse_for_linear(METHOD, problem)?;
        let unscented = settings.unscented();
        let filter = &settings.filter;
        let run = augmented_estimate(
            METHOD,
            problem.record(),
            &problem.structure,
            filter,
            start,
            &|model, initial, noise, observations| {
                unscented_kalman::filter(model, &[], initial, noise, observations, &unscented)
            },
        )?;
        if let Some(path) = &filter.history {
            run.history.write_csv(path)?;
        }
        Ok(run.estimate)
    }
}
