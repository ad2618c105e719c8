//! RBF network + Delta method (`rbf-delta`): Wang et al., "Aerodynamic
//! modeling and parameter estimation from QAR data of an airplane
//! approaching a high-altitude airport", Chinese J. Aeronautics 25 (2012),
//! §3.3–3.4, Eqs. 25–33, with the Delta method of Raisinghani, Ghosh &
//! Kalra (1998) that they cite. The user reference is docs/methods.md,
//! "RBF network + Delta method".
//!
//! 1. **Coefficient data** (setting `coefficients`): the EKF + modified
//!    Bryson–Frazier smoothed coefficients of Wang et al.'s pipeline
//!    (Eqs. 7–24, the smoother of method `ebm`,
//!    [`super::smoothed_regression`]), or the coefficients reconstructed from
//!    measured accelerations and angular accelerations
//!    ([`crate::reconstruction`]); `auto`: reconstructed when the record has
//!    the channels that needs (a QAR records no angular rates).
//! 2. **Networks** (Eqs. 25–32, [`crate::neural::rbf`]): one
//!    multi-input single-output network per coefficient with a free
//!    parameter; inputs (Eq. 27) (Mach, α, β, q̂, δe, δf) for CL, CD, Cm and
//!    (Mach, α, β, p̂, r̂, δa, δr) for CY, Cl, Cn, each as the structure
//!    defines its regressor, so that a derivative of the network is
//!    directly the structure's parameter. An input constant on the record
//!    (or without a channel) is left out, with a note.
//! 3. **Delta method** (Eq. 33): at every sample, ∂C/∂xⱼ by central
//!    differences through the trained network (`difference_step`, scaled
//!    units). Each derivative's values over the record form a
//!    [`ParameterDistribution`] (mean, standard deviation, 5 %, 50 % and
//!    95 % points and the value at the trim point).
//! 4. **Parameters.** A derivative's value is the median of its local
//!    values (the whole record, robust to where the network is poorly
//!    supported); a bias term is the median of
//!    C₀(k) = C(xₖ) − Σⱼ ∂C/∂xⱼ(xₖ)·xⱼ,ₖ over the structure's terms. Terms
//!    whose regressor is not a network input (α̇, V/V₀, CL², the Oswald
//!    factor) are not estimated (a note names them).
//! 5. **Standard errors**: the standard deviation of the local values (the
//!    Delta method has no Cramér–Rao bound; the notes say so).
//! 6. **Status.** Not converged when a network's R² is below
//!    `minimum_r_squared` (poor fit), or when a derivative's 5–95 % interval
//!    contains zero (unidentified, naming the parameters).
//!
//! Every estimate carries the networks' report (`network`: centres, width
//! factors, MSE and R², Verma & Peyada 2020 Eqs. 21–22) and the
//! distributions (`distributions`). No random numbers: the seed is 0.

use crate::error::{Error, Result};
use crate::estimate::{
    Diagnosis, DiagnosisKind, Estimate, OutputFit, ParameterDistribution, ParameterEstimate, Status,
};
use crate::estimator::{Capabilities, Description, Method, Refusal, Settings, parse_settings};
use crate::methods::common::regression::{self, Plan, record_name};
use crate::methods::common::smoothing::{self, SmoothedRegressionSettings};
use crate::neural::rbf::{RbfNetwork, RbfOptions, WidthSearch};
use crate::neural::{NetworkReport, fit_metrics};
use crate::problem::EstimationProblem;
use crate::reconstruction::{
    Reconstruction, ReconstructionOptions, Request, missing_channels, reconstruct,
};
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;
use aeroid_sim::aero::{Coefficient, Regressor};
use serde::{Deserialize, Serialize};

mod data;

use data::{TrainingData, coefficient_data};

/// Method name in estimates.
pub const METHOD: &str = "rbf-delta";

/// Network inputs of a longitudinal coefficient (Eq. 27).
const LONGITUDINAL_INPUTS: [Regressor; 6] = [
    Regressor::Mach,
    Regressor::Alpha,
    Regressor::Beta,
    Regressor::PitchRate,
    Regressor::Elevator,
    Regressor::Flap,
];

/// Network inputs of a lateral coefficient (Eq. 27).
const LATERAL_INPUTS: [Regressor; 7] = [
    Regressor::Mach,
    Regressor::Alpha,
    Regressor::Beta,
    Regressor::RollRate,
    Regressor::YawRate,
    Regressor::Aileron,
    Regressor::Rudder,
];

fn inputs_of(coefficient: Coefficient) -> &'static [Regressor] {
    match coefficient {
        Coefficient::Lift | Coefficient::Drag | Coefficient::Pitch => &LONGITUDINAL_INPUTS,
        Coefficient::Side | Coefficient::Roll | Coefficient::Yaw => &LATERAL_INPUTS,
    }
}

/// Where the networks' coefficient data come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CoefficientSource {
    /// Reconstructed when the record allows it, else smoothed.
    Auto,
    /// The EKF + modified Bryson–Frazier smoothed coefficients (Eqs. 7–24).
    Smoothed,
    /// From measured accelerations and angular accelerations.
    Reconstructed,
}

/// The `[methods.rbf-delta]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RbfDeltaSettings {
    /// Cluster radius d in scaled input units (Eq. 28).
    pub radius: f64,
    /// The range of the width factor λ searched (σ = λ·d, Eq. 30).
    pub width_factor_range: [f64; 2],
    /// The samples the width search scores λ on.
    pub width_search: WidthSearch,
    /// The range inputs and outputs are scaled to.
    pub scaling_range: [f64; 2],
    pub coefficients: CoefficientSource,
    /// Central-difference step δ of Eq. 33, in scaled input units.
    pub difference_step: f64,
    /// Time (s) of the trim point; none: the first sample.
    pub trim: Option<f64>,
    /// A network reproducing its coefficient with a lower R² makes the
    /// estimate a poor fit.
    pub minimum_r_squared: f64,
    /// The smoother's settings (those of `[methods.ebm]`) for smoothed coefficients.
    pub smoother: SmoothedRegressionSettings,
}

impl Default for RbfDeltaSettings {
    fn default() -> Self {
        let network = RbfOptions::default();
        RbfDeltaSettings {
            radius: network.radius,
            width_factor_range: [network.width_factors.0, network.width_factors.1],
            width_search: network.search,
            scaling_range: [network.scaling.0, network.scaling.1],
            coefficients: CoefficientSource::Auto,
            difference_step: 0.01,
            trim: None,
            minimum_r_squared: 0.9,
            smoother: SmoothedRegressionSettings::default(),
        }
    }
}

const SETTINGS: &[(&str, &str)] = &[
    (
        "radius",
        "cluster radius d in scaled input units (Eq. 28): smaller gives more centres",
    ),
    (
        "width_factor_range",
        "the range of λ searched, widths σ = λ·d (Eq. 30)",
    ),
    (
        "width_search",
        "\"held-out\": λ scored on held-out segments of the record; \"training\": on the training samples (Eq. 30 as printed)",
    ),
    (
        "scaling_range",
        "the range inputs and outputs are scaled to (Eq. 16 of Verma & Peyada)",
    ),
    (
        "coefficients",
        "\"auto\", \"smoothed\" (EKF + MBF smoother, Eqs. 7–24) or \"reconstructed\" (from measured accelerations)",
    ),
    (
        "difference_step",
        "central-difference step δ of the Delta method (Eq. 33), in scaled input units",
    ),
    (
        "trim",
        "time (s) of the trim point whose local derivatives are reported; none: the first sample",
    ),
    (
        "minimum_r_squared",
        "a network with a lower R² on its coefficient makes the estimate a poor fit",
    ),
    (
        "smoother",
        "the smoother's settings, keys as in [methods.ebm], for smoothed coefficients",
    ),
];

impl RbfDeltaSettings {
    /// Reads and checks a `[methods.rbf-delta]` table.
    pub fn read(settings: &Settings) -> Result<RbfDeltaSettings> {
        let parsed: RbfDeltaSettings = parse_settings(METHOD, settings)?;
        parsed.check()?;
        Ok(parsed)
    }

    /// Checks the values' ranges, naming the offending key.
    pub fn check(&self) -> Result<()> {
        let refuse = |key: &str, message: String| {
            Err(Error::Settings {
                method: METHOD.to_string(),
                reason: format!("{key}: {message}"),
            })
        };
        let positive = |v: f64| v > 0.0 && v.is_finite();
        if !positive(self.radius) {
            return refuse("radius", format!("must be positive, is {}", self.radius));
        }
        let [low, high] = self.width_factor_range;
        if !(positive(low) && positive(high) && low < high) {
            return refuse(
                "width_factor_range",
                format!("must be two positive values, the first smaller: {low}, {high}"),
            );
        }
        let [low, high] = self.scaling_range;
        if !(low.is_finite() && high.is_finite() && low < high) {
            return refuse(
                "scaling_range",
                format!("must be two finite values, the first smaller: {low}, {high}"),
            );
        }
        if !positive(self.difference_step) {
            return refuse(
                "difference_step",
                format!("must be positive, is {}", self.difference_step),
            );
        }
        if !(0.0..1.0).contains(&self.minimum_r_squared) {
            return refuse(
                "minimum_r_squared",
                format!("must be in [0, 1), is {}", self.minimum_r_squared),
            );
        }
        if let Some(trim) = self.trim.filter(|t| !t.is_finite()) {
            return refuse("trim", format!("must be a finite time, is {trim}"));
        }
        let smoother = serde_json::to_value(&self.smoother)
            .ok()
            .and_then(|v| v.as_object().cloned())
            .unwrap_or_default();
        SmoothedRegressionSettings::read(&smoother).map_err(|e| Error::Settings {
            method: METHOD.to_string(),
            reason: format!("smoother: {e}"),
        })?;
        Ok(())
    }

    fn network(&self) -> RbfOptions {
        RbfOptions {
            radius: self.radius,
            width_factors: (self.width_factor_range[0], self.width_factor_range[1]),
            search: self.width_search,
            scaling: (self.scaling_range[0], self.scaling_range[1]),
        }
    }
}

/// The RBF network + Delta method as a registered method.
pub(crate) struct RbfDelta;

impl Method for RbfDelta {
    const NAME: &'static str = METHOD;
    type Settings = RbfDeltaSettings;

    fn describe() -> Description {
        Description {
            title: "RBF network per aerodynamic coefficient (clustering, width search, least-squares weights), derivatives by the Delta method at every sample",
            paper: "Wang et al., \"Aerodynamic modeling and parameter estimation from QAR data of an airplane approaching a high-altitude airport\", Chinese J. Aeronautics 25 (2012); Raisinghani, Ghosh & Kalra, \"Two new techniques for parameter estimation using neural networks\", Aeronautical J. 102 (1998)",
            equations: "RBF network (Eqs. 25–27), clustering (Eqs. 28–29), width search (Eq. 30), least-squares weights (Eqs. 31–32), Delta method (Eq. 33); coefficients from the EKF + MBF smoother (Eqs. 7–24) or reconstructed from accelerations",
            needs: "reconstructed: load factors, α, β, angular rates, airspeed, altitude or dynamic pressure, controls, throttle when the aircraft has thrust; smoothed: what ebm needs; a structure linear in its parameters (its derivatives are the networks' input derivatives)",
            settings: SETTINGS.to_vec(),
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities::default()
    }

    fn validate(settings: &RbfDeltaSettings) -> Result<()> {
        settings.check()
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &RbfDeltaSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let started = std::time::Instant::now();
        let mut estimate = rbf_delta(
            problem.record(),
            problem.structure.six_dof(METHOD)?,
            settings,
        )?;
        estimate.wall_time = started.elapsed().as_secs_f64();
        Ok(estimate)
    }
}

/// A trained network and its Delta-method results.
struct Delta {
    data: TrainingData,
    network: RbfNetwork,
    predictions: Vec<f64>,
    /// Per input, ∂C/∂xⱼ at every sample (unscaled).
    derivatives: Vec<Vec<f64>>,
    /// C₀ at every sample (module header, step 4): the network's
    /// linearisation about each sample extrapolated to zero regressors, the
    /// inputs that are not terms of the coefficient held where they are (the
    /// network's output at zero inputs itself would be an extrapolation
    /// outside the training data).
    bias: Vec<f64>,
    mse: f64,
    r_squared: f64,
}

/// Trains the network of one coefficient and evaluates Eq. 33 at every sample.
fn train_and_differentiate(
    data: TrainingData,
    plan: &Plan,
    settings: &RbfDeltaSettings,
) -> Result<Delta> {
    let names: Vec<String> = data.inputs.iter().map(|r| r.key().to_string()).collect();
    let network = RbfNetwork::train(&data.rows, &names, &data.targets, &settings.network())
        .map_err(|e| Error::Method {
            reason: format!("{METHOD}: {} network: {e}", data.name),
        })?;
    let m = data.inputs.len();
    let n = data.rows.len();
    let factors: Vec<f64> = (0..m).map(|j| network.derivative_factor(j)).collect();
    // The bias subtracts the terms the structure has: its other inputs
    // are held where they are.
    let in_structure: Vec<bool> = data
        .inputs
        .iter()
        .map(|r| plan.terms.iter().any(|(t, _)| t.single() == Some(*r)))
        .collect();
    let mut derivatives = vec![Vec::with_capacity(n); m];
    let mut bias = Vec::with_capacity(n);
    let mut predictions = Vec::with_capacity(n);
    let mut buffer = vec![0.0; m];
    for row in &data.rows {
        let prediction = network.predict(row, &mut buffer);
        let mut linear = 0.0;
        for j in 0..m {
            let local =
                network.central_difference(&mut buffer, j, settings.difference_step) * factors[j];
            derivatives[j].push(local);
            if in_structure[j] {
                linear += local * row[j];
            }
        }
        predictions.push(prediction);
        bias.push(prediction - linear);
    }
    let scaled = |values: &[f64]| -> Vec<[f64; 1]> {
        values
            .iter()
            .map(|&y| {
                let mut v = [y];
                network.output_scaling.apply(&mut v);
                v
            })
            .collect()
    };
    let (mse, r_squared) = fit_metrics(&scaled(&data.targets), &scaled(&predictions));
    Ok(Delta {
        data,
        network,
        predictions,
        derivatives,
        bias,
        mse,
        r_squared,
    })
}

/// The distribution of local values `values` (not empty), with its value
/// at sample `trim`.
fn distribution(name: &str, values: &[f64], trim: usize) -> ParameterDistribution {
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let percentile = |p: f64| {
        let position = p * (n - 1) as f64;
        let below = position.floor() as usize;
        let above = (below + 1).min(n - 1);
        sorted[below] + (position - below as f64) * (sorted[above] - sorted[below])
    };
    ParameterDistribution {
        name: name.to_string(),
        samples: n,
        mean,
        standard_deviation: variance.sqrt(),
        p05: percentile(0.05),
        median: percentile(0.5),
        p95: percentile(0.95),
        at_trim: values[trim.min(n - 1)],
    }
}

/// The sample nearest `trim` seconds, or the first.
fn trim_index(times: &[f64], trim: Option<f64>) -> usize {
    trim.map_or(0, |t| {
        times
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - t).abs().total_cmp(&(b.1 - t).abs()))
            .map_or(0, |(k, _)| k)
    })
}

/// The network of one coefficient's training data, trained and
/// differentiated ([`train_and_differentiate`]); a refusal when the data
/// are fewer than twice the unknowns or have no input.
fn train(training: TrainingData, plans: &[Plan], settings: &RbfDeltaSettings) -> Result<Delta> {
    let unknowns = training.inputs.len() + 1;
    if training.rows.len() < 2 * unknowns || training.inputs.is_empty() {
        return Err(Error::Refused(Refusal::TooFewData {
            method: METHOD.to_string(),
            data: training.rows.len(),
            unknowns,
        }));
    }
    let plan = plans
        .iter()
        .find(|p| p.coefficient == training.coefficient)
        .ok_or_else(|| Error::Method {
            reason: format!("{METHOD}: no plan for {}", training.name),
        })?;
    train_and_differentiate(training, plan, settings)
}

/// The local values of the parameter of the term with `regressor` (None:
/// a product, which is no network input, so its parameter is not
/// estimated): ∂C/∂x of its input, or C₀ for the constant when every
/// other term of the coefficient is an input (one whose regressor is no
/// input, CL² or the Oswald factor, would stay in C₀).
fn local_values<'d>(
    structure: &ModelStructure,
    plan: &Plan,
    delta: &'d Delta,
    regressor: Option<Regressor>,
) -> Option<&'d Vec<f64>> {
    if regressor == Some(Regressor::Constant) {
        let complete = plan.columns(structure).iter().all(|&i| {
            plan.terms.iter().any(|&(r, t)| {
                t == i
                    && r.single()
                        .is_some_and(|r| r == Regressor::Constant || delta.data.inputs.contains(&r))
            })
        });
        complete.then_some(&delta.bias)
    } else {
        let position = (delta.data.inputs.iter()).position(|&r| Some(r) == regressor);
        position.map(|j| &delta.derivatives[j])
    }
}

/// The note on the network of coefficient `name`: its data, centres,
/// width, fit and trim point (sample `trim`).
fn network_note(name: &str, delta: &Delta, settings: &RbfDeltaSettings, trim: usize) -> String {
    format!(
        "{name} network: {} samples from {:.3} s, {} inputs ({}), {} centres (radius {}), width factor λ = {:.4} (σ = {:.4}), MSE {:.3e}, R² {:.6}; trim point at {:.3} s",
        delta.data.rows.len(),
        delta.data.times.first().copied().unwrap_or(f64::NAN),
        delta.data.inputs.len(),
        delta
            .data
            .inputs
            .iter()
            .map(|r| r.key())
            .collect::<Vec<_>>()
            .join(", "),
        delta.network.centre_count(),
        settings.radius,
        delta.network.width_factor,
        delta.network.width(),
        delta.mse,
        delta.r_squared,
        delta.data.times.get(trim).copied().unwrap_or(f64::NAN),
    )
}

/// The parameters the networks estimate, with the distributions of their
/// local values, the derivatives' names among them, and the free
/// parameters not estimated.
struct Local {
    parameters: Vec<ParameterEstimate>,
    distributions: Vec<ParameterDistribution>,
    derivative_names: Vec<String>,
    not_estimated: Vec<String>,
}

/// Each coefficient's parameters from its network's local values (the
/// median and spread of each over the record), a note on each network and
/// on its width search pushed to `notes`.
fn local_estimates(
    structure: &ModelStructure,
    plans: &[Plan],
    deltas: &[Delta],
    settings: &RbfDeltaSettings,
    notes: &mut Vec<String>,
) -> Local {
    let aero = &structure.aircraft.aero;
    let (names, starts) = (aero.parameters.names(), aero.parameters.values());
    let axes = aero.force_axes;
    let mut parameters = Vec::new();
    let mut distributions = Vec::new();
    let mut derivative_names = Vec::new();
    let mut not_estimated = Vec::new();
    for plan in plans {
        let Some(delta) = deltas
            .iter()
            .find(|d| d.data.coefficient == plan.coefficient)
        else {
            continue;
        };
        let trim = trim_index(&delta.data.times, settings.trim);
        let mut covered = Vec::new();
        for &(term, index) in &plan.terms {
            if !structure.free[index] {
                continue;
            }
            let regressor = term.single();
            let Some(values) = local_values(structure, plan, delta, regressor) else {
                continue;
            };
            let spread = distribution(&names[index], values, trim);
            parameters.push(ParameterEstimate {
                name: names[index].clone(),
                value: spread.median,
                standard_error: spread.standard_deviation,
                start: starts[index],
            });
            if regressor != Some(Regressor::Constant) {
                derivative_names.push(names[index].clone());
            }
            distributions.push(spread);
            covered.push(index);
        }
        not_estimated.extend(
            plan.columns(structure)
                .into_iter()
                .filter(|i| !covered.contains(i))
                .map(|i| names[i].clone()),
        );
        notes.push(network_note(
            plan.coefficient.name(axes),
            delta,
            settings,
            trim,
        ));
        notes.push(search_note(
            plan.coefficient.name(axes),
            &delta.network,
            settings,
        ));
    }
    Local {
        parameters,
        distributions,
        derivative_names,
        not_estimated,
    }
}

/// Estimates the structure's derivatives from `record` by RBF networks and
/// the Delta method (module header).
pub fn rbf_delta(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &RbfDeltaSettings,
) -> Result<Estimate> {
    let plans = regression::plans(structure, METHOD)?;
    let mut notes = Vec::new();
    // The Mach input is Mach − the structure's reference Mach; a structure
    // without a Mach term has none, and the input is the Mach number.
    let mut inputs_structure = structure.clone();
    let reference_mach = &mut inputs_structure.aircraft.aero.reference_mach;
    if reference_mach.is_nan() {
        *reference_mach = 0.0;
    }
    let data = coefficient_data(record, &inputs_structure, &plans, settings, &mut notes)?;
    let deltas = data
        .into_iter()
        .map(|training| train(training, &plans, settings))
        .collect::<Result<Vec<_>>>()?;
    let Local {
        parameters,
        distributions,
        derivative_names,
        not_estimated,
    } = local_estimates(structure, &plans, &deltas, settings, &mut notes);
    if !not_estimated.is_empty() {
        notes.push(format!(
            "not estimated (their regressors are not network inputs or are constant on the record, or, for a bias, another term of its coefficient is not estimated): {}",
            not_estimated.join(", ")
        ));
    }
    notes.push(format!(
        "values: the median of each parameter's local values over the record (Delta method, central differences of step {} in scaled units); bias terms C₀ = C(x) − Σ ∂C/∂xⱼ·xⱼ at each sample, summed over the structure's terms",
        settings.difference_step
    ));
    notes.push("standard errors: the standard deviation of the local values (the Delta method's spread), not a Cramér–Rao bound".into());
    let (status, diagnoses) = judge(
        &deltas,
        &distributions,
        &derivative_names,
        settings,
        &mut notes,
    );
    let fits = deltas
        .iter()
        .map(|d| OutputFit::new(d.data.name, &d.data.targets, &d.predictions))
        .collect();
    let covariance = crate::estimate::diagonal_covariance(
        &parameters
            .iter()
            .map(|p| p.standard_error)
            .collect::<Vec<_>>(),
    );
    let details = distribution_table(&distributions);
    Ok(Estimate {
        method: METHOD.to_string(),
        model: structure.name.clone(),
        record: record_name(record),
        diagnoses,
        status,
        parameters,
        covariance,
        fits,
        iterations: 1,
        cost_history: Vec::new(),
        wall_time: 0.0,
        notes,
        details,
        network: Some(network_report(&deltas, settings)),
        distributions,
        histories: Vec::new(),
    })
}

/// Where the width search ended, and the cost at the ends of its range.
fn search_note(name: &str, network: &RbfNetwork, settings: &RbfDeltaSettings) -> String {
    let history = &network.search_history;
    let best = history
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(f64::NAN, |h| h.1);
    let [low, high] = settings.width_factor_range;
    let at_edge = network.width_factor < low * 1.01 || network.width_factor > high * 0.99;
    format!(
        "{name} width search ({}): {} evaluations, best cost {best:.4e} at λ = {:.4}{}",
        match settings.width_search {
            WidthSearch::Training => "training cost",
            WidthSearch::HeldOut => "held-out cost",
        },
        history.len(),
        network.width_factor,
        if at_edge {
            " — at the end of the searched range"
        } else {
            ""
        }
    )
}

/// The status and the diagnoses (module header, step 6): a network whose
/// R² on its coefficient is below `minimum_r_squared` is a poor fit.
fn judge(
    deltas: &[Delta],
    distributions: &[ParameterDistribution],
    derivative_names: &[String],
    settings: &RbfDeltaSettings,
    notes: &mut Vec<String>,
) -> (Status, Vec<Diagnosis>) {
    let poor: Vec<&Delta> = deltas
        .iter()
        .filter(|d| d.r_squared.is_nan() || d.r_squared < settings.minimum_r_squared)
        .collect();
    let diagnoses: Vec<Diagnosis> = if poor.is_empty() {
        Vec::new()
    } else {
        vec![Diagnosis {
            kind: DiagnosisKind::PoorFit,
            about: poor.iter().map(|d| d.data.name.to_string()).collect(),
            measures: poor.iter().map(|d| d.r_squared).collect(),
            advice: format!(
                "the networks reproduce their coefficient with R² below {}: their derivatives are not to be trusted",
                settings.minimum_r_squared
            ),
        }]
    };
    let undetermined: Vec<String> = distributions
        .iter()
        .filter(|d| derivative_names.contains(&d.name) && d.p05 < 0.0 && d.p95 > 0.0)
        .map(|d| d.name.clone())
        .collect();
    if !undetermined.is_empty() {
        notes.push(format!(
            "not converged: the sign of {} is undetermined (the 5–95 % interval of the local values contains zero)",
            undetermined.join(", ")
        ));
        return (Status::Unidentified(undetermined), diagnoses);
    }
    (Status::Converged, diagnoses)
}

/// The networks' report: kind, inputs (all networks'), outputs, centres in
/// total, MSE and R² over every network (Eqs. 21–22), settings per network.
fn network_report(deltas: &[Delta], settings: &RbfDeltaSettings) -> NetworkReport {
    let mut inputs: Vec<String> = Vec::new();
    let mut extra = vec![("radius".to_string(), settings.radius)];
    let (mut square, mut count, mut r_squared) = (0.0, 0usize, 0.0);
    for delta in deltas {
        for r in &delta.data.inputs {
            if !inputs.iter().any(|i| i == r.key()) {
                inputs.push(r.key().to_string());
            }
        }
        let name = delta.data.name;
        extra.push((
            format!("{name} centres"),
            delta.network.centre_count() as f64,
        ));
        extra.push((format!("{name} width factor"), delta.network.width_factor));
        extra.push((format!("{name} R²"), delta.r_squared));
        square += delta.mse * delta.data.rows.len() as f64;
        count += delta.data.rows.len();
        r_squared += delta.r_squared;
    }
    NetworkReport {
        kind: "rbf".into(),
        inputs,
        outputs: deltas.iter().map(|d| d.data.name.to_string()).collect(),
        hidden: deltas.iter().map(|d| d.network.centre_count()).sum(),
        seed: 0,
        training_samples: deltas.iter().map(|d| d.data.rows.len()).max().unwrap_or(0),
        mse: square / count.max(1) as f64,
        r_squared: r_squared / deltas.len().max(1) as f64,
        settings: extra,
    }
}

/// The distributions as a text table.
fn distribution_table(distributions: &[ParameterDistribution]) -> String {
    let mut text = format!(
        "{:<10} {:>8} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}\n",
        "parameter", "samples", "mean", "std", "p05", "median", "p95", "at trim"
    );
    for d in distributions {
        text += &format!(
            "{:<10} {:>8} {:>12.5e} {:>12.5e} {:>12.5e} {:>12.5e} {:>12.5e} {:>12.5e}\n",
            d.name, d.samples, d.mean, d.standard_deviation, d.p05, d.median, d.p95, d.at_trim
        );
    }
    text
}
