//! Equation error (least squares) estimation of aerodynamic derivatives —
//! the comparison method of the ELM + Gauss–Newton and reflex-wing UAV papers (reflex-wing UAV paper, §3.1, Eqs. 25–27;
//! Klein & Morelli, "Aircraft System Identification", AIAA 2006, ch. 5).
//! Method `ee`; settings `[methods.ee]`: the differentiator of the angular
//! rates and the lag of the coloured-residual bound ([`EquationErrorSettings`]).
//!
//! Inputs: a flight record with load factors, angular rates, air data,
//! controls and (when the aircraft has thrust) throttle and altitude; a
//! postulated model structure (its aircraft's mass, inertia, geometry and
//! propulsion; its terms; which parameters are free).
//!
//! 1. The coefficients are reconstructed from the measured accelerations and
//!    angular accelerations (reflex-wing UAV paper, Eqs. 17–24; see
//!    [`crate::reconstruction`] for the equations, the thrust,
//!    q̄, the differentiator and the common time base).
//! 2. For each coefficient with a free parameter, one ordinary least-squares
//!    problem `z = X·θ + ε` (Eq. 25): z is the measured coefficient minus the
//!    terms whose parameters are fixed, X holds the regressors of the free
//!    terms from the measured channels ([`aeroid_sim::aero::AeroModel::regressors`]:
//!    α, β, normalised rates, controls, …). Drag in wind axes with an Oswald
//!    factor e: the induced drag `CL²/(e·π·Λ)` uses the measured CL; with e
//!    free the regressor `CL²/(π·Λ)` is fitted with parameter 1/e and e is
//!    reported with the delta-method variance `σ_e = σ_{1/e}·e²`.
//!    A product term's regressor is the product of its measured factors
//!    (`alpha^2` → α²). A term tied to a parameter (θ = c·θ_master + d)
//!    adds c times its regressor to the master's column when the master is
//!    in the same regression, and is a known term otherwise, the master's
//!    coefficient fitted first (ties in a cycle between coefficients are
//!    refused). Moments taken about a point other than the CG are moved
//!    there from the measured moments about the CG with the measured
//!    forces, M_ref = M_cg − r × F ([`aeroid_sim::aero::AeroModel::moment_transfer`]).
//! 3. The cost `½·εᵀε` (Eq. 26) is minimised by `θ̂ = (XᵀX)⁻¹·Xᵀz` (Eq. 27),
//!    computed by SVD ([`aeroid_numerics::regression`]), with the
//!    Cramér–Rao bound `s²·(XᵀX)⁻¹` and the bound corrected for coloured
//!    residuals (Morelli & Klein 1997). The CORRECTED bound is reported as
//!    each parameter's standard error; both appear in the notes.
//!
//! Outputs: an [`Estimate`] with method "ee", one fit per coefficient
//! (measured against modelled coefficient), a block-diagonal covariance
//! (the coefficients are fitted separately), and status Converged, or
//! Diverged with the reason when a regressor matrix is rank-deficient or
//! there are too few samples. A missing channel is an error naming it.
//!
//! Limitations, measured in `tests/estimators/equation_error.rs` (ATTAS multisine):
//! - the reflex-wing UAV paper's finding: least squares assumes noise-free regressors;
//!   measured α, β, rates and controls carry noise, so the estimates are
//!   attenuated towards zero (errors in variables). On the 25 Hz
//!   flight-test profile: CLα −5.6 %, Cmq −12.6 %, Clp −1.5 %, each as the
//!   errors-in-variables limit (M_xx + M_nn)⁻¹·M_xx·θ predicts, and several
//!   times larger than the reported standard errors;
//! - the moments need differentiated rates. A simulated step input makes
//!   the angular accelerations jump; the differentiator leaves out the
//!   samples whose window would cross a step found in a control channel
//!   ([`aeroid_record::prep::differentiation`]), so on noise-free data the
//!   moment derivatives are within 1e-3 on step inputs too, and within the
//!   differentiator's gain error (1.2e-3 on a 1.5 Hz multisine) otherwise.
//!   Forces and moments are reconstructed separately, so the force
//!   regressions keep the samples next to the steps.

use crate::estimate::Status;
use crate::estimate::{Estimate, OutputFit, ParameterEstimate};
use crate::estimator::{
    Capabilities, Description, Method, Refusal, Settings, merge_settings, parse_settings,
};
use crate::methods::linear_equation_error::linear_equation_error;
use crate::problem::EstimationProblem;
use crate::reconstruction::{
    AngularAccelerations, Reconstruction, ReconstructionOptions, Request, check_channels,
    reconstruct,
};
use crate::structure::{ModelStructure, Structure};
use aeroid_core::error::{Error, Result};
use aeroid_numerics::regression::{LagWindow, LeastSquares};
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use aeroid_sim::aero::{Coefficient, ForceAxes, ModelKind, Monomial, Regressor};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Method name in estimates.
pub const METHOD: &str = "ee";

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
const CORRELATION_LAG_SETTING: (&str, &str) = (
    "correlation_lag",
    "lag (s) to which residual autocorrelation is summed in the coloured-residual Cramér–Rao bound",
);
pub(crate) const ANGULAR_ACCELERATIONS_SETTING: (&str, &str) = (
    "angular_accelerations",
    "where ṗ, q̇, ṙ come from: \"differentiated\" (the rates), \"measured\" (the record's p_dot, q_dot, r_dot) or \"auto\" (measured when the record has all three)",
);

impl EquationErrorSettings {
    /// Reads and checks a `[methods.ee]` table.
    pub fn read(settings: &Settings) -> Result<EquationErrorSettings> {
        let parsed: EquationErrorSettings = parse_settings(METHOD, settings)?;
        EquationError::validate(&parsed)?;
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
    let problem = differentiator.problems().or_else(|| {
        (!(correlation_lag >= 0.0 && correlation_lag.is_finite()))
            .then(|| format!("correlation_lag must be at least 0 s, is {correlation_lag} s"))
    });
    match problem {
        Some(message) => Err(Error::Other(format!("[methods.{method}]: {message}"))),
        None => Ok(()),
    }
}

/// Equation error as a registered method.
pub struct EquationError;

impl Method for EquationError {
    const NAME: &'static str = METHOD;
    type Settings = EquationErrorSettings;

    fn describe() -> Description {
        Description {
            title: "equation error: least squares on coefficients reconstructed from accelerations and angular accelerations",
            paper: "Klein & Morelli, \"Aircraft System Identification\" (AIAA 2006), ch. 5; \"Longitudinal and lateral aerodynamic characterisation of reflex wing UAV from flight tests using ML, LS and neural Gauss Newton methods\"",
            equations: "coefficients from accelerations (reflex-wing UAV paper, Eqs. 17–24); z = Xθ + ε, θ = (XᵀX)⁻¹Xᵀz (Eqs. 25–27); coloured-residual bounds (Morelli & Klein 1997)",
            needs: "load factors, angular rates, airspeed, α, β, controls, dynamic pressure or altitude, throttle when the aircraft has thrust; a model linear in its parameters; on a linear structure, a channel of every state and input",
            settings: vec![
                DIFFERENTIATOR_SETTING,
                CORRELATION_LAG_SETTING,
                ANGULAR_ACCELERATIONS_SETTING,
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            tied_parameters: true,
            ..Capabilities::default()
        }
    }

    fn validate(settings: &EquationErrorSettings) -> Result<()> {
        check_settings(METHOD, &settings.differentiator, settings.correlation_lag)
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &EquationErrorSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        match &problem.structure {
            Structure::SixDof(structure) => {
                equation_error(problem.record(), structure, &settings.options())
            }
            Structure::Linear(structure) => linear_equation_error(
                problem.record(),
                structure,
                &settings.differentiator,
                settings.correlation_lag,
            ),
        }
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

/// What one coefficient's regression holds: its free terms and, for drag,
/// the Oswald factor.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    pub(crate) coefficient: Coefficient,
    /// (what the parameter multiplies, parameter index) of every term.
    pub(crate) terms: Vec<(Monomial, usize)>,
    /// Index of the Oswald factor e when this is wind-axis drag with one.
    oswald: Option<usize>,
}

impl Plan {
    fn free_terms<'a>(
        &'a self,
        structure: &'a ModelStructure,
    ) -> impl Iterator<Item = (Monomial, usize)> + 'a {
        self.terms
            .iter()
            .copied()
            .filter(|(_, i)| structure.free[*i])
    }

    /// Parameter indices in column order (the free terms, then e when free).
    pub(crate) fn columns(&self, structure: &ModelStructure) -> Vec<usize> {
        let mut columns: Vec<usize> = self.free_terms(structure).map(|(_, i)| i).collect();
        columns.extend(self.oswald.filter(|&e| structure.free[e]));
        columns
    }
}

/// The regression result of one coefficient.
pub(crate) struct CoefficientResult {
    /// Parameter indices (structure order) with value, corrected and white standard error.
    pub(crate) parameters: Vec<(usize, f64, f64, f64)>,
    pub(crate) covariance: DMatrix<f64>,
    pub(crate) fit: OutputFit,
    pub(crate) problem: Option<String>,
    /// Set when the Bartlett lag window replaced the plain truncated sum.
    pub(crate) window_note: Option<String>,
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
) -> std::result::Result<Estimate, String> {
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
            .map_err(|error| format!("no equation-error start ({error})"))?,
    };
    match &estimate.status {
        Status::Converged => Ok(estimate),
        status => Err(format!("equation error ended {status}")),
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

/// The regression step of the regression estimators (equation error, and
/// estimation before modelling on smoothed coefficients): for each group's
/// data, one least-squares fit per plan (Eqs. 25–27) with the
/// coloured-residual bound summed to `correlation_lag` seconds, assembled
/// into one estimate of `method` with the data's notes.
pub(crate) fn regress(
    record: &FlightRecord,
    structure: &ModelStructure,
    method: &str,
    groups: &[(Vec<Plan>, Reconstruction)],
    correlation_lag: f64,
) -> Estimate {
    let mut notes: Vec<String> = Vec::new();
    let mut lag = 0;
    let pending: Vec<(&Plan, &Reconstruction)> = groups
        .iter()
        .flat_map(|(group, reconstruction)| group.iter().map(move |plan| (plan, reconstruction)))
        .collect();
    let plans: Vec<&Plan> = pending.iter().map(|(plan, _)| *plan).collect();
    // The values the fixed and tied terms take: a tied term's master is
    // estimated (its coefficient fitted first) before the tied term is used.
    let mut values = structure.aircraft.aero.parameters.values().to_vec();
    let mut results: Vec<Option<CoefficientResult>> = (0..pending.len()).map(|_| None).collect();
    // [`plans`] refuses ties in a cycle; were there one, the given order.
    let order = fit_order(&plans, structure).unwrap_or_else(|_| (0..plans.len()).collect());
    for index in order {
        let (plan, reconstruction) = pending[index];
        lag = (correlation_lag * reconstruction.rate).round() as usize;
        let result = fit_coefficient(plan, structure, reconstruction, lag, &values);
        for &(i, value, ..) in &result.parameters {
            values[i] = value;
        }
        results[index] = Some(result);
    }
    let results: Vec<CoefficientResult> = results.into_iter().flatten().collect();
    for (_, reconstruction) in groups {
        for note in &reconstruction.notes {
            if !notes.contains(note) {
                notes.push(note.clone());
            }
        }
    }
    let mut estimate = assemble(record, structure, method, &results);
    estimate.notes.extend(notes);
    estimate.notes.push(format!(
        "standard errors: Cramér–Rao bounds corrected for coloured residuals (Morelli & Klein 1997), residual autocorrelation summed to lag {lag} samples ({correlation_lag} s)"
    ));
    estimate
        .notes
        .extend(results.iter().filter_map(|r| r.window_note.clone()));
    estimate
        .notes
        .extend(white_bound_notes(structure, &results));
    estimate
        .notes
        .extend(outside_bounds_notes(structure, &results));
    estimate
}

/// The order the plans are fitted in: as given, except that a plan with a
/// term tied to a parameter another plan estimates comes after that plan
/// (a tied term is a known one once its master is estimated). Err with
/// the plans left when their ties form a cycle.
fn fit_order(
    plans: &[&Plan],
    structure: &ModelStructure,
) -> std::result::Result<Vec<usize>, Vec<usize>> {
    let depends = |a: usize, b: usize| {
        a != b && masters(plans[a], structure).any(|m| plans[b].columns(structure).contains(&m))
    };
    let mut order: Vec<usize> = Vec::with_capacity(plans.len());
    while order.len() < plans.len() {
        let ready = (0..plans.len()).find(|&a| {
            !order.contains(&a) && (0..plans.len()).all(|b| order.contains(&b) || !depends(a, b))
        });
        match ready {
            Some(a) => order.push(a),
            None => return Err((0..plans.len()).filter(|a| !order.contains(a)).collect()),
        }
    }
    Ok(order)
}

/// The masters of a plan's tied terms.
fn masters<'a>(plan: &'a Plan, structure: &'a ModelStructure) -> impl Iterator<Item = usize> + 'a {
    let aero = &structure.aircraft.aero;
    plan.terms
        .iter()
        .filter_map(|(_, i)| aero.tie_of(*i).map(|tie| tie.master))
}

/// One plan per coefficient that has a free parameter; `method` names the
/// estimator in a refusal (a model not linear in its parameters, or nothing
/// to estimate).
pub(crate) fn plans(structure: &ModelStructure, method: &str) -> Result<Vec<Plan>> {
    let aero = &structure.aircraft.aero;
    if aero.kind != ModelKind::Linear {
        return Err(Error::Refused(Refusal::NotLinearInParameters {
            method: method.to_string(),
            model: structure.name.clone(),
            model_kind: format!("{:?}", aero.kind).to_lowercase(),
        }));
    }
    let oswald = aero.parameters.index("e");
    let plans: Vec<Plan> = Coefficient::ALL
        .into_iter()
        .map(|coefficient| Plan {
            coefficient,
            terms: aero.terms(coefficient).collect(),
            oswald: oswald
                .filter(|_| coefficient == Coefficient::Drag && aero.force_axes == ForceAxes::Wind),
        })
        .filter(|plan| !plan.columns(structure).is_empty())
        .collect();
    if plans.is_empty() {
        return Err(Error::Refused(Refusal::NothingToEstimate {
            method: method.to_string(),
            model: structure.name.clone(),
        }));
    }
    let all: Vec<&Plan> = plans.iter().collect();
    if let Err(cycle) = fit_order(&all, structure) {
        let names: Vec<&str> = (cycle.iter())
            .map(|&i| plans[i].coefficient.name(aero.force_axes))
            .collect();
        return Err(Error::Refused(Refusal::UnsuitableModel {
            method: method.to_string(),
            model: structure.name.clone(),
            reason: format!(
                "the terms of {} are tied in a cycle to each other's parameters: the regressions fit one coefficient at a time, a master's before the terms tied to it",
                names.join(", ")
            ),
        }));
    }
    Ok(plans)
}

/// The coefficients and regressors to reconstruct: the measured lift too when
/// drag needs CL² (an Oswald factor or a CL2 term).
pub(crate) fn request(plans: &[Plan]) -> Request {
    let mut request = Request::default();
    for plan in plans {
        request.coefficients.push(plan.coefficient);
        request
            .regressors
            .extend(plan.terms.iter().flat_map(|(term, _)| term.factors()));
        let uses_lift = plan.oswald.is_some()
            || plan
                .terms
                .iter()
                .any(|(term, _)| term.contains(Regressor::LiftSquared));
        if uses_lift && !request.coefficients.contains(&Coefficient::Lift) {
            request.coefficients.push(Coefficient::Lift);
        }
    }
    request
}

/// Induced-drag regressor CL²/(π·Λ), whose parameter is 1/e.
fn induced_drag_regressor(structure: &ModelStructure, lift: f64) -> f64 {
    lift * lift / (PI * structure.aircraft.geometry.aspect_ratio)
}

/// The regression of one coefficient.
fn fit_coefficient(
    plan: &Plan,
    structure: &ModelStructure,
    data: &Reconstruction,
    lag: usize,
    values: &[f64],
) -> CoefficientResult {
    let name = plan.coefficient.name(structure.aircraft.aero.force_axes);
    let columns = plan.columns(structure);
    let measured = data.coefficient(plan.coefficient);
    if measured.len() <= columns.len() {
        let reason = format!(
            "{name}: {} samples for {} parameters",
            measured.len(),
            columns.len()
        );
        return failed_coefficient(name, &columns, reason);
    }
    let (x, z) = regression_problem(plan, structure, data, &columns, values);
    fit_regression(
        plan,
        structure,
        &columns,
        (&x, &z),
        measured,
        Bound::Coloured(lag),
    )
}

/// Which Cramér–Rao bound a regression reports.
pub(crate) enum Bound<'a> {
    /// Corrected for coloured residuals, autocorrelation summed to this lag (rows).
    Coloured(usize),
    /// For residuals whose variance differs from row to row: each row's
    /// variance from the residuals ([`LeastSquares::weighted_covariance`]).
    RowVariances(&'a dyn Fn(&DVector<f64>) -> Vec<f64>),
}

/// The least-squares fit of one coefficient's regression `z = X·θ` (the
/// columns of X are `columns`, a free Oswald factor last as 1/e), with the
/// reported bound (the white one s²·(XᵀX)⁻¹ in the notes) and the fit of
/// `measured` (z plus the fixed terms, row for row).
pub(crate) fn fit_regression(
    plan: &Plan,
    structure: &ModelStructure,
    columns: &[usize],
    (x, z): (&DMatrix<f64>, &DVector<f64>),
    measured: &[f64],
    bound: Bound,
) -> CoefficientResult {
    let name = plan.coefficient.name(structure.aircraft.aero.force_axes);
    let fit = LeastSquares::fit(x, z);
    let (mut covariance, window) = match bound {
        Bound::Coloured(lag) => fit.corrected_covariance(x, lag),
        Bound::RowVariances(variances) => (
            fit.weighted_covariance(x, &variances(&fit.residuals)),
            LagWindow::Rectangular,
        ),
    };
    let window_note = (window == LagWindow::Bartlett).then(|| {
        format!(
            "{name}: the truncated residual autocorrelation sum was not positive definite; its standard errors use Bartlett (triangular) lag weights"
        )
    });
    let mut white = fit.white_covariance();
    let mut theta = fit.theta.clone();
    if plan.oswald.is_some_and(|e| structure.free[e]) {
        to_oswald_factor(&mut theta, &mut covariance, &mut white);
    }
    let predicted: Vec<f64> = (0..measured.len())
        .map(|k| measured[k] - fit.residuals[k])
        .collect();
    let names = structure.aircraft.aero.parameters.names();
    let problem = (!fit.unidentifiable.is_empty()).then(|| {
        let unidentifiable: Vec<&str> = fit
            .unidentifiable
            .iter()
            .map(|&j| names[columns[j]].as_str())
            .collect();
        format!(
            "{name}: the regressors of {} are not independent in this record (not excited, or excited together); fix some of them or fly a richer manoeuvre",
            unidentifiable.join(", ")
        )
    });
    CoefficientResult {
        parameters: columns
            .iter()
            .enumerate()
            .map(|(j, &i)| (i, theta[j], covariance[(j, j)].sqrt(), white[(j, j)].sqrt()))
            .collect(),
        covariance,
        fit: OutputFit::new(name, measured, &predicted),
        problem,
        window_note,
    }
}

/// X (regressors of the free terms, then CL²/(π·Λ) for a free e) and z (the
/// measured coefficient minus the fixed terms) of one coefficient, the
/// fixed terms at `values`. A term tied to a parameter of this regression
/// (θ = c·θ_master + d) adds c times its regressor to the master's column
/// and d times it to the known part; one tied to another coefficient's
/// parameter is known, at `values`.
pub(crate) fn regression_problem(
    plan: &Plan,
    structure: &ModelStructure,
    data: &Reconstruction,
    columns: &[usize],
    values: &[f64],
) -> (DMatrix<f64>, DVector<f64>) {
    let aero = &structure.aircraft.aero;
    let measured = data.coefficient(plan.coefficient);
    let lift = data.coefficient(Coefficient::Lift);
    let count = measured.len();
    // Per term: the column its regressor goes to with its factor, or None (known).
    let placement = |i: usize| -> Option<(usize, f64)> {
        let (parameter, factor) = match aero.tie_of(i) {
            Some(tie) => (tie.master, tie.factor),
            None => (i, 1.0),
        };
        columns
            .iter()
            .position(|&c| c == parameter)
            .map(|j| (j, factor))
    };
    let mut x = DMatrix::zeros(count, columns.len());
    for (j, &i) in columns.iter().enumerate() {
        if plan.oswald == Some(i) {
            x.column_mut(j)
                .iter_mut()
                .zip(lift)
                .for_each(|(x, &lift)| *x = induced_drag_regressor(structure, lift));
        }
    }
    for (term, i) in &plan.terms {
        if let Some((j, factor)) = placement(*i) {
            for k in 0..count {
                x[(k, j)] += factor * term.value(&data.regressors[k]);
            }
        }
    }
    let known = |i: usize| match (aero.tie_of(i), placement(i)) {
        (Some(tie), Some(_)) => tie.offset,
        (Some(tie), None) => tie.value(values),
        (None, _) => values[i],
    };
    let fixed_part = |k: usize| -> f64 {
        let terms: f64 = plan
            .terms
            .iter()
            .filter(|(_, i)| !structure.free[*i])
            .map(|(term, i)| known(*i) * term.value(&data.regressors[k]))
            .sum();
        let induced = match plan.oswald {
            Some(e) if !structure.free[e] => induced_drag_regressor(structure, lift[k]) / values[e],
            _ => 0.0,
        };
        terms + induced
    };
    let z = DVector::from_fn(count, |k, _| measured[k] - fixed_part(k));
    (x, z)
}

/// Replaces the last parameter k = 1/e by e = 1/k, with the delta-method
/// covariance (∂e/∂k = −1/k²).
fn to_oswald_factor(
    theta: &mut DVector<f64>,
    covariance: &mut DMatrix<f64>,
    white: &mut DMatrix<f64>,
) {
    let last = theta.len() - 1;
    let inverse = theta[last];
    theta[last] = 1.0 / inverse;
    let mut jacobian = DMatrix::identity(theta.len(), theta.len());
    jacobian[(last, last)] = -1.0 / (inverse * inverse);
    *covariance = &jacobian * &*covariance * &jacobian;
    *white = &jacobian * &*white * &jacobian;
}

/// A coefficient that could not be fitted: start values, infinite variance.
pub(crate) fn failed_coefficient(
    name: &str,
    columns: &[usize],
    reason: String,
) -> CoefficientResult {
    let n = columns.len();
    CoefficientResult {
        parameters: columns
            .iter()
            .map(|&i| (i, f64::NAN, f64::INFINITY, f64::INFINITY))
            .collect(),
        covariance: DMatrix::from_element(n, n, f64::INFINITY),
        fit: OutputFit::new(name, &[], &[]),
        problem: Some(reason),
        window_note: None,
    }
}

/// The estimate from the per-coefficient results, parameters in structure order.
pub(crate) fn assemble(
    record: &FlightRecord,
    structure: &ModelStructure,
    method: &str,
    results: &[CoefficientResult],
) -> Estimate {
    let aero = &structure.aircraft.aero;
    let parameters = (aero.parameters.names(), aero.parameters.values());
    assemble_named(record, &structure.name, parameters, method, results)
}

/// [`assemble`] for a model named `model` whose parameters have `names`
/// and start values `starts`.
pub(crate) fn assemble_named(
    record: &FlightRecord,
    model: &str,
    (names, starts): (&[String], &[f64]),
    method: &str,
    results: &[CoefficientResult],
) -> Estimate {
    let mut entries: Vec<(usize, f64, f64)> = results
        .iter()
        .flat_map(|r| r.parameters.iter().map(|&(i, v, se, _)| (i, v, se)))
        .collect();
    entries.sort_by_key(|e| e.0);
    let order: Vec<usize> = entries.iter().map(|e| e.0).collect();
    let covariance = block_covariance(
        results.iter().map(|r| {
            let indices: Vec<usize> = r.parameters.iter().map(|p| p.0).collect();
            (indices, &r.covariance)
        }),
        &order,
    );
    let problems: Vec<String> = results.iter().filter_map(|r| r.problem.clone()).collect();
    Estimate {
        method: method.to_string(),
        model: model.to_string(),
        record: record_name(record),
        diagnoses: Vec::new(),
        status: if problems.is_empty() {
            Status::Converged
        } else {
            Status::Diverged(problems.join("; "))
        },
        parameters: entries
            .iter()
            .map(|&(i, value, standard_error)| ParameterEstimate {
                name: names[i].clone(),
                value: if value.is_nan() { starts[i] } else { value },
                standard_error,
                start: starts[i],
            })
            .collect(),
        covariance,
        fits: results.iter().map(|r| r.fit.clone()).collect(),
        iterations: 1,
        cost_history: Vec::new(),
        wall_time: 0.0,
        notes: Vec::new(),
        details: String::new(),
        network: None,
        distributions: Vec::new(),
        histories: Vec::new(),
    }
}

/// The covariance of separately fitted regressions: each block the
/// covariance of the parameters it lists (indices into the structure's),
/// rows and columns in `order` (every listed index once), zero between
/// blocks.
pub(crate) fn block_covariance<'a>(
    blocks: impl Iterator<Item = (Vec<usize>, &'a DMatrix<f64>)>,
    order: &[usize],
) -> Vec<Vec<f64>> {
    let position = |index: usize| order.iter().position(|&i| i == index).unwrap_or(0);
    let mut covariance = vec![vec![0.0; order.len()]; order.len()];
    for (indices, block) in blocks {
        for (a, &i) in indices.iter().enumerate() {
            for (b, &j) in indices.iter().enumerate() {
                covariance[position(i)][position(j)] = block[(a, b)];
            }
        }
    }
    covariance
}

/// A record's name for estimates: its scenario, else its profile.
pub(crate) fn record_name(record: &FlightRecord) -> String {
    record.name().to_string()
}

/// A note for each estimate outside its bounds in the structure file (least
/// squares has no bounds; output error would stop at them).
pub(crate) fn outside_bounds_notes(
    structure: &ModelStructure,
    results: &[CoefficientResult],
) -> Vec<String> {
    let names = structure.aircraft.aero.parameters.names();
    results
        .iter()
        .flat_map(|r| r.parameters.iter())
        .filter(|&&(i, value, ..)| {
            let (low, high) = structure.bounds[i];
            value < low || value > high
        })
        .map(|&(i, value, ..)| {
            let (low, high) = structure.bounds[i];
            format!(
                "{} = {value:.6e} lies outside its bounds [{low}, {high}] (least squares does not apply bounds)",
                names[i]
            )
        })
        .collect()
}

/// One note with every parameter's white-residual bound and the correction ratio.
pub(crate) fn white_bound_notes(
    structure: &ModelStructure,
    results: &[CoefficientResult],
) -> Vec<String> {
    white_bound_notes_named(structure.aircraft.aero.parameters.names(), results)
}

/// [`white_bound_notes`] for parameters of `names`.
pub(crate) fn white_bound_notes_named(
    names: &[String],
    results: &[CoefficientResult],
) -> Vec<String> {
    let items: Vec<String> = results
        .iter()
        .flat_map(|r| r.parameters.iter())
        .map(|&(i, _, corrected, white)| {
            format!(
                "{} {:.3e} (corrected/white {:.2})",
                names[i],
                white,
                corrected / white
            )
        })
        .collect();
    vec![format!(
        "white-residual Cramér–Rao bounds s²(XᵀX)⁻¹: {}",
        items.join(", ")
    )]
}
