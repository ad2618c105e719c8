//! The `[methods.ebm]` table of estimation before modelling: the
//! observations, the Gauss–Markov models' noise densities, change bounds
//! and initial deviations (Wang et al. 2012, Eqs. 7–8), the measurement
//! noise, and the regression's control-step margin and correlation lag;
//! read and checked, a bad value refused naming its key.

use super::METHOD;
use crate::error::{Error, Result};
use crate::estimator::{Settings, parse_settings};
use crate::model::coefficient_states::Output;
use std::collections::BTreeMap;

/// The `[methods.ebm]` table.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SmoothedRegressionSettings {
    /// Channels the filter compares, each needed (Eq. 8).
    pub observations: Vec<String>,
    /// Channels compared when the record has them.
    pub optional_observations: Vec<String>,
    /// Spectral density of d³C/dt³ for CX, CY, CZ (1/s⁵).
    pub force_noise: f64,
    /// Spectral density of d³C/dt³ for Cl, Cm, Cn (1/s⁵).
    pub moment_noise: f64,
    /// The most a force coefficient's Gauss–Markov model may spread the
    /// specific force over one sample period of the observations (m/s²):
    /// a larger `force_noise` or initial derivative deviation is lowered
    /// to it (the rate-aware bound of [`super::GaussMarkov::for_period`]).
    pub force_change_bound: f64,
    /// The same for a moment coefficient and the angular acceleration
    /// (rad/s²).
    pub moment_change_bound: f64,
    /// Spectral density of the process noise on u̇, v̇, ẇ (m²/s³).
    pub velocity_noise: f64,
    /// Spectral density of the process noise on ṗ, q̇, ṙ (rad²/s³).
    pub rate_noise: f64,
    /// Initial standard deviations of a force coefficient, its first and
    /// second derivative.
    pub initial_force_std: [f64; 3],
    /// The same for a moment coefficient.
    pub initial_moment_std: [f64; 3],
    /// Measurement noise standard deviation per channel (SI units), before
    /// the channel's quantization (LSB²/12) is added.
    pub measurement_noise: BTreeMap<String, f64>,
    /// Measurement noise standard deviation (SI units) of a channel the
    /// derive step computed rather than a sensor measured (its source
    /// begins "geometric" or "kinematic": the geometric flow angles and
    /// airspeed, the kinematic rates); the channels not named here take
    /// `measurement_noise`.
    pub derived_measurement_noise: BTreeMap<String, f64>,
    /// Lag (s) to which the residual autocorrelation is summed in the
    /// coloured-residual bound of the regression.
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub correlation_lag: f64,
    /// Grid points within this time (s) of a step in a control channel are
    /// left out of the regression: a Gauss–Markov coefficient cannot jump
    /// between two samples, so its smoothed history ramps across the step.
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub step_margin: f64,
    /// The filter's grid step is the fastest observation's sample period
    /// divided into the fewest equal parts no longer than this (s).
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub max_step: f64,
}

impl Default for SmoothedRegressionSettings {
    fn default() -> Self {
        let deg = std::f64::consts::PI / 180.0;
        let noise = [
            ("nx", 0.002),
            ("ny", 0.002),
            ("nz", 0.002),
            ("roll", 0.1 * deg),
            ("pitch", 0.1 * deg),
            ("yaw", 0.1 * deg),
            ("airspeed", 0.2),
            ("altitude", 1.0),
            ("alpha", 0.1 * deg),
            ("beta", 0.1 * deg),
            ("p", 0.002),
            ("q", 0.002),
            ("r", 0.002),
        ];
        SmoothedRegressionSettings {
            observations: [
                "nx", "ny", "nz", "roll", "pitch", "yaw", "airspeed", "altitude",
            ]
            .map(String::from)
            .to_vec(),
            optional_observations: ["alpha", "beta", "p", "q", "r"].map(String::from).to_vec(),
            force_noise: 100.0,
            moment_noise: 1000.0,
            force_change_bound: 2.0,
            moment_change_bound: 0.25,
            velocity_noise: 1.0,
            rate_noise: 1e-8,
            initial_force_std: [0.02, 0.05, 0.2],
            initial_moment_std: [0.01, 0.02, 0.1],
            measurement_noise: noise
                .iter()
                .map(|(name, value)| (name.to_string(), *value))
                .collect(),
            derived_measurement_noise: [
                ("alpha", 0.02),
                ("beta", 0.02),
                ("airspeed", 1.5),
                ("p", 0.03),
                ("q", 0.01),
                ("r", 0.03),
            ]
            .iter()
            .map(|(name, value)| (name.to_string(), *value))
            .collect(),
            correlation_lag: 2.0,
            step_margin: 0.2,
            max_step: 0.04,
        }
    }
}

pub(crate) const SETTINGS: &[(&str, &str)] = &[
    (
        "observations",
        "channels the filter compares, each needed: any of nx, ny, nz, roll, pitch, yaw, airspeed, altitude, alpha, beta, p, q, r (Eq. 8)",
    ),
    (
        "optional_observations",
        "channels compared when the record has them (α, β and the angular rates)",
    ),
    (
        "force_noise",
        "spectral density of the third derivative of CX, CY, CZ (1/s⁵): larger follows faster changes and passes more noise",
    ),
    (
        "moment_noise",
        "spectral density of the third derivative of Cl, Cm, Cn (1/s⁵)",
    ),
    (
        "force_change_bound",
        "the most a force coefficient's Gauss–Markov model may spread the specific force over one sample period of the observations (m/s²); force_noise and the initial derivative deviations are lowered to it (bites on slow records such as a 1 Hz QAR, not at 10–25 Hz)",
    ),
    (
        "moment_change_bound",
        "the same for a moment coefficient and the angular acceleration (rad/s²), per axis through its inertia and arm",
    ),
    (
        "velocity_noise",
        "process noise spectral density on u̇, v̇, ẇ (m²/s³): the wind's changes (gusts, turbulence), which the still-air model does not carry, and model error",
    ),
    (
        "rate_noise",
        "process noise spectral density on ṗ, q̇, ṙ (rad²/s³)",
    ),
    (
        "initial_force_std",
        "initial standard deviations of a force coefficient, its first and second derivative",
    ),
    (
        "initial_moment_std",
        "initial standard deviations of a moment coefficient, its first and second derivative",
    ),
    (
        "measurement_noise",
        "measurement noise standard deviation per channel (SI: load factor, rad, m/s, m, rad/s); the channel's quantization LSB²/12 is added",
    ),
    (
        "derived_measurement_noise",
        "measurement noise standard deviation (SI) of a channel the derive step computed (geometric α, β, airspeed; kinematic p, q, r): the unknown vertical and lateral gusts in the geometric flow angles (≈ 0.02 rad in moderate turbulence), the turbulence and roll response a 1 Hz attitude cannot carry in the kinematic rates",
    ),
    (
        "correlation_lag",
        "lag (s) to which residual autocorrelation is summed in the regression's coloured-residual Cramér–Rao bound",
    ),
    (
        "step_margin",
        "grid points within this time (s) of a step in a control channel are left out of the regression (the smoothed coefficient ramps across a step)",
    ),
    (
        "max_step",
        "the filter's grid step is the fastest observation's sample period divided into the fewest equal parts no longer than this (s); the smoothed histories and the regression are at the sample instants",
    ),
];

impl SmoothedRegressionSettings {
    /// Reads and checks a `[methods.ebm]` table; a bad value is refused
    /// naming its key.
    pub fn read(settings: &Settings) -> Result<SmoothedRegressionSettings> {
        let parsed: SmoothedRegressionSettings = parse_settings(METHOD, settings)?;
        parsed.check()?;
        Ok(parsed)
    }

    /// Refuses a bad value, naming its key.
    pub(crate) fn check(&self) -> Result<()> {
        self.check_observations()?;
        self.check_noise()?;
        self.check_times()
    }

    /// The observations: each a model output, at least one needed.
    fn check_observations(&self) -> Result<()> {
        for (key, names) in [
            ("observations", &self.observations),
            ("optional_observations", &self.optional_observations),
        ] {
            for name in names {
                if Output::parse(name).is_none() {
                    return refuse(
                        key,
                        format!(
                            "'{name}' is not an observation of the model; known: {}",
                            Output::ALL.map(Output::channel).join(", ")
                        ),
                    );
                }
            }
        }
        if self.observations.is_empty() {
            return refuse("observations", "at least one channel is needed".into());
        }
        Ok(())
    }

    /// The noise densities, change bounds, initial and measurement
    /// deviations: finite and ≥ 0 (the initial ones > 0).
    fn check_noise(&self) -> Result<()> {
        for (key, value) in [
            ("force_noise", self.force_noise),
            ("moment_noise", self.moment_noise),
            ("force_change_bound", self.force_change_bound),
            ("moment_change_bound", self.moment_change_bound),
            ("velocity_noise", self.velocity_noise),
            ("rate_noise", self.rate_noise),
        ] {
            if !(value >= 0.0 && value.is_finite()) {
                return refuse(key, format!("must be a finite value ≥ 0, is {value}"));
            }
        }
        for (key, values) in [
            ("initial_force_std", &self.initial_force_std),
            ("initial_moment_std", &self.initial_moment_std),
        ] {
            if values.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
                return refuse(
                    key,
                    format!("every value must be finite and > 0: {values:?}"),
                );
            }
        }
        for (name, value) in self
            .measurement_noise
            .iter()
            .chain(&self.derived_measurement_noise)
        {
            if Output::parse(name).is_none() {
                return refuse(
                    "measurement_noise",
                    format!("'{name}' is not an observation of the model"),
                );
            }
            if !(*value >= 0.0 && value.is_finite()) {
                return refuse(
                    "measurement_noise",
                    format!("{name} must be a finite value ≥ 0, is {value}"),
                );
            }
        }
        Ok(())
    }

    /// The grid's largest step, the control-step margin and the
    /// correlation lag.
    fn check_times(&self) -> Result<()> {
        if !(self.max_step > 0.0 && self.max_step.is_finite()) {
            return refuse(
                "max_step",
                format!("must be a finite time > 0, is {} s", self.max_step),
            );
        }
        if !(self.step_margin >= 0.0 && self.step_margin.is_finite()) {
            return refuse(
                "step_margin",
                format!("must be at least 0 s, is {} s", self.step_margin),
            );
        }
        if !(self.correlation_lag >= 0.0 && self.correlation_lag.is_finite()) {
            return refuse(
                "correlation_lag",
                format!("must be at least 0 s, is {} s", self.correlation_lag),
            );
        }
        Ok(())
    }
}

/// The refusal of the `[methods.ebm]` table's value under `key`.
fn refuse(key: &str, message: String) -> Result<()> {
    Err(Error::Settings {
        method: METHOD.to_string(),
        reason: format!("{key}: {message}"),
    })
}
