//! The restricted flight-dynamic neural model and the Gauss–Newton fit of a
//! postulated aerodynamic model through it: what ELM + Gauss–Newton,
//! recurrent ELM + Gauss–Newton and neural Gauss–Newton share.
//!
//! Papers: "Parameter estimation of aircraft using extreme learning machine
//! and Gauss-Newton algorithm" (the ELM paper), Eqs. 1–3 and 11–22;
//! Verma & Peyada, "Estimation of aerodynamic parameters near stall using
//! maximum likelihood and extreme learning machine-based methods",
//! Aeronautical J. 2020, Eqs. 11–26 (the recurrent form, Eqs. 17 and 23);
//! the reflex-wing UAV paper, Eqs. 29–30 (coefficients also as outputs).
//!
//! 1. The network (ELM paper, Eqs. 1–2, Fig. 1): input X(i) = the motion
//!    variables (the structure's integrated states without χ) and the
//!    aerodynamic coefficients at sample i; target Z(i+1) = the motion
//!    variables at i+1 (with [`RestrictedOptions::coefficient_outputs`]
//!    also the coefficients, Eq. 30 of the reflex-wing UAV paper). For
//!    training the coefficients come from the measured accelerations
//!    ([`crate::reconstruction`], Verma & Peyada Eqs. 12–15). Inputs and
//!    targets are scaled column by column (Eq. 3/16, [`super::Scaling`]);
//!    the network is trained by the given [`Trainer`].
//! 2. The estimation (ELM paper, Eqs. 11–22): the postulated model's
//!    coefficients, evaluated with Θ at the measured flight condition of
//!    each sample ([`aeroid_sim::aero::AeroModel::coefficients`]), replace
//!    the measured ones and are propagated through the trained network,
//!    Y(i+1) = f(X(i), V̄, W̄, Θ) (Eq. 11), with the measured motion
//!    variables fed in (Eq. 11; the recurrent network's Eq. 23) or with
//!    [`Feedback::Predicted`] the network's own previous prediction. The
//!    cost det(R) (Eqs. 12–15) is minimised by relaxation in the shared
//!    Gauss–Newton core ([`aeroid_numerics::gauss_newton`]):
//!    R = (1/N)·Σ E·Eᵀ (Eq. 13) and a Gauss–Newton step (Eqs. 16–20) on
//!    ½·Σ EᵀR⁻¹E, the response gradients by forward differences (Eq. 19).
//!    The Cramér–Rao bounds are the square roots of the diagonal of
//!    P = [Σ (∂Y/∂Θ)ᵀR⁻¹(∂Y/∂Θ)]⁻¹ (Eqs. 21–22). Residuals are in the
//!    network's scaled units (the same minimum); fits are in physical units.
//!
//! The network approximates the motion's one-step map, not exactly, so
//! even on noise-free data the estimate carries its approximation error
//! (`tests/estimators/elm_gauss_newton.rs`). Coefficients computed from Θ
//! outside the range the network was trained on are extrapolated; the
//! estimate's notes count such samples. User reference: docs/methods.md.

use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::estimator::{MissingChannel, Refusal};
use crate::neural::{NetworkReport, Scaling};
use crate::problem::EstimationProblem;
use crate::reconstruction::{
    Reconstruction, ReconstructionOptions, Request, StepBreaks, check_channels, control_steps,
    reconstruct,
};
use crate::structure::{FLIGHT_PATH_STATES, ModelStructure};
use aeroid_numerics::gauss_newton::{self, LeastSquaresObjective, Options};
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use aeroid_sim::aero::{AeroInput, AeroModel, Coefficient, ModelKind, Regressor};
use aeroid_sim::state::{Control, Controls};
use nalgebra::{DMatrix, DVector, SVector, Vector3};
use serde::{Deserialize, Serialize};

mod data;
use data::*;

/// A trained network on scaled data: predicts its outputs from its inputs without allocating.
pub trait Network: Send + Sync {
    fn inputs(&self) -> usize;
    fn outputs(&self) -> usize;
    fn predict(&self, input: &[f64], output: &mut [f64]);
    /// The length of the state [`Network::partial`] leaves (0: the network
    /// keeps none and [`Network::predict_from`] evaluates from the start).
    fn partial_size(&self) -> usize {
        0
    }
    /// The state of an evaluation after the leading inputs `head` (the
    /// hidden neurons' sums over them).
    fn partial(&self, _head: &[f64], _state: &mut [f64]) {}
    /// The output for `input` whose first `from` inputs left `state` in
    /// [`Network::partial`]: the same as [`Network::predict`], bit for bit.
    fn predict_from(&self, _state: &[f64], _from: usize, input: &[f64], output: &mut [f64]) {
        self.predict(input, output);
    }
}

/// Scaled training pairs (row i: input at sample k, target at k+1) with channel names.
pub struct TrainingSet {
    pub inputs: Vec<Vec<f64>>,
    pub targets: Vec<Vec<f64>>,
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
}

/// Builds a network from a training set (ELM: pseudo-inverse; feed-forward: LM back-propagation).
pub trait Trainer: Sync {
    fn train(&self, set: &TrainingSet) -> Result<(Box<dyn Network>, NetworkReport)>;
}

/// Which motion variables the network is given at sample i during the
/// estimation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Feedback {
    /// The measured ones (ELM paper Eq. 11; Verma & Peyada Eq. 23, the
    /// training observations fed back).
    #[default]
    Measured,
    /// The network's own prediction of the sample before: a free-running
    /// simulation from the measured first sample of each contiguous stretch.
    Predicted,
}

/// What the restricted model contains and the Gauss–Newton settings.
#[derive(Debug, Clone, PartialEq)]
pub struct RestrictedOptions {
    /// The motion variables (record channel names); empty: the structure's
    /// integrated states, χ left out.
    pub motion: Vec<String>,
    /// The coefficients at i+1 are network outputs too (Eq. 30 of the
    /// reflex-wing UAV paper), compared with the measured ones.
    pub coefficient_outputs: bool,
    pub feedback: Feedback,
    /// The range the inputs and targets are scaled to (Eq. 3).
    pub scaling: (f64, f64),
    /// The differentiator of the angular rates (moment coefficients) and of
    /// α (α̇ of the stall model).
    pub differentiator: Differentiator,
    /// Gauss–Newton iterations at most.
    pub max_iterations: usize,
    /// Converged when a Gauss–Newton step's predicted decrease of the
    /// whitened cost is below this (1e-4: a step under 0.014σ).
    pub decrease_tolerance: f64,
}

impl Default for RestrictedOptions {
    fn default() -> Self {
        RestrictedOptions {
            motion: Vec::new(),
            coefficient_outputs: false,
            feedback: Feedback::Measured,
            scaling: (-1.0, 1.0),
            differentiator: Differentiator::default(),
            max_iterations: 30,
            decrease_tolerance: 1e-4,
        }
    }
}

/// The Gauss–Newton problem: Θ → coefficients → network → whitened residuals.
struct Fit<'a> {
    data: &'a Data,
    network: &'a dyn Network,
    model: AeroModel,
    /// Structure indices of the estimated parameters.
    free: Vec<usize>,
    feedback: Feedback,
    /// R^{-1/2}: the inverse of the Cholesky factor of R (Eq. 13).
    whitening: DMatrix<f64>,
    /// The model's coefficients at each instant for the current Θ.
    coefficients: Vec<f64>,
    /// Scaled predictions, pair by pair.
    predictions: Vec<f64>,
    /// Scaled targets, pair by pair.
    targets: Vec<f64>,
    /// The Θ `predictions` and `coefficients` are of.
    predicted_at: Option<DVector<f64>>,
    input: Vec<f64>,
    /// With measured feedback the motion inputs of a pair do not depend on
    /// Θ: the network's state after them ([`Network::partial`]), pair by
    /// pair, so that an evaluation at Θ starts from it (empty otherwise).
    partials: Vec<f64>,
}

impl<'a> Fit<'a> {
    fn new(
        data: &'a Data,
        network: &'a dyn Network,
        structure: &ModelStructure,
        feedback: Feedback,
    ) -> Fit<'a> {
        let outputs = data.output_count();
        let mut targets = vec![0.0; data.pairs.len() * outputs];
        for (row, &k) in targets.chunks_mut(outputs).zip(&data.pairs) {
            data.raw_target(k + 1, row);
            data.output_scaling.apply(row);
        }
        Fit {
            data,
            network,
            model: structure.aircraft.aero.clone(),
            free: (0..structure.free.len())
                .filter(|&i| structure.free[i])
                .collect(),
            feedback,
            whitening: DMatrix::identity(outputs, outputs),
            coefficients: vec![0.0; data.times.len() * data.coefficient_count()],
            predictions: vec![0.0; data.pairs.len() * outputs],
            targets,
            predicted_at: None,
            input: vec![0.0; data.motion_count() + data.coefficient_count()],
            partials: match (feedback, network.partial_size()) {
                (Feedback::Measured, size) if size > 0 => {
                    let m = data.motion_count();
                    let mut input = vec![0.0; m + data.coefficient_count()];
                    let mut partials = vec![0.0; data.pairs.len() * size];
                    for (state, &k) in partials.chunks_mut(size).zip(&data.pairs) {
                        data.raw_input(k, &data.measured, &mut input);
                        data.input_scaling.apply(&mut input);
                        network.partial(&input[..m], state);
                    }
                    partials
                }
                _ => Vec::new(),
            },
        }
    }

    /// The network's output for pair `pair` whose input is `self.input`:
    /// from the pair's partial state when there is one.
    fn evaluate(&self, pair: usize, output: &mut [f64]) {
        let size = self.network.partial_size();
        if self.partials.is_empty() {
            self.network.predict(&self.input, output);
        } else {
            let state = &self.partials[pair * size..(pair + 1) * size];
            self.network
                .predict_from(state, self.data.motion_count(), &self.input, output);
        }
    }

    /// The model's coefficients at every instant with Θ, by the model's own
    /// aerodynamics. For the stall model χ comes from its separation
    /// equations: Eq. 3 with α̇ from the differentiated α channel when
    /// τ1 = 0, else Eq. 2 integrated along the record from χ∞ at the start
    /// of each contiguous stretch by the project's RK4 (`separation`).
    fn evaluate_coefficients(&mut self, theta: &DVector<f64>) -> crate::Result<()> {
        self.predicted_at = None;
        for (j, &i) in self.free.iter().enumerate() {
            self.model.parameters.values_mut()[i] = theta[j];
        }
        let c = self.data.coefficient_count();
        let chi_is_state = self.model.chi_is_state();
        let mut chi = 1.0;
        for k in 0..self.data.times.len() {
            let mut condition = self.data.conditions[k];
            if chi_is_state {
                chi = self.separation(k, chi);
                condition.chi = chi;
            }
            let all = self
                .model
                .coefficient_values(&self.model.coefficients(&condition));
            for (slot, coefficient) in self.coefficients[k * c..(k + 1) * c]
                .iter_mut()
                .zip(&self.data.coefficients)
            {
                *slot = all[*coefficient as usize];
            }
        }
        match self.coefficients.iter().all(|v| v.is_finite()) {
            true => Ok(()),
            false => Err(crate::Error::NotFinite {
                what: "the model's coefficients",
            }),
        }
    }

    /// χ at instant k for a χ state: χ∞ at the start of a contiguous
    /// stretch, else one RK4 step of Eq. 2 from χ at k−1 with α and α̇
    /// interpolated linearly inside the step.
    fn separation(&self, k: usize, previous: f64) -> f64 {
        let conditions = &self.data.conditions;
        let contiguous = k > 0
            && (self.data.times[k] - self.data.times[k - 1] - self.data.period).abs()
                < 0.5 * self.data.period;
        if !contiguous {
            return self.model.separation_target(
                conditions[k].alpha,
                conditions[k].alpha_dot,
                conditions[k].airspeed,
            );
        }
        let (start, end) = (&conditions[k - 1], &conditions[k]);
        let step = self.data.times[k] - self.data.times[k - 1];
        let x = SVector::<f64, 1>::new(previous);
        let next = aeroid_sim::integrator::rk4_step(&x, step, |x, fraction| {
            let alpha = start.alpha + fraction * (end.alpha - start.alpha);
            let alpha_dot = start.alpha_dot + fraction * (end.alpha_dot - start.alpha_dot);
            let airspeed = start.airspeed + fraction * (end.airspeed - start.airspeed);
            SVector::<f64, 1>::new(self.model.separation_rate(alpha, alpha_dot, x[0], airspeed))
        });
        next[0]
    }

    /// The scaled predictions of every pair at Θ (Eq. 11 or 23).
    fn predict(&mut self, theta: &DVector<f64>) -> crate::Result<()> {
        if self.predicted_at.as_ref() == Some(theta) {
            return Ok(());
        }
        self.predicted_at = None;
        self.evaluate_coefficients(theta)?;
        let data = self.data;
        let (m, outputs) = (data.motion_count(), data.output_count());
        let mut previous: Option<usize> = None;
        for (pair, &k) in data.pairs.iter().enumerate() {
            data.raw_input(k, &self.coefficients, &mut self.input);
            data.input_scaling.apply(&mut self.input);
            let chained = self.feedback == Feedback::Predicted && k > 0 && previous == Some(k - 1);
            if chained {
                // The previous prediction of the motion, rescaled from the
                // output scaling to the input scaling (motion columns first
                // in both).
                let last = (pair - 1) * outputs;
                self.input[..m].copy_from_slice(&self.predictions[last..last + m]);
                data.output_scaling.invert(&mut self.input[..m]);
                data.input_scaling.apply(&mut self.input[..m]);
            }
            let mut output = std::mem::take(&mut self.predictions);
            self.evaluate(pair, &mut output[pair * outputs..(pair + 1) * outputs]);
            self.predictions = output;
            previous = Some(k);
        }
        if !self.predictions.iter().all(|v| v.is_finite()) {
            return Err(crate::Error::NotFinite {
                what: "the network's predictions",
            });
        }
        self.predicted_at = Some(theta.clone());
        Ok(())
    }

    /// Z − Y, pair by pair (scaled).
    fn errors(&mut self, theta: &DVector<f64>) -> crate::Result<Vec<f64>> {
        self.predict(theta)?;
        Ok(self
            .targets
            .iter()
            .zip(&self.predictions)
            .map(|(z, y)| z - y)
            .collect())
    }
}

impl LeastSquaresObjective for Fit<'_> {
    type Error = crate::Error;

    fn residuals(&mut self, theta: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let errors = self.errors(theta)?;
        let n = self.data.output_count();
        let mut residuals = DVector::zeros(errors.len());
        for (pair, e) in errors.chunks(n).enumerate() {
            for i in 0..n {
                residuals[pair * n + i] = (0..=i).map(|j| self.whitening[(i, j)] * e[j]).sum();
            }
        }
        Ok(residuals)
    }

    /// R = (1/N)·Σ E·Eᵀ at Θ (Eq. 13), its diagonal floored at 10⁻¹² of
    /// its mean so that a near-perfect fit stays finite.
    fn reweight(&mut self, theta: &DVector<f64>) -> crate::Result<bool> {
        let errors = self.errors(theta)?;
        let n = self.data.output_count();
        let count = self.data.pairs.len() as f64;
        let mut r = DMatrix::zeros(n, n);
        for e in errors.chunks(n) {
            let e = DVector::from_column_slice(e);
            r += &e * e.transpose();
        }
        r /= count;
        let floor = 1e-12 * r.trace() / n as f64;
        for i in 0..n {
            r[(i, i)] += floor.max(f64::MIN_POSITIVE);
        }
        let cholesky = r
            .cholesky()
            .ok_or_else(|| aeroid_numerics::Error::NotPositiveDefinite {
                what: "the residual covariance R".into(),
                why: "",
            })?;
        let factor = cholesky.l();
        self.whitening = factor
            .solve_lower_triangular(&DMatrix::identity(n, n))
            .ok_or_else(|| aeroid_numerics::Error::Singular {
                reason: "the residual covariance R cannot be inverted".into(),
            })?;
        Ok(true)
    }

    /// Forward differences (Eq. 19), step 10⁻⁶·max(|Θ_j|, typical). With
    /// measured feedback Θ reaches the network only through the
    /// coefficients at the same sample, so the difference is taken through
    /// the chain rule, ∂Y(i+1)/∂Θ_j = Σ_c ∂f/∂C_c·∂C_c(i)/∂Θ_j, each factor
    /// a forward difference: the model once per parameter, the network
    /// once per coefficient (3 instead of n_Θ network passes). With
    /// predicted feedback Θ also reaches Y(i+1) through Y(i): the whole
    /// free-running prediction is differenced per parameter.
    fn jacobian(&mut self, theta: &DVector<f64>, options: &Options) -> crate::Result<DMatrix<f64>> {
        let step = |j: usize| {
            options.relative_step
                * theta[j]
                    .abs()
                    .max(options.typical.get(j).copied().unwrap_or(1e-3))
        };
        if self.feedback == Feedback::Predicted {
            let base = self.residuals(theta)?;
            let mut jacobian = DMatrix::zeros(base.len(), theta.len());
            let mut perturbed = theta.clone();
            for j in 0..theta.len() {
                perturbed[j] = theta[j] + step(j);
                let column = (self.residuals(&perturbed)? - &base) / step(j);
                jacobian.set_column(j, &column);
                perturbed[j] = theta[j];
            }
            return Ok(jacobian);
        }
        let slopes = self.coefficient_slopes(theta, step)?;
        let network = self.network_slopes(theta)?;
        let (n, c, parameters) = (
            self.data.output_count(),
            self.data.coefficient_count(),
            theta.len(),
        );
        let mut jacobian = DMatrix::zeros(self.data.pairs.len() * n, parameters);
        let mut response = vec![0.0; n];
        for (pair, &k) in self.data.pairs.iter().enumerate() {
            let network = &network[pair * n * c..(pair + 1) * n * c];
            for j in 0..parameters {
                let slope = &slopes[(j * self.data.times.len() + k) * c..][..c];
                for (o, value) in response.iter_mut().enumerate() {
                    *value = (0..c).map(|i| network[o * c + i] * slope[i]).sum();
                }
                for o in 0..n {
                    jacobian[(pair * n + o, j)] = -(0..=o)
                        .map(|i| self.whitening[(o, i)] * response[i])
                        .sum::<f64>();
                }
            }
        }
        Ok(jacobian)
    }
}

impl Fit<'_> {
    /// ∂C/∂Θ_j of each instant's coefficients, in the network's scaled
    /// input units: parameter by parameter, instant by instant, coefficient
    /// by coefficient. The coefficients at Θ are restored, and with them
    /// the predictions at Θ when they were computed.
    fn coefficient_slopes(
        &mut self,
        theta: &DVector<f64>,
        step: impl Fn(usize) -> f64,
    ) -> crate::Result<Vec<f64>> {
        let data = self.data;
        let (m, c) = (data.motion_count(), data.coefficient_count());
        let scale: Vec<f64> = (0..c)
            .map(|i| match data.input_scaling.unscale_factor(m + i) {
                f if f > 0.0 => 1.0 / f,
                _ => 0.0,
            })
            .collect();
        let predicted_at = self.predicted_at.take();
        self.evaluate_coefficients(theta)?;
        let base = self.coefficients.clone();
        let mut slopes = Vec::with_capacity(theta.len() * base.len());
        let mut perturbed = theta.clone();
        for j in 0..theta.len() {
            let h = step(j);
            perturbed[j] = theta[j] + h;
            self.evaluate_coefficients(&perturbed)?;
            perturbed[j] = theta[j];
            slopes.extend(
                self.coefficients
                    .iter()
                    .zip(&base)
                    .enumerate()
                    .map(|(index, (up, at))| (up - at) / h * scale[index % c]),
            );
        }
        self.coefficients = base;
        // The predictions at Θ, if they were, still are: only the
        // coefficients were changed, and they are Θ's again.
        self.predicted_at = predicted_at.filter(|at| at == theta);
        Ok(slopes)
    }

    /// ∂f/∂x_c of the network at each pair's input at Θ with respect to
    /// each scaled coefficient input, by forward differences of 10⁻⁶ of the
    /// scaled range: pair by pair, output by output, coefficient by
    /// coefficient. Expects the coefficients at Θ (see
    /// [`Fit::coefficient_slopes`]); the predictions at Θ are kept.
    fn network_slopes(&mut self, theta: &DVector<f64>) -> crate::Result<Vec<f64>> {
        self.predict(theta)?;
        let data = self.data;
        let (m, c, n) = (
            data.motion_count(),
            data.coefficient_count(),
            data.output_count(),
        );
        let delta = 1e-6 * (data.input_scaling.high - data.input_scaling.low);
        let mut slopes = vec![0.0; data.pairs.len() * n * c];
        let mut shifted = vec![0.0; n];
        for (pair, &k) in data.pairs.iter().enumerate() {
            data.raw_input(k, &self.coefficients, &mut self.input);
            data.input_scaling.apply(&mut self.input);
            for i in 0..c {
                self.input[m + i] += delta;
                self.evaluate(pair, &mut shifted);
                self.input[m + i] -= delta;
                let base = &self.predictions[pair * n..(pair + 1) * n];
                for o in 0..n {
                    slopes[(pair * n + o) * c + i] = (shifted[o] - base[o]) / delta;
                }
            }
        }
        Ok(slopes)
    }
}

/// Counts of model coefficients outside the range the network was trained
/// on, per coefficient (name, samples outside, samples).
fn extrapolated(data: &Data, coefficients: &[f64]) -> Vec<(String, usize)> {
    let (m, c) = (data.motion_count(), data.coefficient_count());
    (0..c)
        .map(|j| {
            let (min, max) = data.input_scaling.range[m + j];
            let margin = 1e-9 * (max - min).abs();
            let outside = data
                .pairs
                .iter()
                .filter(|&&k| {
                    let v = coefficients[k * c + j];
                    v < min - margin || v > max + margin
                })
                .count();
            (data.coefficient_names[j].clone(), outside)
        })
        .filter(|(_, outside)| *outside > 0)
        .collect()
}

/// Trains the network on the record (coefficients from measured accelerations) and estimates the structure's free parameters by Gauss–Newton on det(R) through it.
pub fn estimate(
    method: &str,
    problem: &EstimationProblem,
    start: Option<&Estimate>,
    trainer: &dyn Trainer,
    options: &RestrictedOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    crate::estimator::one_record(method, problem)?;
    let structure = problem.structure.six_dof(method)?;
    let record = problem.record();
    if !structure.free.iter().any(|&f| f) {
        return Err(Error::Refused(Refusal::NothingToEstimate {
            method: method.to_string(),
            model: structure.name.clone(),
        }));
    }
    let data = prepare(method, record, structure, options)?;
    let (network, report) = trainer.train(&data.training_set())?;
    check_network(method, network.as_ref(), &data)?;
    let mut fit = Fit::new(&data, network.as_ref(), structure, options.feedback);
    let names = structure.free_names();
    let values = structure.aircraft.aero.parameters.values();
    let theta0 = DVector::from_iterator(
        fit.free.len(),
        fit.free.iter().zip(&names).map(|(&i, name)| {
            start
                .and_then(|s| s.parameter(name))
                .map(|p| p.value)
                .filter(|v| v.is_finite())
                .unwrap_or(values[i])
        }),
    );
    let solver = Options::maximum_likelihood(
        &fit.free,
        &structure.bounds,
        options.max_iterations,
        options.decrease_tolerance,
    );
    let solution = gauss_newton::solve(&mut fit, &theta0, &solver);
    let mut estimate = Estimate::from_solution(
        (method, structure.name.clone(), record.name().to_string()),
        &names,
        &theta0,
        &solution,
    );
    estimate.fits = output_fits(&mut fit, &solution.theta);
    estimate.notes = notes(&data, options.feedback, start, &fit.coefficients);
    estimate.network = Some(report);
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// An error unless the trained network takes the restricted model's
/// motion and coefficients and gives its outputs.
fn check_network(method: &str, network: &dyn Network, data: &Data) -> Result<()> {
    let inputs = data.motion_count() + data.coefficient_count();
    if network.inputs() == inputs && network.outputs() == data.output_count() {
        return Ok(());
    }
    Err(Error::Network {
        reason: format!(
            "{method}: the trained network has {} inputs and {} outputs, the restricted model {inputs} and {}",
            network.inputs(),
            network.outputs(),
            data.output_count()
        ),
    })
}

/// The estimate's notes: the data's, the restricted model's inputs and
/// outputs, where Gauss–Newton started, and the coefficients the network
/// extrapolates.
fn notes(
    data: &Data,
    feedback: Feedback,
    start: Option<&Estimate>,
    coefficients: &[f64],
) -> Vec<String> {
    let mut notes = data.notes.clone();
    notes.push(format!(
        "restricted neural model: inputs {} at sample i, outputs {} at i+1; {} training pairs; motion fed back: {}",
        data.input_names().join(", "),
        data.output_names().join(", "),
        data.pairs.len(),
        match feedback {
            Feedback::Measured => "measured (Eq. 11 / 23)",
            Feedback::Predicted => "predicted (free-running)",
        }
    ));
    if let Some(start) = start {
        notes.push(format!(
            "Gauss–Newton started from the {} estimate's values",
            start.method
        ));
    }
    let outside = extrapolated(data, coefficients);
    if !outside.is_empty() {
        notes.push(format!(
            "model coefficients outside the network's training range (extrapolated), samples: {}",
            outside
                .iter()
                .map(|(name, count)| format!("{name} {count}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    notes
}

/// Fits of each output in physical units at Θ (empty when Θ cannot be evaluated).
fn output_fits(fit: &mut Fit, theta: &DVector<f64>) -> Vec<OutputFit> {
    if fit.predict(theta).is_err() {
        return Vec::new();
    }
    let data = fit.data;
    let n = data.output_count();
    let mut measured = fit.targets.clone();
    let mut predicted = fit.predictions.clone();
    for row in measured.chunks_mut(n) {
        data.output_scaling.invert(row);
    }
    for row in predicted.chunks_mut(n) {
        data.output_scaling.invert(row);
    }
    data.output_names()
        .iter()
        .enumerate()
        .map(|(o, name)| {
            let z: Vec<f64> = measured.iter().skip(o).step_by(n).copied().collect();
            let y: Vec<f64> = predicted.iter().skip(o).step_by(n).copied().collect();
            OutputFit::new(name, &z, &y)
        })
        .collect()
}
