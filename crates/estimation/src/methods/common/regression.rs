//! The regression step the regression estimators share (equation error,
//! stepwise regression, estimation before modelling on smoothed
//! coefficients, the frequency-domain regression, the RBF Δ-method): one
//! ordinary least-squares problem `z = X·θ + ε` per coefficient with a free
//! parameter (reflex-wing UAV paper, §3.1, Eq. 25; Klein & Morelli,
//! "Aircraft System Identification", AIAA 2006, ch. 5).
//!
//! z is the measured coefficient minus the terms whose parameters are
//! fixed, X holds the regressors of the free terms from the measured
//! channels ([`aeroid_sim::aero::AeroModel::regressors`]). Drag in wind
//! axes with an Oswald factor e: the induced drag `CL²/(e·π·Λ)` uses the
//! measured CL; with e free the regressor `CL²/(π·Λ)` is fitted with
//! parameter 1/e and e is reported with the delta-method variance
//! `σ_e = σ_{1/e}·e²`. A term tied to a parameter (θ = c·θ_master + d)
//! adds c times its regressor to the master's column when the master is in
//! the same regression, and is a known term otherwise, the master's
//! coefficient fitted first (ties in a cycle between coefficients are
//! refused).
//!
//! The cost `½·εᵀε` (Eq. 26) is minimised by `θ̂ = (XᵀX)⁻¹·Xᵀz` (Eq. 27),
//! computed by SVD ([`aeroid_numerics::regression`]), with the
//! Cramér–Rao bound `s²·(XᵀX)⁻¹` and the bound corrected for coloured
//! residuals (Morelli & Klein 1997); the estimate is block-diagonal (the
//! coefficients are fitted separately).

use crate::error::{Error, Result};
use crate::estimate::Status;
use crate::estimate::{Estimate, OutputFit, ParameterEstimate};
use crate::estimator::Refusal;
use crate::reconstruction::{Reconstruction, Request};
use crate::structure::ModelStructure;
use aeroid_numerics::regression::{LagWindow, LeastSquares};
use aeroid_record::FlightRecord;
use aeroid_sim::aero::{Coefficient, ForceAxes, ModelKind, Monomial, Regressor};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

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
