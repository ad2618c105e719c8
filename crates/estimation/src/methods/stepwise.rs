//! Stepwise regression for model-structure determination (X-31/F-18 HARV EKF note cites it;
//! Efroymson, "Multiple regression analysis", in Ralston & Wilf, Mathematical
//! Methods for Digital Computers, 1960; Draper & Smith, "Applied Regression
//! Analysis", 3rd ed. 1998, §15.2; Klein & Morelli, "Aircraft System
//! Identification", AIAA 2006, §5.4).
//!
//! Inputs: a flight record, a model structure (for the aircraft's mass,
//! inertia, geometry, propulsion and rate normalisation — its terms are not
//! used), one coefficient, and a pool of candidate terms: regressor keys
//! (`alpha`, `q`, `de`, …) and their products (`alpha*beta`, `alpha^2`;
//! [`Monomial`]). The dependent variable is the coefficient reconstructed
//! from the measured accelerations (reflex-wing UAV paper, Eqs. 17–24, see
//! [`crate::reconstruction`]); the constant term is always in. Products are
//! searched as MEAN-REMOVED regressors, `alpha^2` = (α − ᾱ)², so that
//! around a trim point α² is not a near copy of α; the selected model is
//! reported in the plain basis of the model's parameters,
//! (a − ā)(b − b̄) = a·b − b̄·a − ā·b + ā·b̄, the covariance transformed
//! with the same matrix, C' = T·C·Tᵀ (the means are in the notes).
//!
//! Each step (K&M §5.4.2):
//! 1. every candidate not in the model is tried; its partial F statistic is
//!    `F = (SSE_p − SSE_{p+1}) / s²_{p+1}`, `s² = SSE/(N − n)` (K&M Eq. 5.87);
//!    the one with the largest F enters if F ≥ F-to-enter (default 4.0) and
//!    it raises R² by at least `min_r_squared_gain`;
//! 2. after an entry every term in the model is checked: the one with the
//!    smallest partial F to remove, `(SSE_{p−1} − SSE_p) / s²_p`, leaves if
//!    F < F-to-remove (default 3.9, below F-to-enter so that nothing cycles);
//!    repeated until nothing leaves;
//! 3. the procedure stops when no candidate may enter (or after `max_steps`).
//!
//! After each step the report gives R² = 1 − SSE/SST (K&M Eq. 5.70), s²,
//! the overall F = (SSR/p)/s² (K&M Eq. 5.73), PRESS = Σ (eᵢ/(1 − h_ii))²
//! (K&M Eq. 5.81) and the predicted square error
//! PSE = SSE/N + 2·σ²_max·n/N with σ²_max = SST/(2·(N − 1)) (K&M Eq. 5.89,
//! as in SIDPAC's swr.m), which has a minimum at an adequate model.
//!
//! The R² gain guard is this implementation's, not Klein & Morelli's: on
//! exactly reconstructed coefficients it stops entries that only fit
//! rounding error. On flight data with coloured residuals F = 4 admits too
//! much (SIDPAC's swr.m uses F = 20): raise `f_to_enter` there.

use crate::error::{Error, Result};
use crate::estimate::Status;
use crate::estimate::{Estimate, OutputFit, ParameterEstimate};
use crate::estimator::{Capabilities, Description, Method, Refusal};
use crate::methods::common::coefficient_fit::{
    ANGULAR_ACCELERATIONS_SETTING, DIFFERENTIATOR_SETTING, check_settings,
};
use crate::methods::common::regression::record_name;
use crate::problem::EstimationProblem;
use crate::reconstruction::{
    AngularAccelerations, Reconstruction, ReconstructionOptions, Request, missing_channels,
    reconstruct,
};
use crate::structure::ModelStructure;
use aeroid_numerics::regression::LeastSquares;
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use aeroid_sim::aero::{Coefficient, ForceAxes, Monomial, Regressor, TermError};
use nalgebra::{DMatrix, DVector};
use std::fmt;

/// Method name in estimates.
pub const METHOD: &str = "swr";

mod report;
pub use report::*;

/// The products offered besides the single regressors when no candidate list is given.
pub(crate) const DEFAULT_PRODUCTS: [&str; 4] = ["alpha^2", "alpha*beta", "beta^2", "alpha*de"];

/// Settings of stepwise regression.
#[derive(Debug, Clone, PartialEq)]
pub struct StepwiseOptions {
    pub f_to_enter: f64,
    pub f_to_remove: f64,
    /// A term enters only if it raises R² (a fraction) by at least this much
    /// (default 1e-6). When a coefficient is reconstructed exactly (ideal
    /// data; forces need no differentiation) the residual of the right
    /// model is rounding error, s² ≈ 1e-30, and every candidate that
    /// correlates with the rounding pattern gets F ≫ 4; the guard only stops
    /// such meaningless entries. On flight data with coloured residuals
    /// SIDPAC's swr.m uses F = 20 (4 with a safety factor of 5): raise
    /// `f_to_enter` or this there.
    pub min_r_squared_gain: f64,
    /// Candidate terms; None: every regressor key the record can supply
    /// (except the constant, which is always in, and `chi`), plus `DEFAULT_PRODUCTS`.
    pub candidates: Option<Vec<String>>,
    pub max_steps: usize,
    pub reconstruction: ReconstructionOptions,
    /// Lag (s) of the coloured-residual bound of the final estimates (see equation error).
    pub correlation_lag: f64,
}

/// The `[methods.swr]` table.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct StepwiseSettings {
    pub differentiator: Differentiator,
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub correlation_lag: f64,
    pub f_to_enter: f64,
    pub f_to_remove: f64,
    pub min_r_squared_gain: f64,
    pub candidates: Option<Vec<String>>,
    pub max_steps: usize,
    /// Where ṗ, q̇, ṙ come from.
    pub angular_accelerations: AngularAccelerations,
}

impl Default for StepwiseSettings {
    fn default() -> Self {
        let options = StepwiseOptions::default();
        StepwiseSettings {
            differentiator: Differentiator::default(),
            correlation_lag: options.correlation_lag,
            f_to_enter: options.f_to_enter,
            f_to_remove: options.f_to_remove,
            min_r_squared_gain: options.min_r_squared_gain,
            candidates: options.candidates,
            max_steps: options.max_steps,
            angular_accelerations: AngularAccelerations::default(),
        }
    }
}

impl StepwiseSettings {
    pub fn options(&self) -> StepwiseOptions {
        StepwiseOptions {
            f_to_enter: self.f_to_enter,
            f_to_remove: self.f_to_remove,
            min_r_squared_gain: self.min_r_squared_gain,
            candidates: self.candidates.clone(),
            max_steps: self.max_steps,
            reconstruction: ReconstructionOptions {
                differentiator: Some(self.differentiator),
                angular_accelerations: self.angular_accelerations,
                ..Default::default()
            },
            correlation_lag: self.correlation_lag,
        }
    }
}

/// Stepwise regression as a registered method: every coefficient the
/// model has terms in, the selected terms estimated together.
pub(crate) struct StepwiseRegression;

impl Method for StepwiseRegression {
    const NAME: &'static str = METHOD;
    type Settings = StepwiseSettings;

    fn describe() -> Description {
        Description {
            title: "stepwise regression: model-structure determination by F-to-enter/F-to-remove on reconstructed coefficients",
            paper: "Efroymson (1960), in Ralston & Wilf, \"Mathematical Methods for Digital Computers\"; Draper & Smith, \"Applied Regression Analysis\"; Klein & Morelli, \"Aircraft System Identification\", §5.4",
            equations: "partial F statistics to enter and remove terms, PRESS (Klein & Morelli Eqs. 5.83–5.92); coefficients from accelerations as equation error",
            needs: "as equation error: load factors, angular rates, air data, controls",
            settings: vec![
                DIFFERENTIATOR_SETTING,
                ANGULAR_ACCELERATIONS_SETTING,
                (
                    "correlation_lag",
                    "lag (s) of the coloured-residual bound of the final estimates",
                ),
                ("f_to_enter", "partial F a term needs to enter"),
                (
                    "f_to_remove",
                    "partial F below which a term leaves (at most f_to_enter)",
                ),
                (
                    "min_r_squared_gain",
                    "a term enters only if it raises R² by at least this fraction",
                ),
                (
                    "candidates",
                    "candidate terms (regressor keys, products a*b, squares a^2); none: every regressor the record supplies and the default products",
                ),
                ("max_steps", "most entries and removals per coefficient"),
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities::default()
    }

    fn validate(parsed: &StepwiseSettings) -> Result<()> {
        check_settings(METHOD, &parsed.differentiator, parsed.correlation_lag)?;
        let invalid = |message: String| {
            Err(Error::Settings {
                method: METHOD.to_string(),
                reason: message.to_string(),
            })
        };
        if !(parsed.f_to_enter > 0.0 && parsed.f_to_remove > 0.0)
            || parsed.f_to_remove > parsed.f_to_enter
        {
            return invalid(format!(
                "f_to_enter ({}) and f_to_remove ({}) must be positive, f_to_remove at most f_to_enter",
                parsed.f_to_enter, parsed.f_to_remove
            ));
        }
        if parsed.min_r_squared_gain.is_nan() || parsed.min_r_squared_gain < 0.0 {
            return invalid("min_r_squared_gain must be at least 0".into());
        }
        for candidate in parsed.candidates.iter().flatten() {
            Candidate::parse(candidate)?;
        }
        Ok(())
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &StepwiseSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let (reports, mut estimate) = stepwise_all(
            problem.record(),
            problem.structure.six_dof(METHOD)?,
            &settings.options(),
        )?;
        estimate.details = reports.iter().map(|r| format!("{r}\n")).collect();
        Ok(estimate)
    }
}

impl Default for StepwiseOptions {
    fn default() -> Self {
        StepwiseOptions {
            f_to_enter: 4.0,
            f_to_remove: 3.9,
            min_r_squared_gain: 1e-6,
            candidates: None,
            max_steps: 50,
            reconstruction: ReconstructionOptions::default(),
            correlation_lag: 2.0,
        }
    }
}

/// A candidate term: one regressor, or a product of regressors with
/// integer powers, spelt as a model file's term ([`Monomial`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Candidate {
    pub name: String,
    pub factors: Vec<Regressor>,
}

impl Candidate {
    /// Parses `alpha`, `alpha*beta`, `alpha^2` (any term key but the constant `0`).
    pub fn parse(text: &str) -> Result<Candidate> {
        let text = text.trim();
        let monomial = Monomial::parse(text)
            .and_then(|m| match m.single() {
                Some(Regressor::Constant) => Err(TermError::Constant),
                _ => Ok(m),
            })
            .map_err(|message| Error::Method {
                reason: format!("candidate term '{text}': {message}"),
            })?;
        Ok(Candidate {
            name: text.to_string(),
            factors: monomial.factors().to_vec(),
        })
    }

    /// The candidate at one instant: the regressor, or the product of the
    /// mean-removed factors (`means` by `Regressor as usize`).
    fn value(&self, regressors: &[f64], means: &[f64]) -> f64 {
        match self.factors.as_slice() {
            [single] => regressors[*single as usize],
            factors => factors
                .iter()
                .map(|r| regressors[*r as usize] - means[*r as usize])
                .product(),
        }
    }
}

/// Stepwise regression on every coefficient the structure has terms in: the
/// reports, and one estimate of all selected terms (covariance block-diagonal:
/// the coefficients are fitted independently).
pub(crate) fn stepwise_all(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &StepwiseOptions,
) -> Result<(Vec<StepwiseReport>, Estimate)> {
    let mut reports = Vec::new();
    let mut combined: Option<Estimate> = None;
    for coefficient in Coefficient::ALL {
        if structure.aircraft.aero.terms(coefficient).next().is_none() {
            continue;
        }
        let report = stepwise(record, structure, coefficient, options)?;
        let estimate = report.estimate();
        reports.push(report);
        combined = Some(match combined {
            None => estimate,
            Some(mut all) => {
                all.covariance = block_diagonal(&all.covariance, &estimate.covariance);
                all.parameters.extend(estimate.parameters);
                all.fits.extend(estimate.fits);
                all.notes.extend(estimate.notes);
                all.wall_time += estimate.wall_time;
                all
            }
        });
    }
    let estimate = combined.ok_or_else(|| {
        Error::Refused(Refusal::NothingToEstimate {
            method: METHOD.to_string(),
            model: structure.name.clone(),
        })
    })?;
    Ok((reports, estimate))
}

/// The block-diagonal matrix of two square matrices.
fn block_diagonal(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len() + b.len();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| match (i < a.len(), j < a.len()) {
                    (true, true) => a[i][j],
                    (false, false) => b[i - a.len()][j - a.len()],
                    _ => 0.0,
                })
                .collect()
        })
        .collect()
}

/// Determines the terms of `coefficient` from `record` by stepwise regression.
pub fn stepwise(
    record: &FlightRecord,
    structure: &ModelStructure,
    coefficient: Coefficient,
    options: &StepwiseOptions,
) -> Result<StepwiseReport> {
    let started = std::time::Instant::now();
    let aircraft = &structure.aircraft;
    let name = coefficient.name(aircraft.aero.force_axes);
    let (candidates, mut notes) = candidate_pool(record, structure, coefficient, options)?;
    let mut request = Request {
        coefficients: vec![coefficient],
        regressors: candidates.iter().flat_map(|c| c.factors.clone()).collect(),
    };
    if request.regressors.contains(&Regressor::LiftSquared) && coefficient != Coefficient::Lift {
        request.coefficients.push(Coefficient::Lift);
    }
    let data = reconstruct(record, aircraft, &request, &options.reconstruction, METHOD)?;
    if data.times.len() < 3 {
        return Err(Error::Data {
            reason: format!(
                "stepwise regression of {name}: {} usable samples",
                data.times.len()
            ),
        });
    }
    notes.extend(data.notes.clone());
    notes.extend(product_means_note(&data, &candidates));
    let problem = SearchData::new(&data, coefficient, &candidates);
    let search = problem.search(options);
    let lag = (options.correlation_lag * data.rate).round() as usize;
    let report = StepwiseReport {
        coefficient: name.to_string(),
        model: structure.name.clone(),
        record: record_name(record),
        samples: problem.z.len(),
        options: options.clone(),
        selected: Vec::new(),
        covariance: DMatrix::zeros(0, 0),
        excluded: problem.excluded(&search.model),
        stop_reason: search.stop_reason.clone(),
        fit: OutputFit::new(name, &[], &[]),
        steps: search.steps,
        wall_time: 0.0,
        notes,
    };
    let mut report = problem.finish(report, &search.model, lag);
    report.wall_time = started.elapsed().as_secs_f64();
    Ok(report)
}

/// The candidates: the option's list, or every usable regressor plus the default products.
fn candidate_pool(
    record: &FlightRecord,
    structure: &ModelStructure,
    coefficient: Coefficient,
    options: &StepwiseOptions,
) -> Result<(Vec<Candidate>, Vec<String>)> {
    if let Some(names) = &options.candidates {
        let candidates = names
            .iter()
            .map(|n| Candidate::parse(n))
            .collect::<Result<Vec<_>>>()?;
        return Ok((candidates, Vec::new()));
    }
    let aero = &structure.aircraft.aero;
    let drag_in_wind_axes = coefficient == Coefficient::Drag && aero.force_axes == ForceAxes::Wind;
    let usable = |regressor: Regressor| match regressor {
        Regressor::Constant | Regressor::Separation => false,
        Regressor::LiftSquared => drag_in_wind_axes,
        Regressor::SpeedRatio => aero.reference_airspeed.is_finite(),
        Regressor::Mach => aero.reference_mach.is_finite(),
        _ => true,
    };
    let names = Regressor::ALL
        .into_iter()
        .filter(|r| usable(*r))
        .map(|r| r.key().to_string())
        .chain(DEFAULT_PRODUCTS.iter().map(|p| p.to_string()));
    let mut candidates = Vec::new();
    let mut left_out = Vec::new();
    for name in names {
        let candidate = Candidate::parse(&name)?;
        let probe = Request {
            coefficients: Vec::new(),
            regressors: candidate.factors.clone(),
        };
        if missing_channels(record, &structure.aircraft, &probe, &Default::default()).is_empty() {
            candidates.push(candidate);
        } else {
            left_out.push(name);
        }
    }
    let notes = if left_out.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "candidates left out because the record lacks their channels: {}",
            left_out.join(", ")
        )]
    };
    Ok((candidates, notes))
}

/// The mean of every regressor over the kept instants (for centred products).
fn regressor_means(data: &Reconstruction) -> Vec<f64> {
    let count = data.regressors.len().max(1) as f64;
    (0..aeroid_sim::aero::REGRESSOR_COUNT)
        .map(|i| data.regressors.iter().map(|r| r[i]).sum::<f64>() / count)
        .collect()
}

/// The means removed from the factors of product candidates.
fn product_means_note(data: &Reconstruction, candidates: &[Candidate]) -> Option<String> {
    let means = regressor_means(data);
    let mut factors: Vec<Regressor> = candidates
        .iter()
        .filter(|c| c.factors.len() > 1)
        .flat_map(|c| c.factors.clone())
        .collect();
    factors.sort_by_key(|r| *r as usize);
    factors.dedup();
    (!factors.is_empty()).then(|| {
        let items: Vec<String> = factors
            .iter()
            .map(|r| format!("{} {:.6e}", r.key(), means[*r as usize]))
            .collect();
        format!(
            "products and squares are searched as mean-removed regressors and reported in the plain basis (constant and linear terms transformed back); means: {}",
            items.join(", ")
        )
    })
}

/// The data of the search: z, the constant and every candidate's column.
struct SearchData<'a> {
    z: DVector<f64>,
    columns: DMatrix<f64>,
    /// The regressors' means removed from the factors of products.
    means: Vec<f64>,
    candidates: &'a [Candidate],
    total_sum_of_squares: f64,
}

/// The fit of one model (indices into the candidates).
struct ModelFit {
    fit: LeastSquares,
    sum_of_squares: f64,
    usable: bool,
}

/// The result of the search.
struct Search {
    model: Vec<usize>,
    steps: Vec<Step>,
    stop_reason: String,
}

impl<'a> SearchData<'a> {
    fn new(data: &Reconstruction, coefficient: Coefficient, candidates: &'a [Candidate]) -> Self {
        let measured = data.coefficient(coefficient);
        let z = DVector::from_column_slice(measured);
        let means = regressor_means(data);
        let columns = DMatrix::from_fn(measured.len(), candidates.len(), |k, j| {
            candidates[j].value(&data.regressors[k], &means)
        });
        let mean = z.mean();
        SearchData {
            total_sum_of_squares: z.iter().map(|v| (v - mean).powi(2)).sum(),
            z,
            columns,
            means,
            candidates,
        }
    }

    /// The regressor matrix of a model: the constant, then the terms.
    fn matrix(&self, model: &[usize]) -> DMatrix<f64> {
        let count = self.z.len();
        DMatrix::from_fn(count, model.len() + 1, |k, j| match j {
            0 => 1.0,
            _ => self.columns[(k, model[j - 1])],
        })
    }

    fn fit(&self, model: &[usize]) -> ModelFit {
        let fit = LeastSquares::fit(&self.matrix(model), &self.z);
        ModelFit {
            sum_of_squares: fit.residual_sum_of_squares(),
            usable: fit.unidentifiable.is_empty(),
            fit,
        }
    }

    fn step(
        &self,
        action: Action,
        term: Option<&Candidate>,
        partial_f: f64,
        model: &[usize],
    ) -> Step {
        let fitted = self.fit(model);
        let s2 = fitted.fit.residual_variance();
        let regression_sum = self.total_sum_of_squares - fitted.sum_of_squares;
        let count = self.z.len() as f64;
        let largest_variance = self.total_sum_of_squares / (2.0 * (count - 1.0));
        Step {
            action,
            term: term.map(|c| c.name.clone()),
            partial_f,
            terms: model
                .iter()
                .map(|&j| self.candidates[j].name.clone())
                .collect(),
            r_squared: 1.0 - fitted.sum_of_squares / self.total_sum_of_squares,
            residual_variance: s2,
            f_statistic: if model.is_empty() {
                f64::NAN
            } else {
                regression_sum / model.len() as f64 / s2
            },
            press: fitted.fit.press(),
            pse: fitted.sum_of_squares / count
                + 2.0 * largest_variance * (model.len() + 1) as f64 / count,
        }
    }

    /// Partial F of adding candidate j to `model`, with the R² gain; (0, 0) if it is not separable.
    fn entry_statistic(&self, model: &[usize], current: f64, j: usize) -> (f64, f64) {
        let mut larger = model.to_vec();
        larger.push(j);
        let fitted = self.fit(&larger);
        if !fitted.usable {
            return (0.0, 0.0);
        }
        let gain = current - fitted.sum_of_squares;
        (
            gain / fitted.fit.residual_variance(),
            gain / self.total_sum_of_squares,
        )
    }

    /// Partial F of removing term at position `position` of `model`.
    fn removal_statistic(&self, model: &[usize], current: &ModelFit, position: usize) -> f64 {
        let mut smaller = model.to_vec();
        smaller.remove(position);
        (self.fit(&smaller).sum_of_squares - current.sum_of_squares)
            / current.fit.residual_variance()
    }

    fn search(&self, options: &StepwiseOptions) -> Search {
        let mut model: Vec<usize> = Vec::new();
        let mut steps = vec![self.step(Action::Start, None, f64::NAN, &model)];
        let stop_reason = loop {
            if steps.len() > options.max_steps {
                break format!("stopped after {} steps (max_steps)", options.max_steps);
            }
            let current = self.fit(&model).sum_of_squares;
            let best = (0..self.candidates.len())
                .filter(|j| !model.contains(j))
                .map(|j| (j, self.entry_statistic(&model, current, j)))
                .max_by(|a, b| a.1.0.total_cmp(&b.1.0));
            let Some((entering, (partial_f, gain))) = best else {
                break "every candidate is in the model".to_string();
            };
            if partial_f < options.f_to_enter {
                break format!(
                    "no candidate reaches F-to-enter {} (best: {} with F = {partial_f:.3})",
                    options.f_to_enter, self.candidates[entering].name
                );
            }
            if gain < options.min_r_squared_gain {
                break format!(
                    "the best candidate, {} (F = {partial_f:.3}), raises R² by {gain:.2e} only (minimum {:e})",
                    self.candidates[entering].name, options.min_r_squared_gain
                );
            }
            model.push(entering);
            steps.push(self.step(
                Action::Enter,
                Some(&self.candidates[entering]),
                partial_f,
                &model,
            ));
            self.remove_weak_terms(&mut model, &mut steps, options);
        };
        Search {
            model,
            steps,
            stop_reason,
        }
    }

    /// Removes, one at a time, terms whose partial F falls below F-to-remove.
    fn remove_weak_terms(
        &self,
        model: &mut Vec<usize>,
        steps: &mut Vec<Step>,
        options: &StepwiseOptions,
    ) {
        while model.len() > 1 {
            let current = self.fit(model);
            let (position, partial_f) = (0..model.len())
                .map(|p| (p, self.removal_statistic(model, &current, p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .expect("the model has terms");
            if partial_f >= options.f_to_remove {
                return;
            }
            let removed = model.remove(position);
            steps.push(self.step(
                Action::Remove,
                Some(&self.candidates[removed]),
                partial_f,
                model,
            ));
        }
    }

    /// Candidates not selected, with their partial F to enter the final model.
    fn excluded(&self, model: &[usize]) -> Vec<(String, f64)> {
        let current = self.fit(model).sum_of_squares;
        (0..self.candidates.len())
            .filter(|j| !model.contains(j))
            .map(|j| {
                (
                    self.candidates[j].name.clone(),
                    self.entry_statistic(model, current, j).0,
                )
            })
            .collect()
    }

    /// Fills in the selected terms' estimates, bounds and fit, in the
    /// plain basis ([`SearchData::plain_basis`]).
    fn finish(&self, mut report: StepwiseReport, model: &[usize], lag: usize) -> StepwiseReport {
        let x = self.matrix(model);
        let fit = LeastSquares::fit(&x, &self.z);
        let (terms, transform) = self.plain_basis(model);
        let theta = &transform * &fit.theta;
        let white = &transform * fit.white_covariance() * transform.transpose();
        let (corrected, _) = fit.corrected_covariance(&x, lag);
        let corrected = &transform * corrected * transform.transpose();
        let selected = model.len() + 1;
        if terms.len() > selected {
            report.notes.push(format!(
                "terms {} carry the linear parts of the mean-removed products and squares (not selected themselves)",
                terms[selected..].join(", ")
            ));
        }
        report.selected = terms
            .iter()
            .enumerate()
            .map(|(i, term)| SelectedTerm {
                parameter: format!("{}_{term}", report.coefficient),
                value: theta[i],
                standard_error: white[(i, i)].sqrt(),
                corrected_standard_error: corrected[(i, i)].sqrt(),
            })
            .collect();
        let predicted: Vec<f64> = (0..self.z.len())
            .map(|k| self.z[k] - fit.residuals[k])
            .collect();
        report.fit = OutputFit::new(&report.coefficient, self.z.as_slice(), &predicted);
        report.covariance = corrected;
        report
    }

    /// The plain-basis terms of a model (the constant `0`, the selected
    /// terms, then lower-degree terms a product needs but the search did
    /// not select) and the matrix T from the searched (mean-removed)
    /// estimates to theirs: a product of mean-removed factors expands over
    /// the subsets S of its factors, Π(xᵢ − x̄ᵢ) = Σ_S Π_{i∈S} xᵢ · Π_{i∉S}(−x̄ᵢ),
    /// e.g. (a − ā)(b − b̄) = a·b − b̄·a − ā·b + ā·b̄.
    fn plain_basis(&self, model: &[usize]) -> (Vec<String>, DMatrix<f64>) {
        let mut terms: Vec<String> = std::iter::once("0".to_string())
            .chain(model.iter().map(|&j| self.candidates[j].name.clone()))
            .collect();
        let searched = terms.len();
        let mut rows: Vec<Vec<f64>> = (0..searched)
            .map(|i| (0..searched).map(|j| f64::from(u8::from(i == j))).collect())
            .collect();
        for (position, &j) in model.iter().enumerate() {
            let column = position + 1;
            let factors = &self.candidates[j].factors;
            if factors.len() < 2 {
                continue;
            }
            // Every proper subset of the factors (the full one is the term itself).
            for subset in 0..(1usize << factors.len()) - 1 {
                let kept: Vec<Regressor> = (0..factors.len())
                    .filter(|i| subset & (1 << i) != 0)
                    .map(|i| factors[i])
                    .collect();
                let weight: f64 = (0..factors.len())
                    .filter(|i| subset & (1 << i) == 0)
                    .map(|i| -self.means[factors[i] as usize])
                    .product();
                let key = Monomial::from_factors(&kept).map_or("0".to_string(), |m| m.key());
                let row = match terms.iter().position(|t| *t == key) {
                    Some(row) => row,
                    None => {
                        terms.push(key);
                        rows.push(vec![0.0; searched]);
                        rows.len() - 1
                    }
                };
                rows[row][column] += weight;
            }
        }
        let transform = DMatrix::from_fn(rows.len(), searched, |i, j| rows[i][j]);
        (terms, transform)
    }
}

#[cfg(test)]
mod tests;
