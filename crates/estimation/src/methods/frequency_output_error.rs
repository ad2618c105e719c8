//! Output error in the frequency domain: a linear model's transfer
//! functions fitted to the measured Fourier transforms of the outputs.
//!
//! Klein & Morelli, "Aircraft System Identification" (AIAA 2006), §7.4
//! (output-error parameter estimation in the frequency domain); the
//! transform is [`aeroid_numerics::fourier`] (Filon–Simpson, its
//! Eqs. 1–3). Method `fdoe`, settings `[methods.fdoe]`
//! ([`FrequencyOutputErrorSettings`]).
//!
//! 1. **Model.** δẋ = A·δx + B·δu, δy = C·δx + D·δu
//!    ([`crate::model::transfer`]): a nonlinear postulated
//!    model is linearised about the first sample of its record-driven view
//!    (integrated states δx; controls and measured pseudo-controls δu; the
//!    controls sampled on the grid held or linear per channel as the
//!    default `interpolation = "auto"` chooses, said in the notes).
//! 2. **Transforms.** Transforming the state equation over [t₀, t_N]
//!    (fourier Eq. 3) gives, at each ω,
//!    `X̃ = (jωI − A)⁻¹·(B·Ũ − E)`, `E = δx(t_N)·e^{−jωt_N} − δx(t₀)·e^{−jωt₀}`,
//!    `Ỹ = C·X̃ + D·Ũ`; the end states are the measured ones. At the
//!    Fourier frequencies ω = 2πk/T a constant has no transform, so trim
//!    values, output biases and the model's bias terms drop out: the bias
//!    terms (constant regressor) are held at their start values and not
//!    reported.
//! 3. **Cost and step** (K&M §7.4): `J = ½·Σ_ω ṽ*·S⁻¹·ṽ`, ṽ = Z̃ − Ỹ, with S
//!    the diagonal of the residual spectral density re-estimated before each
//!    iteration, `S_ii = (1/M)·Σ_ω |ṽ_i|²`; the shared Gauss–Newton /
//!    Levenberg–Marquardt core on the real and imaginary parts, each
//!    weighted by (S_ii/2)^{−1/2} (circular residuals: half the power in
//!    each part), so JᵀJ = Re Σ (∂Ỹ/∂θ)*·S⁻¹·(∂Ỹ/∂θ) is the information
//!    matrix and its inverse the Cramér–Rao bound. ∂Ỹ/∂θ by central
//!    differences.
//!
//! Limitations: the model is linear about the reference point, so
//! large-amplitude manoeuvres bias the estimates (the kinematic and
//! q̄ variations the nonlinear model follows); measured inputs enter
//! without their noise being modelled (output error's assumption).

use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::estimator::{Capabilities, Description, Method, Refusal, Settings, parse_settings};
use crate::input_timing::{self, InputInterpolation};
use crate::linear_structure::LinearStructure;
use crate::methods::common::frequency_band::{BAND_SETTINGS, BandOptions, model_controls};
use crate::methods::common::refusals::{missing_channels, unsuitable};
use crate::methods::common::regression::record_name;
use crate::model::driven::DrivenSimulation;
use crate::model::linear::Matrix;
use crate::model::state_space::{DrivenStateSpace, recorded_initial_state};
use crate::model::transfer::{LinearisedFlight, TransferModel};
use crate::problem::EstimationProblem;
use crate::reconstruction::control_steps;
use crate::structure::{ModelStructure, Structure};
use aeroid_core::units::Quantity;
use aeroid_numerics::fourier::{FourierTransform, breaks_at};
use aeroid_numerics::gauss_newton::{self, LeastSquaresObjective, Options, Solution};
use aeroid_record::FlightRecord;
use aeroid_sim::aero::Regressor;
use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Method name in estimates.
pub const METHOD: &str = "fdoe";

/// The `[methods.fdoe]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrequencyOutputErrorSettings {
    /// The band [low, high]; none: from the inputs' spectra.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<[Quantity; 2]>,
    /// Frequency spacing; none: 1/T.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resolution: Option<Quantity>,
    pub input_threshold: f64,
    pub max_iterations: usize,
}

impl Default for FrequencyOutputErrorSettings {
    fn default() -> Self {
        FrequencyOutputErrorSettings {
            band: None,
            resolution: None,
            input_threshold: BandOptions::default().input_threshold,
            max_iterations: 50,
        }
    }
}

/// [`FrequencyOutputErrorSettings`] in SI.
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyOutputErrorOptions {
    pub band: BandOptions,
    pub max_iterations: usize,
}

impl Default for FrequencyOutputErrorOptions {
    fn default() -> Self {
        FrequencyOutputErrorOptions {
            band: BandOptions::default(),
            max_iterations: 50,
        }
    }
}

impl FrequencyOutputErrorSettings {
    /// Reads and checks a `[methods.fdoe]` table.
    pub fn read(settings: &Settings) -> Result<FrequencyOutputErrorOptions> {
        parse_settings::<FrequencyOutputErrorSettings>(METHOD, settings)?.options()
    }

    /// The settings in SI, checked.
    pub fn options(&self) -> Result<FrequencyOutputErrorOptions> {
        if self.max_iterations == 0 {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: "max_iterations must be at least 1".to_string(),
            });
        }
        Ok(FrequencyOutputErrorOptions {
            band: BandOptions::read(
                METHOD,
                self.band.as_ref(),
                self.resolution.as_ref(),
                self.input_threshold,
            )?,
            max_iterations: self.max_iterations,
        })
    }
}

/// Frequency-domain output error as a registered method.
pub(crate) struct FrequencyOutputError;

impl Method for FrequencyOutputError {
    const NAME: &'static str = METHOD;
    type Settings = FrequencyOutputErrorSettings;

    fn describe() -> Description {
        Description {
            title: "frequency-domain output error: the linearised model's transfer functions fitted to the outputs' Fourier transforms",
            paper: "Klein & Morelli, \"Aircraft System Identification\" (AIAA 2006), §7.4",
            equations: "Ỹ = C(jωI − A)⁻¹(BŨ − E) + DŨ at the Fourier frequencies; J = ½Σ ṽ*S⁻¹ṽ, S diagonal re-estimated; Gauss–Newton, Cramér–Rao bounds from Re Σ (∂Ỹ/∂θ)*S⁻¹(∂Ỹ/∂θ)",
            needs: "the compared outputs, the controls and the pseudo-controls the model does not integrate, uniformly sampled; a manoeuvre small enough for the linearisation",
            settings: vec![
                BAND_SETTINGS[0],
                BAND_SETTINGS[1],
                BAND_SETTINGS[2],
                ("max_iterations", "Gauss–Newton iterations at most"),
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            ..Capabilities::default()
        }
    }

    fn validate(settings: &FrequencyOutputErrorSettings) -> Result<()> {
        settings.options().map(|_| ())
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &FrequencyOutputErrorSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let options = settings.options()?;
        match &problem.structure {
            Structure::SixDof(structure) => {
                frequency_output_error(problem.record(), structure, &options)
            }
            Structure::Linear(structure) => {
                linear_frequency_output_error(problem.record(), structure, &options)
            }
        }
    }
}

/// The Fourier transforms a linear model is fitted to, at angular
/// frequencies ω (rad/s): inputs Ũ, measured outputs Z̃ and the end-state
/// terms E, each indexed \[signal\]\[frequency\].
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyData {
    pub frequencies: Vec<f64>,
    pub inputs: Vec<Vec<Complex<f64>>>,
    pub outputs: Vec<Vec<Complex<f64>>>,
    pub ends: Vec<Vec<Complex<f64>>>,
}

impl FrequencyData {
    /// The transforms of δu (N × m) and z (N × l) on `transform`'s grid,
    /// with the state perturbations at its first and last sample.
    pub fn new(
        transform: &FourierTransform,
        inputs: &DMatrix<f64>,
        outputs: &DMatrix<f64>,
        (first, last): (&[f64], &[f64]),
    ) -> Result<FrequencyData> {
        let end = transform.start + (transform.samples - 1) as f64 * transform.step;
        let zero = vec![Complex::new(0.0, 0.0); transform.frequencies.len()];
        let ends = first
            .iter()
            .zip(last)
            .map(|(&x0, &xn)| {
                // E = jω·0 + xN·e^{−jωtN} − x0·e^{−jωt0} (fourier Eq. 3 without x̃).
                aeroid_numerics::fourier::derivative_transform(
                    &transform.frequencies,
                    &zero,
                    (transform.start, x0),
                    (end, xn),
                )
            })
            .collect();
        Ok(FrequencyData {
            frequencies: transform.frequencies.clone(),
            inputs: transform.transform_columns(inputs)?,
            outputs: transform.transform_columns(outputs)?,
            ends,
        })
    }

    /// Ỹ of the model at θ, \[output\]\[frequency\].
    pub fn predicted(&self, [a, b, c, d]: &[DMatrix<f64>; 4]) -> Result<Vec<Vec<Complex<f64>>>> {
        let (n, m, l) = (a.nrows(), b.ncols(), c.nrows());
        if m != self.inputs.len() || l != self.outputs.len() || n != self.ends.len() {
            return Err(Error::Shape {
                reason: format!(
                    "a model with {n} states, {m} inputs and {l} outputs does not match transforms of {} states, {} inputs and {} outputs",
                    self.ends.len(),
                    self.inputs.len(),
                    self.outputs.len()
                ),
            });
        }
        let complex = |matrix: &DMatrix<f64>| matrix.map(|v| Complex::new(v, 0.0));
        let (a, b, c, d) = (complex(a), complex(b), complex(c), complex(d));
        let mut predicted = vec![vec![Complex::new(0.0, 0.0); self.frequencies.len()]; l];
        for (f, &omega) in self.frequencies.iter().enumerate() {
            let u = DVector::from_fn(m, |i, _| self.inputs[i][f]);
            let e = DVector::from_fn(n, |i, _| self.ends[i][f]);
            let resolvent = DMatrix::from_fn(n, n, |i, j| {
                let diagonal = if i == j {
                    Complex::new(0.0, omega)
                } else {
                    Complex::new(0.0, 0.0)
                };
                diagonal - a[(i, j)]
            });
            // No state (`integrate = []`): y = D·u (nalgebra's LU does not take 0×0).
            let x = if n == 0 {
                DVector::zeros(0)
            } else {
                resolvent
                    .lu()
                    .solve(&(&b * &u - e))
                    .ok_or_else(|| Error::Numerical {
                        reason: format!(
                            "jωI − A is singular at ω = {omega} rad/s (a pole on the imaginary axis)"
                        ),
                    })?
            };
            let y = &c * x + &d * u;
            for (o, series) in predicted.iter_mut().enumerate() {
                series[f] = y[o];
            }
        }
        Ok(predicted)
    }
}

/// The fit of a [`TransferModel`] to [`FrequencyData`].
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFit {
    /// Every parameter, the held ones at their start values.
    pub theta: DVector<f64>,
    /// The solver's run over the free parameters.
    pub solution: Solution,
    /// S_ii at the solution.
    pub spectral_density: Vec<f64>,
    /// Ỹ at the solution.
    pub predicted: Vec<Vec<Complex<f64>>>,
}

/// The least-squares problem of the frequency-domain cost.
struct FrequencyObjective<'a> {
    model: &'a dyn TransferModel,
    data: &'a FrequencyData,
    full: DVector<f64>,
    free: &'a [usize],
    /// (S_ii/2)^{−1/2} per output.
    weights: Vec<f64>,
}

impl FrequencyObjective<'_> {
    fn theta(&self, free: &DVector<f64>) -> DVector<f64> {
        let mut full = self.full.clone();
        for (&i, &value) in self.free.iter().zip(free.iter()) {
            full[i] = value;
        }
        full
    }

    /// ṽ = Z̃ − Ỹ at θ (free parameters), [output][frequency].
    fn errors(&self, free: &DVector<f64>) -> crate::Result<Vec<Vec<Complex<f64>>>> {
        let theta = self.theta(free);
        let matrices = self.model.matrices(theta.as_slice())?;
        let predicted = self.data.predicted(&matrices)?;
        Ok(self
            .data
            .outputs
            .iter()
            .zip(&predicted)
            .map(|(z, y)| z.iter().zip(y).map(|(z, y)| z - y).collect())
            .collect())
    }
}

/// S_ii = (1/M)·Σ_ω |ṽ_i|² of each output.
fn spectral_density(errors: &[Vec<Complex<f64>>]) -> Vec<f64> {
    errors
        .iter()
        .map(|e| e.iter().map(|v| v.norm_sqr()).sum::<f64>() / e.len().max(1) as f64)
        .collect()
}

impl LeastSquaresObjective for FrequencyObjective<'_> {
    type Error = crate::Error;

    fn residuals(&mut self, theta: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let errors = self.errors(theta)?;
        let count = 2 * errors.iter().map(Vec::len).sum::<usize>();
        let mut residuals = Vec::with_capacity(count);
        for (series, weight) in errors.iter().zip(&self.weights) {
            residuals.extend(series.iter().map(|v| v.re * weight));
            residuals.extend(series.iter().map(|v| v.im * weight));
        }
        Ok(DVector::from_vec(residuals))
    }

    fn reweight(&mut self, theta: &DVector<f64>) -> crate::Result<bool> {
        let density = spectral_density(&self.errors(theta)?);
        // A noise-free output keeps a floor (1e-20 of the largest) so that
        // its weight stays finite.
        let largest = density.iter().copied().fold(0.0, f64::max).max(1e-300);
        self.weights = density
            .iter()
            .map(|s| 1.0 / (0.5 * s.max(1e-20 * largest)).sqrt())
            .collect();
        Ok(true)
    }
}

/// Fits the `free` parameters of `model` to `data` from `start` (every
/// parameter; the others are held there).
pub fn fit_transfer(
    model: &dyn TransferModel,
    data: &FrequencyData,
    start: &DVector<f64>,
    free: &[usize],
    options: &Options,
) -> Result<TransferFit> {
    if start.len() != model.parameter_count() {
        return Err(Error::Method {
            reason: format!(
                "{} start values for a model of {} parameters",
                start.len(),
                model.parameter_count()
            ),
        });
    }
    let mut problem = FrequencyObjective {
        model,
        data,
        full: start.clone(),
        free,
        weights: vec![1.0; data.outputs.len()],
    };
    let free_start = DVector::from_iterator(free.len(), free.iter().map(|&i| start[i]));
    let solution = gauss_newton::solve(&mut problem, &free_start, options);
    let theta = problem.theta(&solution.theta);
    let errors = problem.errors(&solution.theta).unwrap_or_default();
    let predicted = if errors.is_empty() {
        Vec::new()
    } else {
        data.outputs
            .iter()
            .zip(&errors)
            .map(|(z, e)| z.iter().zip(e).map(|(z, e)| z - e).collect())
            .collect()
    };
    Ok(TransferFit {
        theta,
        solution,
        spectral_density: spectral_density(&errors),
        predicted,
    })
}

/// Stacked real and imaginary parts, for fit metrics.
fn parts(series: &[Complex<f64>]) -> Vec<f64> {
    series
        .iter()
        .map(|c| c.re)
        .chain(series.iter().map(|c| c.im))
        .collect()
}

/// Estimates the free parameters of `structure` from `record` by output
/// error in the frequency domain on its linearisation at the record's start.
pub fn frequency_output_error(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FrequencyOutputErrorOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(METHOD, missing_channels(record, structure), present) {
        return Err(Error::Refused(refusal));
    }
    unsuitable(METHOD, structure)?;
    let (view, x0) = DrivenStateSpace::for_record(
        record,
        structure,
        &InputInterpolation::default(),
        None,
        None,
    )?;
    let simulation = view.simulation();
    let count = simulation.len();
    let (start, step) = (simulation.start, simulation.step);
    let linearised = LinearisedFlight::new(&view, 0, x0.as_slice())?;
    let inputs = linearised.input_perturbations();
    let controls = control_series(structure, simulation);
    let (omegas, band_note) =
        options
            .band
            .frequencies(METHOD, &controls, (start, step, count), false)?;
    let breaks = breaks_at(start, step, count, &control_steps(record));
    let transform = FourierTransform::with_breaks(&omegas, start, step, count, &breaks)?;
    let times: Vec<f64> = (0..count).map(|k| simulation.time(k)).collect();
    let measured = measured_outputs(record, &structure.outputs, &times)?;
    let end_time = simulation.time(transform.samples - 1);
    let end_state = view.state_of(&recorded_initial_state(
        record, structure, simulation, end_time,
    ));
    let reference = linearised.reference_state();
    let last: Vec<f64> = end_state
        .iter()
        .zip(&reference)
        .map(|(x, r)| x - r)
        .collect();
    let first = vec![0.0; reference.len()];
    let data = FrequencyData::new(&transform, &inputs, &measured, (&first, &last))?;
    let names = structure.aircraft.aero.parameters.names().to_vec();
    let (free, held) = free_and_held(structure);
    let start_values = view.parameters();
    let fitted = Fitted {
        method_model_record: (METHOD, structure.name.clone(), record_name(record)),
        names: &names,
        start: &start_values,
        free: &free,
        held: &held,
        bounds: &structure.bounds,
        outputs: &structure.outputs,
    };
    let inputs_used: Vec<&str> = linearised.inputs().iter().map(|i| i.name()).collect();
    let notes = vec![
        format!(
            "linearised about the record at {:.3} s: states {}; inputs {}",
            start,
            view.state_names().join(", "),
            inputs_used.join(", ")
        ),
        transform_note(&transform, &breaks, &band_note),
        input_timing::note(&simulation.input_timing),
    ];
    let mut estimate = fitted.fit(&linearised, &data, options, notes)?;
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// Each control the model's terms use, with its values on the grid.
fn control_series(
    structure: &ModelStructure,
    simulation: &DrivenSimulation,
) -> Vec<(&'static str, Vec<f64>)> {
    model_controls(structure)
        .into_iter()
        .filter_map(|r| {
            let control = regressor_control(r)?;
            Some((
                control.name(),
                simulation
                    .controls
                    .iter()
                    .map(|u| u[control.index()])
                    .collect(),
            ))
        })
        .collect()
}

/// The free parameters fitted, and those held: the constant terms, which a
/// perturbation model about the record's start does not see.
fn free_and_held(structure: &ModelStructure) -> (Vec<usize>, Vec<usize>) {
    let aero = &structure.aircraft.aero;
    let count = aero.parameters.names().len();
    let held: Vec<usize> = (0..count)
        .filter(|&i| {
            structure.free[i]
                && aero
                    .term_of(i)
                    .is_some_and(|(_, r)| r.single() == Some(Regressor::Constant))
        })
        .collect();
    let free = (0..count)
        .filter(|&i| structure.free[i] && !held.contains(&i))
        .collect();
    (free, held)
}

/// The note on the transforms.
fn transform_note(transform: &FourierTransform, breaks: &[usize], band_note: &str) -> String {
    format!(
        "finite Fourier transforms by Filon–Simpson quadrature over {} samples at {} Hz{}: {band_note}",
        transform.samples,
        aeroid_record::rate_text(1.0 / transform.step),
        match breaks.len() {
            0 => String::new(),
            n => format!(", integrated piecewise across {n} control steps"),
        }
    )
}

/// What the fit of either kind of structure needs besides the model and
/// the transforms.
struct Fitted<'a> {
    method_model_record: (&'a str, String, String),
    names: &'a [String],
    start: &'a DVector<f64>,
    free: &'a [usize],
    /// Free parameters that are not estimated (bias terms).
    held: &'a [usize],
    bounds: &'a [(f64, f64)],
    outputs: &'a [String],
}

impl Fitted<'_> {
    /// Fits `model` to `data` and assembles the estimate with `notes`.
    fn fit(
        &self,
        model: &dyn TransferModel,
        data: &FrequencyData,
        options: &FrequencyOutputErrorOptions,
        mut notes: Vec<String>,
    ) -> Result<Estimate> {
        if self.free.is_empty() {
            return Err(Error::Refused(Refusal::NothingToEstimate {
                method: METHOD.into(),
                model: self.method_model_record.1.clone(),
            }));
        }
        // Converged within 0.014σ of the optimum, as output error.
        let solver =
            Options::maximum_likelihood(self.free, self.bounds, options.max_iterations, 1e-4);
        let fit = fit_transfer(model, data, self.start, self.free, &solver)?;
        let free_names: Vec<String> = self.free.iter().map(|&i| self.names[i].clone()).collect();
        let free_start =
            DVector::from_iterator(self.free.len(), self.free.iter().map(|&i| self.start[i]));
        let (method, model_name, record) = self.method_model_record.clone();
        let mut estimate = Estimate::from_solution(
            (method, model_name, record),
            &free_names,
            &free_start,
            &fit.solution,
        );
        estimate.fits = self
            .outputs
            .iter()
            .enumerate()
            .filter(|_| !fit.predicted.is_empty())
            .map(|(o, name)| {
                OutputFit::new(
                    &format!("{name} (Fourier transforms)"),
                    &parts(&data.outputs[o]),
                    &parts(&fit.predicted[o]),
                )
            })
            .collect();
        if !self.held.is_empty() {
            let held: Vec<&str> = self.held.iter().map(|&i| self.names[i].as_str()).collect();
            notes.push(format!(
                "not estimated: {} (bias terms have no transform at the Fourier frequencies; held at their start values)",
                held.join(", ")
            ));
        }
        notes.push(format!(
            "residual spectral density S (diagonal): {}",
            self.outputs
                .iter()
                .zip(&fit.spectral_density)
                .map(|(name, s)| format!("{name} {s:.3e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        estimate.notes = notes;
        Ok(estimate.assess())
    }
}

/// Frequency-domain output error on a linear structure (`kind = "linear"`):
/// its own matrices, the inputs and outputs as the record gives them; a
/// state's end values from the record channel of its name (0 for a state
/// no channel measures).
pub fn linear_frequency_output_error(
    record: &FlightRecord,
    structure: &LinearStructure,
    options: &FrequencyOutputErrorOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(METHOD, structure.missing_channels(record), present) {
        return Err(Error::Refused(refusal));
    }
    let (model, _) = structure.for_record(record, None, None)?;
    let (start, step, count) = (model.start, model.step, model.inputs.len());
    let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
    let inputs = DMatrix::from_fn(count, structure.inputs.len(), |k, i| model.inputs[k][i]);
    let controls: Vec<(&str, Vec<f64>)> = structure
        .inputs
        .iter()
        .enumerate()
        .map(|(i, name)| (name.as_str(), inputs.column(i).iter().copied().collect()))
        .collect();
    let (omegas, band_note) =
        options
            .band
            .frequencies(METHOD, &controls, (start, step, count), false)?;
    let breaks = breaks_at(start, step, count, &control_steps(record));
    let transform = FourierTransform::with_breaks(&omegas, start, step, count, &breaks)?;
    let measured = measured_outputs(record, &structure.outputs, &times)?;
    let end = times[count - 1];
    let mut unmeasured = Vec::new();
    let mut state_at = |t: f64| -> Result<Vec<f64>> {
        structure
            .states
            .iter()
            .map(|name| match record.channel(name) {
                Ok(channel) => Ok(channel.values_at(&[t])?[0]),
                Err(_) => {
                    if !unmeasured.contains(name) {
                        unmeasured.push(name.clone());
                    }
                    Ok(0.0)
                }
            })
            .collect()
    };
    let (first, last) = (state_at(start)?, state_at(end)?);
    let data = FrequencyData::new(&transform, &inputs, &measured, (&first, &last))?;
    let held: Vec<usize> = (0..structure.names.len())
        .filter(|&i| {
            structure.free[i]
                && structure.entries[i]
                    .iter()
                    .any(|e| matches!(e.matrix, Matrix::StateBias | Matrix::OutputBias))
        })
        .collect();
    let free: Vec<usize> = (0..structure.names.len())
        .filter(|&i| structure.free[i] && !held.contains(&i))
        .collect();
    let start_values = structure.parameter_values();
    let fitted = Fitted {
        method_model_record: (METHOD, structure.name.clone(), record_name(record)),
        names: &structure.names,
        start: &start_values,
        free: &free,
        held: &held,
        bounds: &structure.bounds,
        outputs: &structure.outputs,
    };
    let mut notes = vec![transform_note(&transform, &breaks, &band_note)];
    if !unmeasured.is_empty() {
        notes.push(format!(
            "no channel measures the states {}: their values at the record's ends are taken as 0",
            unmeasured.join(", ")
        ));
    }
    let mut estimate = fitted.fit(&model, &data, options, notes)?;
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// The outputs' channels at `times`; an error naming a channel without a value.
fn measured_outputs(
    record: &FlightRecord,
    outputs: &[String],
    times: &[f64],
) -> Result<DMatrix<f64>> {
    let mut measured = DMatrix::zeros(times.len(), outputs.len());
    for (o, name) in outputs.iter().enumerate() {
        let values = record.channel(name)?.values_at(times)?;
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::Data {
                reason: format!(
                    "{METHOD}: channel '{name}' has no value at {:.3} s; the Fourier transform needs every sample",
                    times[k]
                ),
            });
        }
        measured.set_column(o, &DVector::from_vec(values));
    }
    Ok(measured)
}

/// The control a control regressor reads.
fn regressor_control(regressor: Regressor) -> Option<aeroid_sim::state::Control> {
    use aeroid_sim::state::Control;
    match regressor {
        Regressor::Elevator => Some(Control::Elevator),
        Regressor::Aileron => Some(Control::Aileron),
        Regressor::Rudder => Some(Control::Rudder),
        Regressor::Flap => Some(Control::Flap),
        _ => None,
    }
}
