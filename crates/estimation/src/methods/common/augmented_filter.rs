//! The Kalman filter with the aerodynamic parameters as augmented states
//! (the X-31/F-18 HARV EKF note, seed 003; Jategaonkar, "Flight Vehicle
//! System Identification", 2nd ed., ch. 7) that the extended (`ekf`) and
//! the unscented (`ukf`) filters share: everything but the filter pass,
//! which each method gives [`augmented_estimate`]. Settings
//! `[methods.ekf]` and `[methods.ukf]` ([`FilterSettings`]); the user
//! reference is docs/methods.md, "Augmented-state extended Kalman filter".
//!
//! **Model** (the note's Eqs. 1–3): ẋ = f(x, u, θ) + w (Eq. 1),
//! z_k = h(x(t_k), u, θ) + v_k (Eq. 2), the free parameters θ_a made states
//! with θ̇_a = w_PN (Eq. 3): constant when the pseudonoise intensity Q_PN is
//! zero, a random walk otherwise. f and h are output error's record-driven
//! model ([`DrivenStateSpace::for_record`]); [`Augmented`] makes θ_a states
//! (Jategaonkar Eq. 7.8). On a linear structure the model is its linear
//! state-space model ([`LinearStructure::for_record`]), the free entries of
//! A, B, C, D and the biases the parameter states ([`Filtered`]).
//!
//! **Filter**: the continuous–discrete EKF of
//! [`extended_kalman::filter`](crate::solver::extended_kalman::filter)
//! (Jategaonkar §7.2, Eqs. 7.11–7.19; the note refers to Gelb, whose
//! Table 6.1-1 is the same filter), or the unscented one.
//!
//! **Noise** (the note's "EKF for parameter estimation" section):
//! 1. R by Fourier decomposition (the note's ref. 7; Klein & Morelli 2006,
//!    §11.2): σ² = (Σ_{f_k > f_c} |X_k|²)/(N·M) over the M bins above the
//!    motion's bandwidth f_c ([`fourier_noise_variance`]).
//! 2. The residual-correlation method (the note's ref. 6, Mehra, "On the
//!    identification of variances and adaptive Kalman filtering", IEEE TAC
//!    15(2), 1970, §IV, Eqs. 13, 29, 30, 33; `tuning`): after each pass the
//!    innovations' autocorrelations give R and the integrated states'
//!    process noise for the next; a pass that makes the record less likely
//!    (−ln L = ½·Σ(νᵀS⁻¹ν + ln det 2πS)) is discarded for zero-lag
//!    covariance matching. The passes stop when every output's mean ν²/S
//!    is within [`TUNED`] of 1, or after `passes`.
//!
//! **Estimate**: the final filtered augmented state and covariance, θ
//! started from equation error (`start = "ee"`) where it serves. **Status**:
//! converged when every parameter has settled over the last
//! [`SETTLING_FRACTION`] of the record and the data identified it (σ below
//! σ₀/√2); innovations beyond [`CONSISTENT`] are a diagnosis. **Histories**:
//! θ_a and σ at every grid point of the last pass ([`History::write_csv`]).

use crate::error::{Error, Result};
use crate::estimate::{Diagnosis, DiagnosisKind, Estimate, OutputFit, ParameterEstimate, Status};
use crate::estimator::{Refusal, Settings, parse_settings};
use crate::input_timing::{self, InputInterpolation};
use crate::linear_structure::LinearStructure;
use crate::methods::common::coefficient_fit::{Start, linear_start_estimate, start_estimate};
use crate::methods::common::refusals::{
    enough_data, free_parameters, missing_channels, unsuitable,
};
use crate::model::augmented::Augmented;
use crate::model::observations::Observations;
use crate::model::state_space::{DrivenStateSpace, StateSpaceModel, fitting_window};
use crate::problem::EstimationProblem;
use crate::solver::extended_kalman::{Innovation, Noise, Pass};
use crate::structure::{ModelStructure, Structure};
use aeroid_numerics::kalman::Gaussian;
use aeroid_record::{Channel, FlightRecord};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod tuning;
use tuning::normalised_innovations;

mod fourier_noise;
mod history;
mod status;
pub use fourier_noise::*;
pub use history::*;
use status::*;

/// The innovations are consistent when every output's mean normalised
/// squared innovation over the second half of the record is within this
/// of 1. Its sampling scatter is √(2/N) ≈ 0.05 for the 750 samples of a
/// 60 s, 25 Hz half-record; 0.25 leaves room for the linearisation.
pub const CONSISTENT: f64 = 0.25;

/// The residual-correlation passes stop once every output's mean
/// normalised squared innovation is within this of 1 (2 sampling σ of a
/// 60 s, 25 Hz half-record).
pub const TUNED: f64 = 0.1;

/// The last part of the record over which a parameter must have settled.
pub const SETTLING_FRACTION: f64 = 0.1;

/// Parameters of magnitude below this get this as the scale of their prior
/// σ and pseudonoise (aerodynamic derivatives are O(0.01–10) per radian).
pub const PARAMETER_SCALE: f64 = 0.1;

/// The smallest measurement noise σ, relative to a channel's standard
/// deviation: a noise-free record still needs a positive R, and one much
/// smaller leaves the posterior covariance so ill-conditioned that the
/// UKF's sigma points (a Cholesky factor) fail (at 10⁻⁶ they did, on the
/// noise-free lateral record).
const NOISE_FLOOR: f64 = 1e-4;

/// Settings of the augmented-state filters: the `[methods.ekf]` table, and
/// the `[methods.ukf]` table without its sigma-point keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilterSettings {
    /// Where θ starts: "ee" (equation error's estimate when it serves) or "model".
    pub start: Start,
    /// Prior σ of each parameter state, relative to max(|θ₀|, 0.1).
    pub initial_uncertainty: f64,
    /// Pseudonoise on every free parameter: σ growth per √s relative to
    /// max(|θ₀|, 0.1) (Q_PN = (value·scale)² per s). 0: constant parameters.
    pub pseudonoise: f64,
    /// Pseudonoise per parameter, overriding `pseudonoise`.
    pub pseudonoise_for: BTreeMap<String, f64>,
    /// Bandwidth of the motion (Hz): the spectrum above it is noise.
    pub motion_bandwidth: f64,
    /// Filter passes at most (1: the Fourier R and no process noise, no tuning).
    pub passes: usize,
    /// Whether the residual-correlation passes also tune the states' process noise.
    pub tune_process_noise: bool,
    /// The lags of the residual-correlation method: 0, the zero-lag
    /// covariance matching; k ≥ 1, Mehra's method with lags 1 … k; none,
    /// Mehra's method with as many lags as the model integrates states.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correlation_lags: Option<usize>,
    /// Grid step (s); none: the fastest output's period.
    #[serde(
        deserialize_with = "aeroid_core::units::optional_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub step: Option<f64>,
    /// Inputs inside a step ([`InputInterpolation`]; default: chosen per
    /// input from its samples).
    pub interpolation: InputInterpolation,
    /// A CSV file to write the parameter histories to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub history: Option<PathBuf>,
}

impl Default for FilterSettings {
    fn default() -> Self {
        FilterSettings {
            start: Start::EquationError,
            initial_uncertainty: 0.3,
            pseudonoise: 0.0,
            pseudonoise_for: BTreeMap::new(),
            motion_bandwidth: 2.0,
            passes: 4,
            tune_process_noise: true,
            correlation_lags: None,
            step: None,
            interpolation: InputInterpolation::default(),
            history: None,
        }
    }
}

/// Each key of [`FilterSettings`] with its meaning.
pub(crate) const FILTER_SETTINGS: [(&str, &str); 11] = [
    (
        "start",
        "\"ee\": θ from equation error's estimate when that method serves the model; \"model\": the model file's values",
    ),
    (
        "initial_uncertainty",
        "prior σ of each parameter state, relative to max(|θ₀|, 0.1)",
    ),
    (
        "pseudonoise",
        "parameter pseudonoise on every free parameter: σ growth per √s relative to max(|θ₀|, 0.1); 0: constant parameters",
    ),
    (
        "pseudonoise_for",
        "pseudonoise per parameter, e.g. { Cm_alpha = 0.2 }, overriding `pseudonoise`",
    ),
    (
        "motion_bandwidth",
        "bandwidth of the motion in Hz: each output's spectrum above it gives its noise floor (R)",
    ),
    (
        "passes",
        "filter passes at most; R and Q are re-estimated from the innovations between passes (residual-correlation method)",
    ),
    (
        "tune_process_noise",
        "whether the passes also tune the integrated states' process noise",
    ),
    (
        "correlation_lags",
        "none: Mehra's residual-correlation method with as many lags as the model integrates states; k ≥ 1: with the innovations' autocorrelations at lags 1 … k; 0: R and Q by zero-lag covariance matching",
    ),
    (
        "step",
        "grid step, e.g. \"0.04 s\"; none: the fastest output's period",
    ),
    (
        "interpolation",
        "inputs inside a step: \"auto\" (each input held where its samples are piecewise constant, linear where it ramps or moves; said in the notes), \"zoh\" (hold), \"linear\", or a table by channel, e.g. { aileron = \"linear\" }",
    ),
    (
        "history",
        "a CSV file to write θ and σ of every parameter state at every grid point to",
    ),
];

impl FilterSettings {
    /// Reads and checks a settings table of `method`, naming a bad key.
    pub fn read(method: &str, settings: &Settings) -> Result<FilterSettings> {
        let parsed: FilterSettings = parse_settings(method, settings)?;
        parsed.check(method)?;
        Ok(parsed)
    }

    /// Checks the values of a settings table of `method`, naming a bad key.
    pub fn check(&self, method: &str) -> Result<()> {
        let bad = |key: &str, message: String| {
            Err(Error::Setting {
                method: method.to_string(),
                reason: format!("{key}: {message}"),
            })
        };
        let non_negative = |v: f64| v >= 0.0 && v.is_finite();
        if !(self.initial_uncertainty > 0.0 && self.initial_uncertainty.is_finite()) {
            return bad(
                "initial_uncertainty",
                format!("must be positive, is {}", self.initial_uncertainty),
            );
        }
        self.interpolation.check_controls(method)?;
        if !non_negative(self.pseudonoise) {
            return bad(
                "pseudonoise",
                format!("must be at least 0, is {}", self.pseudonoise),
            );
        }
        if let Some((name, value)) = self
            .pseudonoise_for
            .iter()
            .find(|(_, v)| !non_negative(**v))
        {
            return bad(
                "pseudonoise_for",
                format!("{name} must be at least 0, is {value}"),
            );
        }
        if !(self.motion_bandwidth > 0.0 && self.motion_bandwidth.is_finite()) {
            return bad(
                "motion_bandwidth",
                format!("must be positive (Hz), is {}", self.motion_bandwidth),
            );
        }
        if self.passes == 0 {
            return bad("passes", "must be at least 1".into());
        }
        if self.step.is_some_and(|s| !(s > 0.0 && s.is_finite())) {
            return bad("step", "must be positive".into());
        }
        Ok(())
    }
}

/// On a linear structure, an error naming the settings of `method` it
/// does not take (the augmented filters' `interpolation`: a linear model
/// states it in its file).
pub fn refuse_for_linear(method: &str, problem: &EstimationProblem) -> Result<()> {
    match &problem.structure {
        Structure::Linear(structure) => crate::estimator::refuse_for_linear(
            method,
            &problem.settings,
            &structure.name,
            &[(
                "interpolation",
                "a linear model states its inputs' interpolation in its file",
            )],
        ),
        Structure::SixDof(_) => Ok(()),
    }
}

/// What an augmented filter produced: the estimate, the last pass's
/// parameter histories and its innovations per output.
#[derive(Debug, Clone)]
pub struct FilterRun {
    pub estimate: Estimate,
    pub history: History,
    /// Per output, the last pass's innovations.
    pub innovations: Vec<Vec<Innovation>>,
}

/// One filter pass over an augmented model (the EKF's or the UKF's).
pub type FilterPass<'a> =
    dyn Fn(&Augmented<dyn StateSpaceModel>, Gaussian, &Noise, &Observations) -> Result<Pass> + 'a;

/// A structure's parameters: names, start values, free flags, bounds.
struct Parameters<'a> {
    names: &'a [String],
    values: &'a [f64],
    free: &'a [bool],
    bounds: &'a [(f64, f64)],
}

/// A structure's state-space view on a record's grid.
struct View {
    model: Box<dyn StateSpaceModel>,
    x0: DVector<f64>,
    state_names: Vec<String>,
    notes: Vec<String>,
}

/// The model structure an augmented filter runs on: the 6-DOF equations
/// driven by the record ([`DrivenStateSpace::for_record`]) or a linear
/// state-space model driven by its input channels
/// ([`LinearStructure::for_record`], its exact discretisation and the
/// model file's `interpolation`).
#[derive(Debug, Clone, Copy)]
pub enum Filtered<'a> {
    SixDof(&'a ModelStructure),
    Linear(&'a LinearStructure),
}

impl<'a> From<&'a ModelStructure> for Filtered<'a> {
    fn from(structure: &'a ModelStructure) -> Filtered<'a> {
        Filtered::SixDof(structure)
    }
}

impl<'a> From<&'a LinearStructure> for Filtered<'a> {
    fn from(structure: &'a LinearStructure) -> Filtered<'a> {
        Filtered::Linear(structure)
    }
}

impl<'a> From<&'a Structure> for Filtered<'a> {
    fn from(structure: &'a Structure) -> Filtered<'a> {
        match structure {
            Structure::SixDof(s) => Filtered::SixDof(s),
            Structure::Linear(s) => Filtered::Linear(s),
        }
    }
}

impl Filtered<'_> {
    fn name(&self) -> &str {
        match self {
            Filtered::SixDof(s) => &s.name,
            Filtered::Linear(s) => &s.name,
        }
    }

    fn outputs(&self) -> &[String] {
        match self {
            Filtered::SixDof(s) => &s.outputs,
            Filtered::Linear(s) => &s.outputs,
        }
    }

    /// Every parameter's name, start value (the model file's), free flag
    /// and bounds.
    fn parameters(&self) -> Parameters<'_> {
        match self {
            Filtered::SixDof(s) => Parameters {
                names: s.aircraft.aero.parameters.names(),
                values: s.aircraft.aero.parameters.values(),
                free: &s.free,
                bounds: &s.bounds,
            },
            Filtered::Linear(s) => Parameters {
                names: &s.names,
                values: &s.starts,
                free: &s.free,
                bounds: &s.bounds,
            },
        }
    }

    fn free_names(&self) -> Vec<String> {
        match self {
            Filtered::SixDof(s) => s.free_names(),
            Filtered::Linear(s) => s.free_names(),
        }
    }

    /// Equation error's estimate on the record as a start, with the model
    /// file's `[methods.ee]` settings ([`start_estimate`] on a 6-DOF
    /// structure), or the reason there is none.
    fn equation_error_start(
        &self,
        record: &FlightRecord,
        given: Option<&Estimate>,
    ) -> std::result::Result<Estimate, String> {
        match self {
            Filtered::SixDof(structure) => start_estimate(record, structure, given),
            Filtered::Linear(structure) => linear_start_estimate(record, structure, given),
        }
    }

    /// The state-space view on the record's grid, the initial state, the
    /// state names and the view's notes.
    fn view(&self, record: &FlightRecord, settings: &FilterSettings) -> Result<View> {
        match self {
            Filtered::SixDof(structure) => {
                let (view, x0) = DrivenStateSpace::for_record(
                    record,
                    structure,
                    &settings.interpolation,
                    settings.step,
                    None,
                )?;
                let names = view.state_names().iter().map(|s| s.to_string()).collect();
                Ok(View {
                    notes: view.simulation().notes.clone(),
                    model: Box::new(view),
                    x0,
                    state_names: names,
                })
            }
            Filtered::Linear(structure) => {
                let (model, x0) = structure.for_record(record, settings.step, None)?;
                let note = format!(
                    "linear model '{}', exact discretisation; {} (the model file's `interpolation`)",
                    structure.name,
                    input_timing::note(&model.input_timing)
                );
                Ok(View {
                    model: Box::new(model),
                    x0,
                    state_names: structure.states.clone(),
                    notes: vec![note],
                })
            }
        }
    }
}

/// What every pass shares: the model view, the start, the prior, the
/// observations and the noise floors.
struct Setup {
    view: Box<dyn StateSpaceModel>,
    state_names: Vec<String>,
    x0: DVector<f64>,
    /// Every aerodynamic parameter, the free ones at their start.
    theta: Vec<f64>,
    /// Indices of the free parameters in θ.
    free: Vec<usize>,
    names: Vec<String>,
    observations: Observations,
    prior: DMatrix<f64>,
    /// Pseudonoise intensity per free parameter.
    pseudonoise: Vec<f64>,
    /// Fourier R per output and its floor.
    measurement: Vec<f64>,
    floors: Vec<f64>,
    notes: Vec<String>,
}

/// Refuses what no augmented filter can run on.
fn check(method: &str, record: &FlightRecord, structure: Filtered) -> Result<()> {
    let missing = match structure {
        Filtered::SixDof(s) => missing_channels(record, s),
        Filtered::Linear(s) => s.missing_channels(record),
    };
    let free = structure.parameters().free;
    free_parameters(method, record, missing, structure.name(), free)?;
    if let Filtered::SixDof(s) = structure {
        unsuitable(method, s)?;
    }
    Ok(())
}

/// The start θ and a note saying which: equation error's estimate
/// (`start = "ee"`) when that method serves the structure. The EKF is
/// linearised about its running estimate, and a start near the optimum
/// keeps the early transient, where a wide prior makes large gains act on
/// a poor linearisation, short; regression costs a fraction of a pass. The
/// prior σ of each parameter state is `initial_uncertainty` times
/// max(|θ₀|, 0.1), wide enough that the data, not the start, decide.
fn start_values(
    record: &FlightRecord,
    structure: Filtered,
    settings: &FilterSettings,
    given: Option<&Estimate>,
) -> (Vec<f64>, String) {
    let Parameters {
        names,
        values,
        free,
        bounds,
    } = structure.parameters();
    let mut theta = values.to_vec();
    if settings.start == Start::Model {
        return (theta, "θ started from the model file's values".into());
    }
    match structure.equation_error_start(record, given) {
        Ok(estimate) => {
            for (i, name) in names.iter().enumerate() {
                if let (true, Some(p)) = (free[i], estimate.parameter(name))
                    && p.value.is_finite()
                {
                    theta[i] = p.value.clamp(bounds[i].0, bounds[i].1);
                }
            }
            (theta, "θ started from equation error's estimate".into())
        }
        Err(reason) => (
            theta,
            format!("θ started from the model file's values: {reason}"),
        ),
    }
}

/// An error when `pseudonoise_for` names a parameter that is not free.
fn check_pseudonoise(method: &str, structure: Filtered, settings: &FilterSettings) -> Result<()> {
    match settings
        .pseudonoise_for
        .keys()
        .find(|name| !structure.free_names().contains(name))
    {
        Some(name) => Err(Error::Setting {
            method: method.to_string(),
            reason: format!(
                "pseudonoise_for: '{name}' is not a free parameter of model '{}'",
                structure.name()
            ),
        }),
        None => Ok(()),
    }
}

/// Each output's measurement noise variance from its spectrum above the
/// motion's band, with its floor, and a note per output (σ, and the
/// Fourier estimate's).
fn measurement_noise(
    record: &FlightRecord,
    outputs: &[String],
    settings: &FilterSettings,
) -> Result<(Vec<f64>, Vec<f64>, Vec<String>)> {
    let window = fitting_window(record, outputs, None)?;
    let mut measurement = Vec::new();
    let mut floors = Vec::new();
    let mut notes = Vec::new();
    for name in outputs {
        let channel = record.channel(name)?;
        let (variance, fourier, floor) = channel_noise(channel, window, settings.motion_bandwidth);
        measurement.push(variance);
        floors.push(floor);
        notes.push(format!(
            "{name} {:.3e} (Fourier {:.3e})",
            variance.sqrt(),
            fourier.sqrt()
        ));
    }
    Ok((measurement, floors, notes))
}

impl Setup {
    fn new(
        method: &str,
        record: &FlightRecord,
        structure: Filtered,
        settings: &FilterSettings,
        start: Option<&Estimate>,
    ) -> Result<Setup> {
        check(method, record, structure)?;
        let parameters = structure.parameters();
        let (names_all, free_flags) = (parameters.names, parameters.free);
        let outputs = structure.outputs();
        check_pseudonoise(method, structure, settings)?;
        let View {
            model: view,
            x0,
            state_names,
            notes: view_notes,
        } = structure.view(record, settings)?;
        if view.len() < 2 {
            return Err(Error::Refused(Refusal::TooFewData {
                method: method.to_string(),
                data: view.len(),
                unknowns: 2,
            }));
        }
        let (theta, start_note) = start_values(record, structure, settings, start);
        let free: Vec<usize> = (0..theta.len()).filter(|&i| free_flags[i]).collect();
        let names: Vec<String> = free.iter().map(|&i| names_all[i].clone()).collect();
        let step = view.time(1) - view.time(0);
        let observations =
            Observations::from_record(record, outputs, view.time(0), step, view.len())?;
        enough_data(method, &observations, free.len())?;
        let (measurement, floors, noise_notes) = measurement_noise(record, outputs, settings)?;
        let mut notes = vec![
            start_note,
            format!(
                "measurement noise σ from the spectrum above {} Hz: {}",
                settings.motion_bandwidth,
                noise_notes.join(", ")
            ),
        ];
        notes.extend(observations.note(step));
        notes.extend(view_notes);
        let setup = Setup {
            view,
            state_names,
            x0,
            theta,
            free,
            names,
            observations,
            prior: DMatrix::zeros(0, 0),
            pseudonoise: Vec::new(),
            measurement,
            floors,
            notes,
        };
        Ok(setup.with_prior(outputs, settings))
    }

    /// The setup with its prior covariance (a state's measurement variance
    /// where it is an output, else 0.01; a free parameter's initial
    /// uncertainty relative to its start) and each free parameter's
    /// pseudonoise.
    fn with_prior(mut self, outputs: &[String], settings: &FilterSettings) -> Setup {
        let (free, theta) = (&self.free, &self.theta);
        let scale = |v: f64| v.abs().max(PARAMETER_SCALE);
        let n = self.x0.len();
        let mut prior = DMatrix::zeros(n + free.len(), n + free.len());
        for (i, state) in self.state_names.iter().enumerate() {
            prior[(i, i)] = outputs
                .iter()
                .position(|o| o == state)
                .map_or(0.01, |o| self.measurement[o]);
        }
        for (j, &i) in free.iter().enumerate() {
            prior[(n + j, n + j)] = (settings.initial_uncertainty * scale(theta[i])).powi(2);
        }
        let pseudonoise: Vec<f64> = free
            .iter()
            .zip(&self.names)
            .map(|(&i, name)| {
                let relative = settings
                    .pseudonoise_for
                    .get(name)
                    .copied()
                    .unwrap_or(settings.pseudonoise);
                (relative * scale(theta[i])).powi(2)
            })
            .collect();
        self.prior = prior;
        self.pseudonoise = pseudonoise;
        self
    }
}

/// Runs the augmented filter `run` with the residual-correlation passes and
/// assembles the estimate and the last pass's parameter histories (module
/// header). Shared by the EKF and the UKF.
pub fn augmented_estimate<'a>(
    method: &str,
    record: &FlightRecord,
    structure: impl Into<Filtered<'a>>,
    settings: &FilterSettings,
    start: Option<&Estimate>,
    run: &FilterPass,
) -> Result<FilterRun> {
    let started = std::time::Instant::now();
    let structure: Filtered = structure.into();
    let mut setup = Setup::new(method, record, structure, settings, start)?;
    let n = setup.x0.len();
    let len = setup.view.len();
    let start_values: Vec<f64> = setup.free.iter().map(|&i| setup.theta[i]).collect();
    let mut passes = Passes {
        process_states: vec![0.0; n],
        theta: setup.theta.clone(),
        lags: settings.correlation_lags.unwrap_or(n),
        best: None,
        rejected: None,
        mehra_failed: false,
        costs: Vec::new(),
        report: String::from("pass  −ln L  mean ν²/S per output\n"),
    };
    let mut last = None;
    let mut pass_number = 0;
    while pass_number < settings.passes {
        pass_number += 1;
        let noise = pass_noise(&setup, &passes.process_states);
        let outcome = run_pass(&setup, &passes.theta, &noise, run)?;
        if worse(&outcome, passes.best.as_ref()) && passes.lags > 0 && passes.rejected.is_none() {
            passes.reject(pass_number, &outcome, &mut setup, settings);
            pass_number -= 1;
            continue;
        }
        let pass = match outcome {
            Ok(pass) => pass,
            Err(error) => {
                return Ok(FilterRun {
                    estimate: diverged(method, structure, record, &setup, &start_values, error),
                    history: History::empty(&setup.names),
                    innovations: Vec::new(),
                });
            }
        };
        passes.costs.push(pass.negative_log_likelihood);
        let ratios = normalised_innovations(&pass, len);
        passes.report += &report_line(pass_number, &pass, &ratios, structure.outputs());
        let consistent = ratios.iter().all(|r| (r - 1.0).abs() <= TUNED);
        let done = consistent || pass_number == settings.passes;
        if !done {
            passes.tune(pass_number, &pass, &mut setup, settings);
        }
        last = Some((pass, ratios, noise));
        if done {
            break;
        }
    }
    let last = last.expect("at least one pass");
    let mut filter_run = finish(
        method,
        structure,
        record,
        &setup,
        &start_values,
        last,
        passes,
    );
    filter_run.estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(filter_run)
}

/// The estimate of the last pass (`last`: the pass, its outputs' mean
/// ν²/S and the noise it ran with), its notes and report, and its
/// parameter histories.
fn finish(
    method: &str,
    structure: Filtered,
    record: &FlightRecord,
    setup: &Setup,
    start_values: &[f64],
    (pass, ratios, noise): (Pass, Vec<f64>, Noise),
    passes: Passes,
) -> FilterRun {
    let n = setup.x0.len();
    let times: Vec<f64> = (0..setup.view.len()).map(|k| setup.view.time(k)).collect();
    let history = History::of(&pass, &setup.names, times, n);
    let mut estimate = assemble(
        method,
        structure,
        record,
        setup,
        start_values,
        &pass,
        &ratios,
        &history,
    );
    estimate.cost_history = passes.costs;
    estimate.iterations = estimate.cost_history.len();
    noise_notes(
        &mut estimate,
        structure,
        setup,
        &noise,
        passes.rejected,
        passes.mehra_failed.then_some(passes.lags),
    );
    estimate.details = passes.report;
    FilterRun {
        estimate,
        history,
        innovations: pass.innovations,
    }
}

/// What the residual-correlation passes carry from pass to pass.
struct Passes {
    /// The states' process noise intensities and θ the next pass runs
    /// with.
    process_states: Vec<f64>,
    theta: Vec<f64>,
    /// Mehra's lags (0: the zero-lag update).
    lags: usize,
    /// What the best pass so far ran with and ended with, for a pass whose
    /// noise makes the record less likely (module header, Noise 2).
    best: Option<Best>,
    /// The pass rejected, by its number.
    rejected: Option<usize>,
    /// Whether Mehra's method did not serve a pass.
    mehra_failed: bool,
    /// Each pass's −ln L, and the report's lines.
    costs: Vec<f64>,
    report: String,
}

impl Passes {
    /// Mehra's noise made the record less likely than the noise it
    /// replaced (pass `number`, its `outcome`): back to the best pass, the
    /// zero-lag update from it.
    fn reject(
        &mut self,
        number: usize,
        outcome: &Result<Pass>,
        setup: &mut Setup,
        settings: &FilterSettings,
    ) {
        let best = self.best.take().expect("a best pass");
        self.costs.push(match outcome {
            Ok(pass) => pass.negative_log_likelihood,
            Err(_) => f64::INFINITY,
        });
        self.report += &format!(
            "{number:>4}  rejected: the record less likely than after pass {}\n",
            best.number
        );
        self.rejected = Some(number);
        self.lags = 0;
        back_to_best(
            &best,
            setup,
            settings,
            &mut self.process_states,
            &mut self.theta,
        );
    }

    /// The noise and θ for the pass after `pass` (number `number`), what
    /// it ran with kept as the best so far while Mehra's method tunes.
    fn tune(&mut self, number: usize, pass: &Pass, setup: &mut Setup, settings: &FilterSettings) {
        let ran_with = Best {
            number,
            pass: pass.clone(),
            measurement: setup.measurement.clone(),
            process: self.process_states.clone(),
            theta: self.theta.clone(),
        };
        let update = next_noise_and_theta(
            pass,
            setup,
            settings,
            self.lags,
            &mut self.process_states,
            &mut self.theta,
        );
        if update == tuning::Update::ZeroLagFallback {
            self.mehra_failed = true;
        }
        if self.lags > 0 {
            self.best = Some(ran_with);
        }
    }
}

/// One pass of the filter `run` over the record with the parameters
/// `theta` (the free ones among the states) and `noise`: its outcome; an
/// error when the augmented model cannot be made.
fn run_pass(setup: &Setup, theta: &[f64], noise: &Noise, run: &FilterPass) -> Result<Result<Pass>> {
    let augmented = Augmented::new(setup.view.as_ref(), theta, setup.free.clone())?;
    let initial = Gaussian {
        mean: augmented.state(setup.x0.as_slice()),
        covariance: setup.prior.clone(),
    };
    Ok(run(&augmented, initial, noise, &setup.observations))
}

/// Whether a pass's outcome makes the record less likely than the best
/// pass so far (a failed pass does; none is worse without a best pass).
fn worse(outcome: &Result<Pass>, best: Option<&Best>) -> bool {
    match (outcome, best) {
        (Ok(pass), Some(best)) => !matches!(
            pass.negative_log_likelihood
                .partial_cmp(&best.pass.negative_log_likelihood),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ),
        (Err(_), Some(_)) => true,
        (_, None) => false,
    }
}

/// The noise of a pass: the process noise intensities of the states
/// (`process_states`) and the parameters' pseudonoise, the measurement
/// variances.
fn pass_noise(setup: &Setup, process_states: &[f64]) -> Noise {
    Noise {
        process: DMatrix::from_diagonal(&DVector::from_iterator(
            setup.x0.len() + setup.free.len(),
            process_states.iter().chain(&setup.pseudonoise).copied(),
        )),
        measurement: DVector::from_column_slice(&setup.measurement),
    }
}

/// After a rejected pass: the noise and θ the best pass ran with, then
/// the zero-lag update from the best pass and θ advanced to where it
/// ended.
fn back_to_best(
    best: &Best,
    setup: &mut Setup,
    settings: &FilterSettings,
    process_states: &mut Vec<f64>,
    theta: &mut Vec<f64>,
) {
    setup.measurement = best.measurement.clone();
    *process_states = best.process.clone();
    *theta = best.theta.clone();
    next_noise_and_theta(&best.pass, setup, settings, 0, process_states, theta);
}

/// The next pass's noise from `pass` by Mehra's method with `lags` lags
/// (0: the zero-lag update), the process noise only if the settings tune
/// it, and θ advanced to where `pass` ended.
fn next_noise_and_theta(
    pass: &Pass,
    setup: &mut Setup,
    settings: &FilterSettings,
    lags: usize,
    process_states: &mut [f64],
    theta: &mut [f64],
) -> tuning::Update {
    let (n, len) = (setup.x0.len(), setup.view.len());
    let step = setup.view.time(1) - setup.view.time(0);
    let update = tuning::update(
        pass,
        len,
        step,
        n,
        lags,
        &mut setup.measurement,
        &setup.floors,
        settings.tune_process_noise.then_some(process_states),
    );
    advance(theta, pass, &setup.free, n, len);
    update
}

/// The report's line of a pass: its −ln L and each output's mean ν²/S.
fn report_line(number: usize, pass: &Pass, ratios: &[f64], outputs: &[String]) -> String {
    format!(
        "{number:>4}  {:.1}  {}\n",
        pass.negative_log_likelihood,
        ratios
            .iter()
            .zip(outputs)
            .map(|(r, o)| format!("{o} {r:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The estimate's notes on the final noise, on a rejected pass
/// (`rejected`, its number) and on a pass Mehra's method with the lags
/// `mehra_failed` did not serve.
fn noise_notes(
    estimate: &mut Estimate,
    structure: Filtered,
    setup: &Setup,
    noise: &Noise,
    rejected: Option<usize>,
    mehra_failed: Option<usize>,
) {
    let n = setup.x0.len();
    estimate.notes.push(format!(
        "final noise: R σ {}; process noise intensity on {} {}",
        structure
            .outputs()
            .iter()
            .zip(noise.measurement.iter())
            .map(|(o, r)| format!("{o} {:.3e}", r.sqrt()))
            .collect::<Vec<_>>()
            .join(", "),
        setup.state_names.join(", "),
        (0..n)
            .map(|i| format!("{:.3e}", noise.process[(i, i)]))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    if let Some(number) = rejected {
        estimate.notes.push(format!(
            "residual correlation: the noise Mehra's method gave made the record less likely (pass {number}, rejected); the passes from there used the zero-lag update"
        ));
    }
    if let Some(lags) = mehra_failed {
        estimate.notes.push(format!(
            "residual correlation: Mehra's method with {lags} lags did not serve a pass (too few points with every output measured, or no transitions kept); that pass used the zero-lag update"
        ));
    }
}

/// A pass the residual-correlation passes may return to, with the noise
/// and θ it ran with.
struct Best {
    number: usize,
    pass: Pass,
    measurement: Vec<f64>,
    process: Vec<f64>,
    theta: Vec<f64>,
}

/// θ for the next pass: the free parameters where `pass` ended.
fn advance(theta: &mut [f64], pass: &Pass, free: &[usize], states: usize, len: usize) {
    let end = pass
        .filtered
        .get(len - 1)
        .expect("a pass keeps every point")
        .mean;
    for (j, &i) in free.iter().enumerate() {
        if end[states + j].is_finite() {
            theta[i] = end[states + j];
        }
    }
}

/// A diverged filter's estimate: the start values with unknown σ.
fn diverged(
    method: &str,
    structure: Filtered,
    record: &FlightRecord,
    setup: &Setup,
    start: &[f64],
    error: Error,
) -> Estimate {
    let m = setup.names.len();
    Estimate {
        method: method.to_string(),
        model: structure.name().to_string(),
        record: record.scenario.clone(),
        diagnoses: Vec::new(),
        status: Status::Diverged(error.to_string()),
        parameters: (0..m)
            .map(|j| ParameterEstimate {
                name: setup.names[j].clone(),
                value: start[j],
                standard_error: f64::INFINITY,
                start: start[j],
            })
            .collect(),
        covariance: Vec::new(),
        fits: Vec::new(),
        iterations: 0,
        cost_history: Vec::new(),
        wall_time: 0.0,
        notes: setup.notes.clone(),
        details: String::new(),
        network: None,
        distributions: Vec::new(),
        histories: Vec::new(),
    }
}

/// The estimate of the last pass: final filtered θ_a and its covariance,
/// one-step-prediction fits, and the status (module header).
#[allow(clippy::too_many_arguments)]
fn assemble(
    method: &str,
    structure: Filtered,
    record: &FlightRecord,
    setup: &Setup,
    start: &[f64],
    pass: &Pass,
    ratios: &[f64],
    history: &History,
) -> Estimate {
    let n = setup.x0.len();
    let m = setup.names.len();
    let end = pass.filtered.last().expect("a pass has grid points");
    let covariance = end.covariance.view((n, n), (m, m)).into_owned();
    let parameters: Vec<ParameterEstimate> = (0..m)
        .map(|j| ParameterEstimate {
            name: setup.names[j].clone(),
            value: end.mean[n + j],
            standard_error: covariance[(j, j)].max(0.0).sqrt(),
            start: start[j],
        })
        .collect();
    let outputs = structure.outputs();
    let fits = outputs
        .iter()
        .zip(&pass.innovations)
        .map(|(name, innovations)| {
            let (measured, predicted): (Vec<f64>, Vec<f64>) = innovations
                .iter()
                .map(|i| {
                    let z = setup.observations.at[i.k]
                        .iter()
                        .find(|(o, _)| outputs[*o] == *name)
                        .map_or(f64::NAN, |(_, z)| *z);
                    (z, z - i.value)
                })
                .unzip();
            OutputFit::new(name, &measured, &predicted)
        })
        .collect();
    let (status, diagnoses) = status(setup, history, ratios, outputs);
    let mut notes = setup.notes.clone();
    notes.push(
        "estimate: the filtered parameter states and their covariance at the record's last grid point; fits: the one-step predictions".into(),
    );
    Estimate {
        method: method.to_string(),
        model: structure.name().to_string(),
        record: record.scenario.clone(),
        diagnoses,
        status,
        parameters,
        covariance: (0..m)
            .map(|i| covariance.row(i).iter().copied().collect())
            .collect(),
        fits,
        iterations: 0,
        cost_history: Vec::new(),
        wall_time: 0.0,
        notes,
        details: String::new(),
        network: None,
        distributions: Vec::new(),
        histories: Vec::new(),
    }
}

#[cfg(test)]
mod tests;
