//! Estimation before modelling (`ebm`): the aerodynamic coefficients as
//! Gauss–Markov states of an extended Kalman filter, smoothed by the
//! modified Bryson–Frazier smoother, then regressed on the model
//! structure's terms (Wang et al. 2012, "Aerodynamic modeling and
//! parameter estimation from QAR data of an airplane approaching a
//! high-altitude airport", Chinese J. Aeronautics 25, §3.2, Eqs. 7–24; the
//! regression of the smoothed histories is equation error's, Klein &
//! Morelli 2006, ch. 5, where Wang et al. fit an RBF network and use the
//! Delta method, Eqs. 25–33).
//!
//! 1. Model (Eqs. 7–8, [`crate::model::coefficient_states`]):
//!    u, v, w, p, q, r, φ, θ, ψ, h and CX, CY, CZ, Cl, Cm, Cn each a
//!    third-order Gauss–Markov process (value, first and second derivative;
//!    the third derivative white noise of spectral density
//!    `force_noise` / `moment_noise`); observed through nx, ny, nz, φ, θ, ψ,
//!    V, h (`observations`) and α, β, p, q, r where the record has them
//!    (`optional_observations`). No angular rate is needed. Without an
//!    `altitude` channel the pressure altitude observes h; the thrust is
//!    the record's `thrust` channel when it has one (a QAR's, derived from
//!    the fuel flow), else the throttle through the engine model.
//! 2. Forward pass (Eqs. 10–16): the continuous–discrete EKF
//!    ([`extended_kalman::filter_with`]) with the state propagated by RK4
//!    (Eq. 12) and the covariance by Φ = I + F·Δt + ½(F·Δt)² (Eq. 11b).
//!    R is diagonal (each output's noise variance), so the measurement
//!    update is a sequence of scalar updates, one per measured output
//!    (Bierman, "Factorization Methods for Discrete Sequential
//!    Estimation", 1977, ch. II; [`kalman::sequential_update_with`]):
//!    sᵢ = hᵢᵀ·P·hᵢ + rᵢ, kᵢ = P·hᵢ/sᵢ, x ← x + kᵢ·νᵢ,
//!    P ← (I − kᵢ·hᵢᵀ)·P·(I − kᵢ·hᵢᵀ)ᵀ + kᵢ·rᵢ·kᵢᵀ, no matrix inverse;
//!    equal to the vector update of Eqs. 13–16 in exact arithmetic.
//! 3. Backward pass (Eqs. 17–24): the modified Bryson–Frazier smoother
//!    ([`kalman::mbf_smooth_variances`]; adjoint λ, Λ from zero after the
//!    last measurement, updated at each measurement, propagated by Φᵀ;
//!    x_{k|N} = x_{k|k−1} − P_{k|k−1}·λ_k, P_{k|N} = P − P·Λ·P). The
//!    transcript's Eqs. 17–22 are damaged; Bierman's (1973) textbook form
//!    is used, which they transcribe, in its form for scalar updates
//!    (Bierman, "Sequential square root filtering and smoothing of
//!    discrete linear systems", Automatica 10, 1974; 1977, ch. X): through
//!    each scalar update in reverse, λ ← (I − kᵢ·hᵢᵀ)ᵀ·λ − hᵢ·νᵢ/sᵢ,
//!    Λ ← (I − kᵢ·hᵢᵀ)ᵀ·Λ·(I − kᵢ·hᵢᵀ) + hᵢ·hᵢᵀ/sᵢ, with νᵢ, sᵢ and kᵢ
//!    kept per output per point.
//! 4. Coefficients (Eq. 9): the smoothed CX, CY, CZ, Cl, Cm, Cn; CL and CD
//!    from CX, CZ and the smoothed α for a wind-axis structure.
//! 5. Modelling: for each coefficient with a free parameter, least squares
//!    of the smoothed coefficient on the structure's terms, the regressors
//!    from the smoothed states (α, β, V, p̂, q̂, r̂, α̇, Mach) and the recorded
//!    controls — the regression equation error runs
//!    (`equation_error::regress`), with its coloured-residual
//!    Cramér–Rao bounds.
//!
//! Outputs: an [`Estimate`] of the structure's free parameters, and on
//! request the smoothed histories ([`smooth`], [`Smoothed::write_csv`]).
//!
//! Limitations: still air is assumed (a wind or turbulence puts its
//! accelerations into the coefficients); the Gauss–Markov model smooths a
//! coefficient's steps over its bandwidth, so a step in a control shows as
//! a ramp; the moments are observed through the second derivative of the
//! attitude when the record has no rates.

use crate::estimate::{Estimate, History};
use crate::estimator::{
    Estimator, MethodInfo, MissingChannel, Refusal, Settings, parse_settings, setting_infos,
};
use crate::methods::equation_error::{self, Plan};
use crate::model::coefficient_states::{
    self, COEFFICIENT_NAMES, CoefficientStates, H, Output, P, PHI, PSI, STATE_COUNT, THETA, U,
};
use crate::model::driven::ALTITUDE_SUBSTITUTES;
use crate::model::observations::Observations;
use crate::model::state_space::{StateSpaceModel, fitting_window};
use crate::problem::EstimationProblem;
use crate::reconstruction::Reconstruction;
use crate::solver::extended_kalman::{self, Discretisation, Keep, Noise};
use crate::structure::ModelStructure;
use aeroid_core::error::{Error, Result};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::kalman::{self, Gaussian};
use aeroid_record::FlightRecord;
use aeroid_sim::aero::{AeroInput, ForceAxes, REGRESSOR_COUNT, Regressor};
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::state::{Control, Controls};
use nalgebra::{DMatrix, DVector, Vector3};
use std::collections::BTreeMap;
use std::path::Path;

/// Method name in estimates.
pub const METHOD: &str = "ebm";

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
    /// to it (the rate-aware bound of [`GaussMarkov::for_period`]).
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

const SETTINGS: &[(&str, &str)] = &[
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

    fn check(&self) -> Result<()> {
        let refuse = |key: &str, message: String| {
            Err(Error::Other(format!(
                "[methods.{METHOD}]: {key}: {message}"
            )))
        };
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

/// Estimation before modelling as a registered method.
pub struct SmoothedRegression;

impl Estimator for SmoothedRegression {
    fn name(&self) -> &'static str {
        METHOD
    }

    fn info(&self) -> MethodInfo {
        MethodInfo {
            title: "estimation before modelling: coefficients as Gauss–Markov states of an EKF, smoothed by the modified Bryson–Frazier smoother, regressed on the model's terms",
            paper: "Wang et al., \"Aerodynamic modeling and parameter estimation from QAR data of an airplane approaching a high-altitude airport\", Chinese J. Aeronautics 25 (2012); Bierman, \"Fixed interval smoothing with discrete measurements\" (1973); Klein & Morelli (2006), ch. 5",
            equations: "6-DOF kinematics with third-order Gauss–Markov coefficients (Eq. 7), observations (Eq. 8), coefficients (Eq. 9), EKF (Eqs. 10–16), modified Bryson–Frazier smoother (Eqs. 17–24); least squares on the smoothed coefficients (Eqs. 25–27 of the reflex-wing UAV paper)",
            needs: "load factors, attitude angles, airspeed, altitude or pressure altitude (α, β, p, q, r used when present), the controls of the model's terms, thrust or throttle when the aircraft has thrust; a model linear in its parameters",
            settings: setting_infos(&SmoothedRegressionSettings::default(), SETTINGS),
        }
    }

    fn check_settings(&self, settings: &Settings) -> Result<()> {
        SmoothedRegressionSettings::read(settings).map(|_| ())
    }

    /// Its moment equations are about the CG, in its own form.
    fn fits_moment_reference(&self) -> bool {
        false
    }

    fn estimate(&self, problem: &EstimationProblem, _start: Option<&Estimate>) -> Result<Estimate> {
        let settings = SmoothedRegressionSettings::read(&problem.settings)?;
        crate::estimator::one_record(METHOD, problem)?;
        let started = std::time::Instant::now();
        let (smoothed, mut estimate) = smooth_and_regress(
            problem.record(),
            problem.structure.six_dof(METHOD)?,
            &settings,
        )?;
        estimate.notes.extend(smoothed.notes.iter().cloned());
        estimate.notes.push(determined_note(&estimate));
        estimate.histories = smoothed.coefficient_histories();
        estimate.wall_time = started.elapsed().as_secs_f64();
        Ok(estimate)
    }
}

/// Which parameters the record determined: those with a standard error
/// below 10 % of their value (a ±2σ interval of ±20 %), and the others.
pub fn determined_note(estimate: &Estimate) -> String {
    let (determined, not): (Vec<_>, Vec<_>) = estimate
        .parameters
        .iter()
        .partition(|p| p.standard_error < 0.1 * p.value.abs());
    let names = |list: Vec<&crate::estimate::ParameterEstimate>| {
        if list.is_empty() {
            "none".to_string()
        } else {
            list.iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    format!(
        "determined to 10 % (σ < 0.1·|value|): {}; not: {}",
        names(determined),
        names(not)
    )
}

/// The smoothed histories on the filter's grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothed {
    /// Grid times (s).
    pub times: Vec<f64>,
    /// Smoothed states x_{k|N} (the layout of
    /// [`crate::model::coefficient_states`]).
    pub states: Vec<DVector<f64>>,
    /// Their standard deviations √diag P_{k|N}.
    pub deviations: Vec<DVector<f64>>,
    /// The observations compared, in order.
    pub observations: Vec<String>,
    /// What the pass found (observations used and absent, how well each
    /// coefficient history is determined).
    pub notes: Vec<String>,
}

/// The history columns of [`Smoothed::write_csv`]: name, unit, value of a state.
type Column = (&'static str, &'static str, fn(&[f64]) -> f64);

const HISTORY_COLUMNS: &[Column] = &[
    ("CX", "-", |x| x[coefficient_states::coefficient(0)]),
    ("CY", "-", |x| x[coefficient_states::coefficient(1)]),
    ("CZ", "-", |x| x[coefficient_states::coefficient(2)]),
    ("Cl", "-", |x| x[coefficient_states::coefficient(3)]),
    ("Cm", "-", |x| x[coefficient_states::coefficient(4)]),
    ("Cn", "-", |x| x[coefficient_states::coefficient(5)]),
    ("CL", "-", |x| wind_axes(x).0),
    ("CD", "-", |x| wind_axes(x).1),
    ("airspeed", "m/s", |x| speed(x)),
    ("alpha", "rad", |x| x[U + 2].atan2(x[U])),
    ("beta", "rad", |x| {
        (x[U + 1] / speed(x)).clamp(-1.0, 1.0).asin()
    }),
    ("p", "rad/s", |x| x[P]),
    ("q", "rad/s", |x| x[P + 1]),
    ("r", "rad/s", |x| x[P + 2]),
    ("roll", "rad", |x| x[PHI]),
    ("pitch", "rad", |x| x[THETA]),
    ("yaw", "rad", |x| x[PSI]),
    ("altitude", "m", |x| x[H]),
];

fn speed(x: &[f64]) -> f64 {
    (x[U] * x[U] + x[U + 1] * x[U + 1] + x[U + 2] * x[U + 2]).sqrt()
}

/// (CL, CD) of a state: CL = CX·sin α − CZ·cos α, CD = −CX·cos α − CZ·sin α.
fn wind_axes(x: &[f64]) -> (f64, f64) {
    let (sin, cos) = x[U + 2].atan2(x[U]).sin_cos();
    let (cx, cz) = (
        x[coefficient_states::coefficient(0)],
        x[coefficient_states::coefficient(2)],
    );
    (cx * sin - cz * cos, -cx * cos - cz * sin)
}

impl Smoothed {
    /// The six smoothed body-axis coefficients (CX … Cn) with their
    /// standard deviations, as an estimate's histories.
    pub fn coefficient_histories(&self) -> Vec<History> {
        COEFFICIENT_NAMES
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let state = coefficient_states::coefficient(i);
                History {
                    name: (*name).to_string(),
                    times: self.times.clone(),
                    values: self.states.iter().map(|x| x[state]).collect(),
                    sigma: self.deviations.iter().map(|d| d[state]).collect(),
                }
            })
            .collect()
    }

    /// Writes the histories as CSV: time, the six body-axis coefficients,
    /// CL, CD, the air data, rates, attitude and altitude, then the
    /// standard deviation of each coefficient (`sigma_CX` …), header
    /// `name [unit]` as the truth trace's, so that a plot can lay one over
    /// the other.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let io_error = |source: std::io::Error| aeroid_core::error::write_error(path, source);
        let mut writer = csv::Writer::from_path(path).map_err(|e| io_error(e.into()))?;
        let mut header = vec!["time [s]".to_string()];
        header.extend(HISTORY_COLUMNS.iter().map(|(n, u, _)| format!("{n} [{u}]")));
        header.extend(COEFFICIENT_NAMES.iter().map(|n| format!("sigma_{n} [-]")));
        writer
            .write_record(&header)
            .map_err(|e| io_error(e.into()))?;
        for ((t, x), sigma) in self.times.iter().zip(&self.states).zip(&self.deviations) {
            let mut row = vec![t.to_string()];
            row.extend(
                HISTORY_COLUMNS
                    .iter()
                    .map(|(_, _, f)| f(x.as_slice()).to_string()),
            );
            row.extend((0..6).map(|i| sigma[coefficient_states::coefficient(i)].to_string()));
            writer.write_record(&row).map_err(|e| io_error(e.into()))?;
        }
        writer.flush().map_err(io_error)
    }

    /// The smoothed value of a body-axis coefficient (0 CX … 5 Cn) at each grid point.
    pub fn coefficient(&self, i: usize) -> Vec<f64> {
        self.states
            .iter()
            .map(|x| x[coefficient_states::coefficient(i)])
            .collect()
    }
}

/// What a record and structure need of channels: (name, purpose).
fn needed_inputs(structure: &ModelStructure, plans: &[Plan]) -> Vec<(&'static str, String)> {
    let mut needs: Vec<(&'static str, String)> = Vec::new();
    for plan in plans {
        for regressor in plan.terms.iter().flat_map(|(term, _)| term.factors()) {
            let control = match regressor {
                Regressor::Elevator => Some(Control::Elevator),
                Regressor::Aileron => Some(Control::Aileron),
                Regressor::Rudder => Some(Control::Rudder),
                Regressor::Flap => Some(Control::Flap),
                _ => None,
            };
            if let Some(control) = control
                && !needs.iter().any(|(n, _)| *n == control.name())
            {
                needs.push((control.name(), format!("regressor '{}'", regressor.key())));
            }
        }
    }
    if structure.aircraft.propulsion.max_thrust > 0.0 {
        needs.push(("throttle", "thrust".into()));
    }
    needs
}

/// The thrust input on the grid `times`: the record's `thrust` channel (N)
/// when it has one, else the throttle when the aircraft has propulsion
/// (zeros without), and whether it is the measured thrust.
fn thrust_input(
    record: &FlightRecord,
    structure: &ModelStructure,
    times: &[f64],
) -> Result<(Vec<f64>, bool)> {
    let finite = |values: Vec<f64>| -> Vec<f64> {
        values
            .into_iter()
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect()
    };
    if let Ok(thrust) = record.channel("thrust") {
        return Ok((finite(thrust.values_at(times)?), true));
    }
    Ok(match record.channel("throttle") {
        Ok(channel) if structure.aircraft.propulsion.max_thrust > 0.0 => {
            (finite(channel.values_at(times)?), false)
        }
        _ => (vec![0.0; times.len()], false),
    })
}

/// The record with an `altitude` channel: its own, else the pressure
/// altitude (the ISA altitude of the static pressure, which on a standard
/// day is the altitude the model's ISA density is read at), with a note.
fn with_altitude(record: &FlightRecord) -> (std::borrow::Cow<'_, FlightRecord>, Option<String>) {
    if record.channel("altitude").is_ok() {
        return (std::borrow::Cow::Borrowed(record), None);
    }
    let Ok(pressure) = record.channel(ALTITUDE_SUBSTITUTES[0]) else {
        return (std::borrow::Cow::Borrowed(record), None);
    };
    let mut altitude = pressure.clone();
    altitude.name = "altitude".into();
    altitude.source = format!("the record's pressure_altitude ({})", pressure.source);
    let mut with = record.clone();
    with.channels.push(altitude);
    (
        std::borrow::Cow::Owned(with),
        Some("no altitude channel: the pressure altitude observes h (the ISA of a standard day; a temperature offset would scale ḣ by T/T_ISA)".into()),
    )
}

/// The filter's observations: the needed ones, then the optional ones the
/// record has; a refusal naming every needed channel that is missing (and
/// every missing input).
fn observations_and_inputs(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: &[Plan],
) -> Result<(Vec<Output>, Vec<String>)> {
    let mut missing: Vec<MissingChannel> = Vec::new();
    let mut outputs: Vec<Output> = Vec::new();
    let has = |name: &str| {
        record.channel(name).is_ok()
            || (name == "altitude" && record.channel(ALTITUDE_SUBSTITUTES[0]).is_ok())
    };
    for name in &settings.observations {
        if !has(name) {
            missing.push(MissingChannel {
                name: name.clone(),
                purpose: "observation (Wang et al. 2012, Eq. 8)".into(),
            });
        } else if let Some(output) = Output::parse(name).filter(|o| !outputs.contains(o)) {
            outputs.push(output);
        }
    }
    for (name, purpose) in needed_inputs(structure, plans) {
        let measured_thrust = name == "throttle" && record.channel("thrust").is_ok();
        if record.channel(name).is_err() && !measured_thrust {
            missing.push(MissingChannel {
                name: name.to_string(),
                purpose,
            });
        }
    }
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(METHOD, missing, present) {
        return Err(Error::Refused(refusal));
    }
    let mut absent = Vec::new();
    for name in &settings.optional_observations {
        match Output::parse(name) {
            Some(output) if record.channel(name).is_ok() => {
                if !outputs.contains(&output) {
                    outputs.push(output);
                }
            }
            _ => absent.push(name.clone()),
        }
    }
    Ok((outputs, absent))
}

/// The record with its yaw channel unwrapped (no jump of 2π between
/// samples), so that the filter compares a continuous heading (an
/// estimation problem's records are already; `smooth` may be given others).
fn unwrapped_yaw(record: &FlightRecord) -> FlightRecord {
    let mut record = record.clone();
    if let Some(channel) = record.channels.iter_mut().find(|c| c.name == "yaw") {
        aeroid_record::unwrap_angles(&mut channel.values);
    }
    record
}

/// A channel's value at t, or `default` when the record lacks it.
fn value_or(record: &FlightRecord, name: &str, t: f64, default: f64) -> f64 {
    record
        .channel(name)
        .ok()
        .and_then(|c| c.value_at(t))
        .filter(|v| v.is_finite())
        .unwrap_or(default)
}

/// The initial estimate at the window's start: the recorded air data,
/// attitude, altitude and rates (α from the pitch angle and β = 0 when not
/// recorded; rates 0), the force coefficients from the load factors (Eq. 8
/// inverted), the moment coefficients those of no angular acceleration
/// (M_aero = ω × I·ω − r_T × T), derivatives 0.
fn initial_estimate(
    record: &FlightRecord,
    model: &CoefficientStates,
    settings: &SmoothedRegressionSettings,
    start: f64,
    period: f64,
) -> (Gaussian, GaussMarkov) {
    let aircraft = model.aircraft();
    let pitch = value_or(record, "pitch", start, 0.0);
    let airspeed = value_or(record, "airspeed", start, 100.0);
    let alpha = value_or(record, "alpha", start, pitch);
    let beta = value_or(record, "beta", start, 0.0);
    let rates = Vector3::new(
        value_or(record, "p", start, 0.0),
        value_or(record, "q", start, 0.0),
        value_or(record, "r", start, 0.0),
    );
    let mut x = DVector::zeros(STATE_COUNT);
    x[U] = airspeed * alpha.cos() * beta.cos();
    x[U + 1] = airspeed * beta.sin();
    x[U + 2] = airspeed * alpha.sin() * beta.cos();
    for i in 0..3 {
        x[P + i] = rates[i];
    }
    x[PHI] = value_or(record, "roll", start, 0.0);
    x[THETA] = pitch;
    x[PSI] = value_or(record, "yaw", start, 0.0);
    x[H] = value_or(record, "altitude", start, 0.0);
    let air = Atmosphere::default().at(x[H]);
    let scale = 0.5 * air.density * airspeed * airspeed * aircraft.wing_area;
    let throttle = value_or(record, "throttle", start, 0.0);
    let propulsion = &aircraft.propulsion;
    let measured = value_or(record, "thrust", start, f64::NAN);
    let thrust = if measured.is_finite() {
        propulsion.direction * measured
    } else if propulsion.max_thrust > 0.0 {
        propulsion.direction * propulsion.thrust(throttle, air.log_density_ratio)
    } else {
        Vector3::zeros()
    };
    let weight = aircraft.mass.mass * STANDARD_GRAVITY;
    let load = Vector3::new(
        value_or(record, "nx", start, 0.0),
        value_or(record, "ny", start, 0.0),
        -value_or(record, "nz", start, 1.0),
    );
    let inertia = aircraft.mass.inertia;
    let moment = rates.cross(&(inertia * rates)) - propulsion.position.cross(&thrust);
    let geometry = &aircraft.geometry;
    let arms = Vector3::new(geometry.span, geometry.chord, geometry.span);
    for i in 0..3 {
        x[coefficient_states::coefficient(i)] = (load[i] * weight - thrust[i]) / scale;
        x[coefficient_states::coefficient(3 + i)] = moment[i] / (scale * arms[i]);
    }
    let mut gains = [0.0; 6];
    for i in 0..3 {
        gains[i] = scale / aircraft.mass.mass;
        gains[3 + i] = aircraft.mass.inertia_inverse[(i, i)] * arms[i] * scale;
    }
    let markov = GaussMarkov::for_period(settings, &gains, period);
    let mut deviations = vec![1.0, 1.0, 1.0, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 5.0];
    for initial in &markov.initial {
        deviations.extend(initial);
    }
    let covariance = DMatrix::from_diagonal(&DVector::from_iterator(
        STATE_COUNT,
        deviations.iter().map(|s| s * s),
    ));
    (
        Gaussian {
            mean: x,
            covariance,
        },
        markov,
    )
}

/// The Gauss–Markov model of each coefficient (CX, CY, CZ, Cl, Cm, Cn) for
/// observations sampled every T: the spectral density of its third
/// derivative and the initial standard deviations of the coefficient and
/// its two derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussMarkov {
    pub density: [f64; 6],
    pub initial: [[f64; 3]; 6],
    /// For a lowered coefficient, the white process noise density its axis
    /// takes instead (on u̇, v̇, ẇ for CX, CY, CZ in m²/s³; on ṗ, q̇, ṙ for
    /// Cl, Cm, Cn in rad²/s³): bound²·T, the bound's spread over one
    /// sample period as white noise; 0 where the chain is not lowered.
    pub white: [f64; 6],
    /// Coefficients whose density or initial deviations the bound lowered.
    pub bounded: Vec<&'static str>,
}

impl GaussMarkov {
    /// The settings' densities and deviations, each lowered where over one
    /// sample period T of the observations it would spread the
    /// coefficient's specific force or angular acceleration by more than
    /// `force_change_bound` or `moment_change_bound` (`gains`: the
    /// acceleration per unit coefficient, q̄S/m for a force,
    /// I⁻¹_ii·L_i·q̄S for a moment, L the span or chord). With σ_C =
    /// bound/gain the coefficient's largest spread over T: a white third
    /// derivative of density q spreads it by q·T⁵/20 (variance), so
    /// q ≤ 20·σ_C²/T⁵; the initial first and second derivatives by σ′·T and
    /// σ″·T²/2, so σ′ ≤ σ_C/T and σ″ ≤ 2·σ_C/T². A lowered coefficient's
    /// axis takes white process noise of density bound²·T instead
    /// ([`GaussMarkov::white`]).
    ///
    /// Why: between two samples nothing restores the motion (the model has
    /// no aerodynamic stiffness or damping). At 25 Hz a sample follows
    /// within 0.04 s; on a 1 Hz QAR the default moment chains spread each
    /// moment coefficient by σ = 7 in one second, the predicted σ of p
    /// reaches about 200 rad/s (103 rad/s² per unit Cl times
    /// √(q·T⁷/252)) and the body velocity departs after 3 s. Lowered
    /// chains without the white noise are overconfident instead: the
    /// turbulence moves the coefficients faster than they may follow, the
    /// extrapolated slope and curvature make the predicted yaw rate and
    /// sideslip overshoot from sample to sample (the ψ, β and r
    /// innovations alternate in sign, growing from 5σ to 10σ; airspeed
    /// innovations of 10–40σ), and the filter departs after 15–55 s. The
    /// white noise gives the same spread over one sample without an
    /// extrapolated slope.
    ///
    /// For a transport at 25 Hz the default bounds lie above the default
    /// densities (the tightest, Cl at q̄ = 10 kPa, allows about 1100 1/s⁵ against
    /// the 1000 set) and change nothing; at 10 Hz they lower Cl and Cn.
    pub fn for_period(
        settings: &SmoothedRegressionSettings,
        gains: &[f64; 6],
        period: f64,
    ) -> GaussMarkov {
        let mut markov = GaussMarkov {
            density: [0.0; 6],
            initial: [[0.0; 3]; 6],
            white: [0.0; 6],
            bounded: Vec::new(),
        };
        for (i, gain) in gains.iter().enumerate() {
            let (density, initial, bound) = if i < 3 {
                (
                    settings.force_noise,
                    settings.initial_force_std,
                    settings.force_change_bound,
                )
            } else {
                (
                    settings.moment_noise,
                    settings.initial_moment_std,
                    settings.moment_change_bound,
                )
            };
            let spread = if *gain > 0.0 && gain.is_finite() {
                bound / gain
            } else {
                f64::INFINITY
            };
            let lowered = [
                density.min(20.0 * spread * spread / period.powi(5)),
                initial[1].min(spread / period),
                initial[2].min(2.0 * spread / (period * period)),
            ];
            if lowered != [density, initial[1], initial[2]] {
                markov.bounded.push(COEFFICIENT_NAMES[i]);
                markov.white[i] = bound * bound * period;
            }
            markov.density[i] = lowered[0];
            markov.initial[i] = [initial[0], lowered[1], lowered[2]];
        }
        markov
    }
}

/// The process noise spectral density (diagonal): velocities, rates, the
/// coefficients' third derivatives.
fn process_noise(settings: &SmoothedRegressionSettings, markov: &GaussMarkov) -> DMatrix<f64> {
    let mut density = DVector::zeros(STATE_COUNT);
    for i in 0..3 {
        density[U + i] = settings.velocity_noise.max(markov.white[i]);
        density[P + i] = settings.rate_noise.max(markov.white[3 + i]);
    }
    for (i, value) in markov.density.iter().enumerate() {
        density[coefficient_states::coefficient(i) + 2] = *value;
    }
    DMatrix::from_diagonal(&density)
}

/// Runs the EKF and the modified Bryson–Frazier smoother over the record
/// (steps 1–3 of the module header); the grid is the fastest observation's
/// sample period over the window where every needed observation has
/// samples.
pub fn smooth(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
) -> Result<Smoothed> {
    let plans = equation_error::plans(structure, METHOD).unwrap_or_default();
    smooth_with(
        record,
        structure,
        settings,
        &plans,
        Keep::SEQUENTIAL_SMOOTHER,
    )
}

/// The `ebm` pass set up on a record, as [`smooth`] runs it: the
/// coefficient-state model on its grid (the fastest observation's sample
/// period, cut to `max_step`), the filter's initial estimate and noise,
/// and the observations on the grid.
pub struct SmootherSetup {
    pub model: CoefficientStates,
    pub initial: Gaussian,
    pub noise: Noise,
    pub observations: Observations,
    /// The grid's times, first time and step.
    times: Vec<f64>,
    start: f64,
    step: f64,
    /// Grid points to a sample period.
    parts: usize,
    period: f64,
    names: Vec<String>,
    absent: Vec<String>,
    derived: Vec<String>,
    markov: GaussMarkov,
    altitude_note: Option<String>,
    thrust_measured: bool,
}

impl SmootherSetup {
    /// The set-up of [`smooth`] on `record`.
    pub fn new(
        record: &FlightRecord,
        structure: &ModelStructure,
        settings: &SmoothedRegressionSettings,
    ) -> Result<SmootherSetup> {
        let plans = equation_error::plans(structure, METHOD).unwrap_or_default();
        SmootherSetup::with_plans(record, structure, settings, &plans)
    }

    fn with_plans(
        record: &FlightRecord,
        structure: &ModelStructure,
        settings: &SmoothedRegressionSettings,
        plans: &[Plan],
    ) -> Result<SmootherSetup> {
        let (outputs, absent) = observations_and_inputs(record, structure, settings, plans)?;
        let (record, altitude_note) = with_altitude(record);
        let record = record.as_ref();
        let names: Vec<String> = outputs.iter().map(|o| o.channel().to_string()).collect();
        let (start, end) = fitting_window(record, &settings.observations, None)?;
        let mut fastest: f64 = 0.0;
        for name in &names {
            fastest = fastest.max(record.channel(name)?.rate);
        }
        if !(fastest > 0.0 && fastest.is_finite()) {
            return Err(Error::Other(
                "ebm: the observations have no sample rate".into(),
            ));
        }
        let period = 1.0 / fastest;
        let parts = ((period / settings.max_step) - 1e-9).ceil().max(1.0) as usize;
        let step = period / parts as f64;
        let len = ((end - start) / step + 1e-9).floor() as usize + 1;
        if len < 3 * parts {
            return Err(Error::Refused(Refusal::TooFewData {
                method: METHOD.to_string(),
                data: len / parts,
                unknowns: 3,
            }));
        }
        let times: Vec<f64> = (0..len).map(|k| start + k as f64 * step).collect();
        let (thrust, thrust_measured) = thrust_input(record, structure, &times)?;
        let record = unwrapped_yaw(record);
        let mut model = CoefficientStates::new(
            structure.aircraft.clone(),
            start,
            step,
            thrust,
            outputs.clone(),
        )?;
        if thrust_measured {
            model = model.with_measured_thrust();
        }
        let observations = Observations::from_record(&record, &names, start, step, len)?;
        let defaults = SmoothedRegressionSettings::default().measurement_noise;
        let mut derived = Vec::new();
        let measurement = DVector::from_iterator(
            names.len(),
            names.iter().map(|name| {
                let computed = record
                    .channel(name)
                    .is_ok_and(|c| aeroid_record::prep::derive::is_derived(&c.source))
                    && settings.derived_measurement_noise.contains_key(name);
                if computed {
                    derived.push(name.clone());
                }
                let sigma = if computed {
                    settings.derived_measurement_noise[name]
                } else {
                    settings
                        .measurement_noise
                        .get(name)
                        .or_else(|| defaults.get(name))
                        .copied()
                        .unwrap_or(0.0)
                };
                let resolution = record
                    .channel(name)
                    .ok()
                    .and_then(|c| c.resolution)
                    .unwrap_or(0.0);
                (sigma * sigma + resolution * resolution / 12.0).max(1e-16)
            }),
        );
        let (initial, markov) = initial_estimate(&record, &model, settings, start, period);
        let noise = Noise {
            process: process_noise(settings, &markov),
            measurement,
        };
        Ok(SmootherSetup {
            model,
            initial,
            noise,
            observations,
            times,
            start,
            step,
            parts,
            period,
            names,
            absent,
            derived,
            markov,
            altitude_note,
            thrust_measured,
        })
    }

    /// The forward EKF over the grid (its covariance's transition by the
    /// second-order series, [`Discretisation::SecondOrder`]), keeping what
    /// `keep` says.
    pub fn filter(&self, keep: Keep) -> Result<extended_kalman::Pass> {
        extended_kalman::filter_with(
            &self.model,
            &[],
            self.initial.clone(),
            &self.noise,
            &self.observations,
            Discretisation::SecondOrder,
            keep,
        )
    }

    /// The modified Bryson–Frazier smoother back through `pass` (a
    /// [`SmootherSetup::filter`] that kept what `keep` says: the smoother
    /// goes back through the scalar updates ([`Keep::sequential`]) or the
    /// vector updates): the smoothed mean and variances at every grid
    /// point, all the histories read of it.
    pub fn smooth(pass: &extended_kalman::Pass, keep: Keep) -> Vec<(DVector<f64>, DVector<f64>)> {
        let updates: &dyn kalman::SmootherUpdates = if keep.sequential {
            &pass.scalar_updates
        } else {
            &pass.measured
        };
        if keep.sparse_transitions {
            kalman::mbf_smooth_variances(&pass.predicted, updates, &pass.sparse_transitions)
        } else {
            kalman::mbf_smooth_variances(&pass.predicted, updates, &pass.transitions)
        }
    }
}

/// [`smooth`] with the filter keeping what `keep` says
/// ([`SmootherSetup::smooth`]).
fn smooth_with(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: &[Plan],
    keep: Keep,
) -> Result<Smoothed> {
    let setup = SmootherSetup::with_plans(record, structure, settings, plans)?;
    let pass = setup.filter(keep)?;
    // The histories at the sample instants: every `parts`-th grid point.
    let mut smoothed = SmootherSetup::smooth(&pass, keep);
    drop(pass);
    let SmootherSetup {
        model,
        observations,
        times,
        start,
        step,
        parts,
        period,
        names,
        absent,
        derived,
        markov,
        altitude_note,
        thrust_measured,
        ..
    } = setup;
    let len = model.len();
    let mut times = times;
    if parts > 1 {
        smoothed = smoothed.into_iter().step_by(parts).collect();
        times = times.into_iter().step_by(parts).collect();
    }
    let mut notes = vec![format!(
        "EKF + modified Bryson–Frazier smoother over {len} points of {} s from {start:.3} s{}, observing {}{}",
        aeroid_record::rounded(step),
        if parts > 1 {
            format!(
                " ({parts} to the sample period; the histories at the {} s samples)",
                aeroid_record::rounded(period)
            )
        } else {
            String::new()
        },
        names.join(", "),
        if absent.is_empty() {
            String::new()
        } else {
            format!("; not in the record: {}", absent.join(", "))
        }
    )];
    notes.extend(observations.note(step));
    if !derived.is_empty() {
        notes.push(format!(
            "derived channels weighted by derived_measurement_noise: {}",
            derived.join(", ")
        ));
    }
    if !markov.bounded.is_empty() {
        notes.push(format!(
            "the Gauss–Markov models of {} lowered to the change bounds over the {} s sample period (third-derivative densities {})",
            markov.bounded.join(", "),
            aeroid_record::rounded(period),
            markov
                .density
                .iter()
                .zip(COEFFICIENT_NAMES)
                .map(|(q, name)| format!("{name} {q:.2e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    notes.extend(altitude_note);
    if thrust_measured {
        notes.push(
            "thrust: the record's 'thrust' channel, along the aircraft's thrust line, not the throttle and engine model".into(),
        );
    }
    // The standard deviations in the variances' own vectors.
    let (states, deviations): (Vec<DVector<f64>>, Vec<DVector<f64>>) = smoothed
        .into_iter()
        .map(|(mean, mut variances)| {
            variances.apply(|v| *v = v.max(0.0).sqrt());
            (mean, variances)
        })
        .unzip();
    notes.push(determination_note(&states, &deviations));
    Ok(Smoothed {
        times,
        states,
        deviations,
        observations: names,
        notes,
    })
}

/// How well each coefficient history is determined: its smoothed standard
/// deviation (RMS over the record) against its variation (standard
/// deviation about its mean).
fn determination_note(smoothed: &[DVector<f64>], deviations: &[DVector<f64>]) -> String {
    let items: Vec<String> = COEFFICIENT_NAMES
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let c = coefficient_states::coefficient(i);
            let n = smoothed.len() as f64;
            let mean = smoothed.iter().map(|x| x[c]).sum::<f64>() / n;
            let variation =
                (smoothed.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / n).sqrt();
            let sigma = (deviations.iter().map(|d| d[c] * d[c]).sum::<f64>() / n).sqrt();
            format!("{name} σ {sigma:.2e} (variation {variation:.2e})")
        })
        .collect();
    format!(
        "smoothed coefficient histories, RMS standard deviation against the history's own variation: {}",
        items.join(", ")
    )
}

/// The smoothed coefficients and regressors as the regression's data:
/// every grid point, the coefficients in the structure's axes, the
/// regressors from the smoothed states and the recorded controls.
pub(crate) fn regression_data(
    record: &FlightRecord,
    structure: &ModelStructure,
    smoothed: &Smoothed,
    plans: &[Plan],
    step_margin: f64,
) -> Result<Reconstruction> {
    let steps = crate::reconstruction::control_steps(record);
    let near_step = |t: f64| {
        let i = steps.partition_point(|&s| s < t - step_margin);
        steps.get(i).is_some_and(|&s| s <= t + step_margin)
    };
    let aero = &structure.aircraft.aero;
    let request = equation_error::request(plans);
    let mut controls: Vec<Vec<f64>> = vec![vec![0.0; smoothed.times.len()]; Control::ALL.len()];
    for control in Control::ALL {
        if let Ok(channel) = record.channel(control.name()) {
            controls[control.index()] = channel.values_at(&smoothed.times)?;
        }
    }
    let (thrust, thrust_measured) = thrust_input(record, structure, &smoothed.times)?;
    let mut model = CoefficientStates::new(
        structure.aircraft.clone(),
        smoothed.times[0],
        smoothed.times[1] - smoothed.times[0],
        thrust,
        Vec::new(),
    )?;
    if thrust_measured {
        model = model.with_measured_thrust();
    }
    let atmosphere = Atmosphere::default();
    let mut data = Reconstruction {
        times: Vec::new(),
        coefficients: Default::default(),
        regressors: Vec::new(),
        reference_channel: "ebm grid".into(),
        dynamic_pressure: Vec::new(),
        rate: 1.0 / (smoothed.times[1] - smoothed.times[0]),
        notes: Vec::new(),
    };
    for &coefficient in &request.coefficients {
        data.coefficients[coefficient as usize] = Some(Vec::new());
    }
    let (mut dropped, mut at_steps) = (0, 0);
    for (k, (&t, x)) in smoothed.times.iter().zip(&smoothed.states).enumerate() {
        if near_step(t) {
            at_steps += 1;
            continue;
        }
        let x = x.as_slice();
        let airspeed = speed(x);
        let (u, w) = (x[U], x[U + 2]);
        let rates = model.rates(t, x, &[])?;
        let alpha_dot = (u * rates[U + 2] - w * rates[U]) / (u * u + w * w);
        let input = AeroInput {
            alpha: w.atan2(u),
            beta: (x[U + 1] / airspeed).clamp(-1.0, 1.0).asin(),
            airspeed,
            mach: airspeed / atmosphere.at(x[H]).speed_of_sound,
            rates: Vector3::new(x[P], x[P + 1], x[P + 2]),
            alpha_dot,
            measured_alpha_dot: None,
            controls: Controls::from_fn(|i, _| controls[i][k]),
            chi: 1.0,
        };
        let (lift, drag) = match aero.force_axes {
            ForceAxes::Wind => wind_axes(x),
            ForceAxes::Body => (
                x[coefficient_states::coefficient(2)],
                x[coefficient_states::coefficient(0)],
            ),
        };
        let all = [
            lift,
            x[coefficient_states::coefficient(1)],
            drag,
            x[coefficient_states::coefficient(3)],
            x[coefficient_states::coefficient(4)],
            x[coefficient_states::coefficient(5)],
        ];
        let mut regressors: [f64; REGRESSOR_COUNT] = aero.regressors(&input, 1.0);
        regressors[Regressor::LiftSquared as usize] = lift * lift;
        let finite = request
            .regressors
            .iter()
            .all(|&r| regressors[r as usize].is_finite())
            && request
                .coefficients
                .iter()
                .all(|&c| all[c as usize].is_finite());
        if !finite {
            dropped += 1;
            continue;
        }
        data.times.push(t);
        data.regressors.push(regressors);
        for (series, value) in data.coefficients.iter_mut().zip(all) {
            if let Some(series) = series {
                series.push(value);
            }
        }
    }
    data.notes.push(format!(
        "regression on the smoothed coefficients at {} grid points (regressors α, β, V, rates, α̇ from the smoothed states, controls from the record); {at_steps} points within {step_margin} s of a control step left out{}",
        data.times.len(),
        if dropped > 0 {
            format!("; {dropped} points left out (a control not finite)")
        } else {
            String::new()
        }
    ));
    Ok(data)
}

/// Steps 1–5 of the module header: the smoothed histories and the estimate.
pub fn smooth_and_regress(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
) -> Result<(Smoothed, Estimate)> {
    let plans = equation_error::plans(structure, METHOD)?;
    let smoothed = smooth_with(
        record,
        structure,
        settings,
        &plans,
        Keep::SEQUENTIAL_SMOOTHER,
    )?;
    let estimate = regress_smoothed(record, structure, settings, plans, &smoothed)?;
    Ok((smoothed, estimate))
}

/// Step 5 of the module header: the regression of the smoothed histories.
fn regress_smoothed(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: Vec<Plan>,
    smoothed: &Smoothed,
) -> Result<Estimate> {
    let data = regression_data(record, structure, smoothed, &plans, settings.step_margin)?;
    Ok(equation_error::regress(
        record,
        structure,
        METHOD,
        &[(plans, data)],
        settings.correlation_lag,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_record::Channel;
    use std::f64::consts::PI;

    /// The scalar updates and their smoother give the vector updates'
    /// results to rounding (module header, steps 2–3: equal in exact
    /// arithmetic), on the record the `ebm_smoother_pass` bench runs on
    /// (ATTAS lateral multistep, flight-test-25hz, 1501 points, 28 states,
    /// 13 outputs): each smoothed state within 1e-9 of its largest value
    /// over the record, each standard deviation within 1e-9 of its largest
    /// (rounding carried through 1501 filter and smoother steps, the
    /// covariance shrinking by orders of magnitude, is about 1e-12 and
    /// below; an error in the sequence's algebra moves them by its own
    /// size), the regressed estimates within 1e-6 of their standard errors
    /// and those within 1e-8 relative.
    #[test]
    fn scalar_and_vector_updates_smooth_alike() {
        use aeroid_record::recorder::{Profile, record_scenario};
        use aeroid_sim::scenario::Scenario;
        let scenario = Scenario::load("attas-lateral-multistep").unwrap();
        let profile = Profile::load("flight-test-25hz", None).unwrap();
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        let structure = ModelStructure::load("attas-lateral").unwrap();
        let settings = SmoothedRegressionSettings::default();
        let run = |keep: Keep| {
            let plans = equation_error::plans(&structure, METHOD).unwrap();
            let smoothed = smooth_with(&record, &structure, &settings, &plans, keep).unwrap();
            let estimate =
                regress_smoothed(&record, &structure, &settings, plans, &smoothed).unwrap();
            (smoothed, estimate)
        };
        let (scalar, scalar_estimate) = run(Keep::SEQUENTIAL_SMOOTHER);
        let (vector, vector_estimate) = run(Keep::SMOOTHER);
        assert_eq!(scalar.states.len(), vector.states.len());
        let worst = |of: fn(&Smoothed) -> &Vec<DVector<f64>>| {
            let (a, b) = (of(&scalar), of(&vector));
            (0..STATE_COUNT)
                .map(|i| {
                    let largest = b.iter().map(|x| x[i].abs()).fold(0.0, f64::max);
                    let difference = a
                        .iter()
                        .zip(b)
                        .map(|(x, y)| (x[i] - y[i]).abs())
                        .fold(0.0, f64::max);
                    difference / largest.max(f64::MIN_POSITIVE)
                })
                .fold(0.0, f64::max)
        };
        let (states, deviations) = (worst(|s| &s.states), worst(|s| &s.deviations));
        let (mut estimates, mut errors) = (0.0_f64, 0.0_f64);
        for (a, b) in scalar_estimate
            .parameters
            .iter()
            .zip(&vector_estimate.parameters)
        {
            assert_eq!(a.name, b.name);
            estimates = estimates.max((a.value - b.value).abs() / b.standard_error);
            errors = errors.max((a.standard_error - b.standard_error).abs() / b.standard_error);
        }
        println!(
            "scalar against vector updates: states {states:.1e}, deviations {deviations:.1e} of their largest; estimates {estimates:.1e} of their standard errors, those {errors:.1e} relative"
        );
        assert!(
            states < 1e-9 && deviations < 1e-9,
            "{states:e} {deviations:e}"
        );
        assert!(
            estimates < 1e-6 && errors < 1e-8,
            "{estimates:e} {errors:e}"
        );
    }

    /// A heading through ±180° becomes continuous; dropouts stay dropouts
    /// and do not break the unwrapping.
    #[test]
    fn yaw_is_unwrapped_across_the_branch_cut() {
        let values = vec![3.0, 3.1, f64::NAN, -3.1, -3.0, 3.05];
        let record = FlightRecord {
            channels: vec![Channel {
                name: "yaw".into(),
                unit: "rad".into(),
                rate: 1.0,
                resolution: None,
                source: "test".into(),
                times: (0..values.len()).map(|k| k as f64).collect(),
                values,
            }],
            ..FlightRecord::default()
        };
        let unwrapped = unwrapped_yaw(&record).channels[0].values.clone();
        let expected = [3.0, 3.1, f64::NAN, 2.0 * PI - 3.1, 2.0 * PI - 3.0, 3.05];
        for (u, e) in unwrapped.iter().zip(expected) {
            assert!(
                u.is_nan() && e.is_nan() || (u - e).abs() < 1e-12,
                "{unwrapped:?}"
            );
        }
    }

    /// The change bound: for a transport at q̄ = 10 kPa (accelerations per
    /// unit coefficient 36 m/s² for the forces, 103, 8 and 38 rad/s² for
    /// Cl, Cm, Cn) the default chains are left alone at 25 Hz; at 1 Hz each
    /// is lowered so that its spread over one sample period, the (0, 0)
    /// entry of the exact (Van Loan) discrete noise of the chain, times the
    /// gain is the bound, its initial derivative deviations to σ_C/T and
    /// 2·σ_C/T², and its axis takes white noise of bound²·T.
    #[test]
    fn change_bounds_hold_the_spread_over_one_sample_period() {
        use crate::solver::extended_kalman::Discretisation;
        let settings = SmoothedRegressionSettings::default();
        let gains = [36.0, 36.0, 36.0, 103.0, 8.0, 38.0];
        let fast = GaussMarkov::for_period(&settings, &gains, 0.04);
        assert!(fast.bounded.is_empty(), "{:?}", fast.bounded);
        assert_eq!(fast.white, [0.0; 6]);
        assert_eq!(fast.density[3], settings.moment_noise);
        let period = 1.0;
        let slow = GaussMarkov::for_period(&settings, &gains, period);
        assert_eq!(slow.bounded, COEFFICIENT_NAMES.to_vec());
        let chain = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        for (i, gain) in gains.iter().enumerate() {
            let bound = if i < 3 {
                settings.force_change_bound
            } else {
                settings.moment_change_bound
            };
            let mut density = DMatrix::zeros(3, 3);
            density[(2, 2)] = slow.density[i];
            let (_, noise) = Discretisation::Exact.transition_and_noise(&chain, &density, period);
            let spread = noise[(0, 0)].sqrt() * gain;
            assert!(
                (spread / bound - 1.0).abs() < 1e-9,
                "{i}: {spread} against {bound}"
            );
            let sigma = bound / gain;
            let initial = slow.initial[i];
            assert!(
                initial[1] <= sigma / period * (1.0 + 1e-12),
                "{i}: {initial:?}"
            );
            assert!(initial[2] <= 2.0 * sigma / (period * period) * (1.0 + 1e-12));
            assert_eq!(slow.white[i], bound * bound * period);
        }
        let q = process_noise(&settings, &slow);
        assert_eq!(q[(U, U)], settings.force_change_bound.powi(2) * period);
        assert_eq!(
            q[(P + 1, P + 1)],
            settings.moment_change_bound.powi(2) * period
        );
    }

    /// The process noise puts each setting on its states: the third
    /// derivatives of the coefficients, the velocities and the rates, and
    /// nothing on the kinematic angles, height or lower derivatives.
    #[test]
    fn process_noise_sits_on_the_third_derivatives_and_velocities() {
        let settings = SmoothedRegressionSettings::default();
        let markov = GaussMarkov::for_period(&settings, &[1.0; 6], 0.04);
        let q = process_noise(&settings, &markov);
        for i in 0..3 {
            let force = coefficient_states::coefficient(i);
            let moment = coefficient_states::coefficient(3 + i);
            assert_eq!(q[(force + 2, force + 2)], settings.force_noise);
            assert_eq!(q[(moment + 2, moment + 2)], settings.moment_noise);
            assert_eq!(q[(force, force)] + q[(force + 1, force + 1)], 0.0);
            assert_eq!(q[(U + i, U + i)], settings.velocity_noise);
            assert_eq!(q[(P + i, P + i)], settings.rate_noise);
        }
        for state in [PHI, THETA, PSI, H] {
            assert_eq!(q[(state, state)], 0.0);
        }
        assert_eq!(q.nrows(), STATE_COUNT);
        assert_eq!((&q - DMatrix::from_diagonal(&q.diagonal())).amax(), 0.0);
    }
}
