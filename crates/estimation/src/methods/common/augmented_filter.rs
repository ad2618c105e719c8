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
//!    motion's bandwidth f_c (`fourier_noise_variance`).
//! 2. The residual-correlation method (the note's ref. 6, Mehra, "On the
//!    identification of variances and adaptive Kalman filtering", IEEE TAC
//!    15(2), 1970, §IV, Eqs. 13, 29, 30, 33; `tuning`): after each pass the
//!    innovations' autocorrelations give R and the integrated states'
//!    process noise for the next; a pass that makes the record less likely
//!    (−ln L = ½·Σ(νᵀS⁻¹ν + ln det 2πS)) is discarded for zero-lag
//!    covariance matching. The passes stop when every output's mean ν²/S
//!    is within `TUNED` of 1, or after `passes`.
//!
//! **Estimate**: the final filtered augmented state and covariance, θ
//! started from equation error (`start = "ee"`) where it serves. **Status**:
//! converged when every parameter has settled over the last
//! `SETTLING_FRACTION` of the record and the data identified it (σ below
//! σ₀/√2); innovations beyond `CONSISTENT` are a diagnosis. **Histories**:
//! θ_a and σ at every grid point of the last pass ([`History::write_csv`]).

use crate::error::{Error, Result};
use crate::estimate::{Diagnosis, DiagnosisKind, Estimate, OutputFit, ParameterEstimate, Status};
use crate::estimator::{Refusal, Settings, parse_settings};
use crate::input_timing::{self, InputInterpolation};
use crate::linear_structure::LinearStructure;
use crate::methods::common::coefficient_fit::{Start, linear_start_estimate, start_estimate};
use crate::methods::common::iterations::{MIN_STEP, step_in_range};
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
mod passes;
mod setup;
mod status;
pub(crate) use fourier_noise::*;
pub use history::*;
use passes::{Passes, noise_notes, pass_noise, report_line, run_pass, worse};
use setup::Setup;
use status::*;

/// The innovations are consistent when every output's mean normalised
/// squared innovation over the second half of the record is within this
/// of 1. Its sampling scatter is √(2/N) ≈ 0.05 for the 750 samples of a
/// 60 s, 25 Hz half-record; 0.25 leaves room for the linearisation.
pub(crate) const CONSISTENT: f64 = 0.25;

/// The residual-correlation passes stop once every output's mean
/// normalised squared innovation is within this of 1 (2 sampling σ of a
/// 60 s, 25 Hz half-record).
pub(crate) const TUNED: f64 = 0.1;

/// The last part of the record over which a parameter must have settled.
pub(crate) const SETTLING_FRACTION: f64 = 0.1;

/// Parameters of magnitude below this get this as the scale of their prior
/// σ and pseudonoise (aerodynamic derivatives are O(0.01–10) per radian).
pub(crate) const PARAMETER_SCALE: f64 = 0.1;

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
        if let Some(step) = self.step.filter(|&step| !step_in_range(step)) {
            return bad(
                "step",
                format!("must be at least {MIN_STEP} s, is {step} s"),
            );
        }
        Ok(())
    }
}

/// On a linear structure, an error naming the settings of `method` it
/// does not take (the augmented filters' `interpolation`: a linear model
/// states it in its file).
pub(crate) fn refuse_for_linear(method: &str, problem: &EstimationProblem) -> Result<()> {
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
    ) -> crate::Result<Estimate> {
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
