//! Filter error, maximum likelihood with a Kalman filter in the loop
//! (Maine & Iliff, "Identification of dynamic systems", NASA RP-1138,
//! 1985, ch. 9; Jategaonkar, "Flight Vehicle System Identification",
//! 2nd ed., ch. 5; the seed paper 002 uses it as its comparison method).
//! The equation numbers are Jategaonkar's as his FVSysID programs
//! (`gainmat`, `fcompn`) cite them; elsewhere the sections are named.
//! Output error assumes that the only noise is on the measurements; with
//! turbulence (process noise) its simulation drifts away from the flight
//! and its estimates are biased. The filter error method predicts each
//! sample from the filtered state of the one before, so the innovations
//! stay white and the likelihood is the right one for both noises.
//!
//! System (Jategaonkar §5.1): ẋ = f(x, u, θ) + F·w,
//! z_k = h(x_k, u_k, θ) + G·v_k, w and v white with unit intensity, F
//! diagonal with one entry per state driven by noise (the
//! `process_noise` states), estimated with the aerodynamic parameters.
//!
//! Filter (`gain = "steady"`, the default; the steady-state extended
//! filter, Jategaonkar §5.5):
//! - prediction by the nonlinear model's own integration step
//!   ([`StateSpaceModel::step`]): x̃_k = step(x̂_{k−1}), ỹ_k = h(x̃_k);
//! - correction x̂_k = x̃_k + K·(z_k − ỹ_k) with a constant gain K;
//! - K = P·Cᵀ·R⁻¹ (Eq. 5.48), R the covariance of the innovations
//!   ν = z − ỹ (so the measurement noise is G·Gᵀ = R − C·P·Cᵀ, §5.3),
//!   P the steady-state predicted covariance of the system linearised, as
//!   FVSysID's `gainmat` does, at the first grid point (t₀, x₀, u(t₀)) of
//!   the record (A = ∂f/∂x, C = ∂h/∂x there, Eqs. 5.50–5.51).
//!   P solves the discrete Riccati equation
//!   P = Φ·(P − P·Cᵀ·R⁻¹·C·P)·Φᵀ + Q_d, Φ = e^{A·Δt}, Q_d the process noise
//!   F·Fᵀ discretised (Van Loan) over Δt, the interval between an output's
//!   corrections (the fastest output's sample period: several grid steps
//!   where the grid is divided into sub-steps), solved exactly
//!   ([`kalman::steady_state_for_innovation`]: Newton's method started
//!   from [`kalman::steady_state`]). Jategaonkar (§5.3, and
//!   `gainmat` by Potter's method, Eqs. 5.15–5.17) solves the continuous equation
//!   A·P + P·Aᵀ − P·Cᵀ·R⁻¹·C·P/Δt + F·Fᵀ = 0 instead, its first-order
//!   approximation in Δt; the exact discrete form makes the filter, on a
//!   linear model, the linear Kalman filter of that system exactly, which
//!   `tests/estimators/filter_error.rs` checks against an independent filter.
//!   On a multi-rate record a grid point with only some outputs corrects
//!   with those outputs' columns of K.
//!
//! Cost and relaxation (Jategaonkar §5.3): the negative
//! log-likelihood of the innovations, ½·Σ_k (ν_kᵀR⁻¹ν_k + ln det R),
//! minimised by relaxation: at every iteration R is re-estimated from the
//! innovations at the current (θ, F), R = (1/N)·Σ ν·νᵀ (Jategaonkar
//! Eq. 5.37), then one Gauss–Newton step on ½·Σ νᵀR⁻¹ν with R fixed is
//! taken on θ and F together, by the shared core ([`gauss_newton`]), on
//! the innovations whitened by R ([`InnovationCovariance`]). With process
//! noise and the steady gain, R is by default the whole (1/N)·Σ ν·νᵀ where
//! every grid point with a measurement measures every output
//! (`innovation_covariance = "diagonal"`: one variance per output, as
//! output error's). The innovations of outputs that share a state's
//! prediction error are correlated (β and n_y through β, −0.85 on the
//! ATTAS lateral flight in turbulence), and a diagonal R weighs that error
//! twice: its bounds on the side-force derivatives are about twice their
//! scatter, the full R's honest (docs/findings.md, "The full innovation
//! covariance"). The full R is fitted in two stages
//! ([`FilterErrorFit::fit`]): with a diagonal R to convergence, then with
//! the full R from that estimate; where either stage does not converge
//! the diagonal R's estimate is the result, with a note. On a multi-rate
//! record, each output correcting at its own instants, and without
//! process noise (output error), R stays diagonal. R's start, from the
//! simulation without the filter, is diagonal. After each R update F
//! is compensated by the heuristic of Jategaonkar Eq. 5.41 as FVSysID's
//! `fcompn` codes it, on R's diagonal: F_ii ← F_ii·Σ_j C_ji²·R_jj,old⁻¹·√(R_jj,new/R_jj,old)
//! / Σ_j C_ji²·R_jj,old⁻¹, so that the gain, which depends on both, does
//! not jump with R ([`LeastSquaresProblem::compensate`]).
//! Constraint (Jategaonkar §5.3): the diagonal of K·C must stay ≤ 1 (a
//! channel's share of R left to measurement noise cannot be negative).
//! Where the Gauss–Newton step would cross it (diag(K·C) at the full step
//! above 1), the step is the quadratic program Jategaonkar describes
//! (FVSysID's `kcle1`): min gᵀΔ + ½·ΔᵀMΔ (g = Jᵀr, M = JᵀJ) subject to
//! diag(K·C)(u) + A·Δ ≤ 1 − 10⁻⁶ on every state with a gain, A the
//! constraint linearised in the unknowns (central differences of the
//! steady-state gain, a Riccati solution each), solved by the active-set
//! method (`active_set_step`: the violated constraints held as
//! equalities through the KKT system, one with a negative multiplier
//! released, the most violated one added). diag(K·C) curves up towards
//! 1, so the step to the linearised boundary crosses the true one: up to
//! four second-order corrections (Nocedal & Wright, "Numerical
//! Optimization", §18.3) move the bound of each constraint the step holds
//! by its overshoot at the step's end (halve it where no filter exists
//! there) and solve again. The solver halves the step as any other and
//! judges convergence by its predicted decrease. Measured in
//! `tests/estimators/filter_error.rs`
//! (`filter_error_converges_with_the_gain_constraint_active`, a channel
//! recorded without noise): where the constraint binds, the fits stop
//! where the KKT conditions hold (multiplier positive, the step along the
//! constraint predicting below 3·10⁻⁷), diag(K·C) on that channel at
//! 0.9956–0.9963 after the last R update and F's compensation with K·C's
//! largest eigenvalue within 3·10⁻⁷ of 1 (on the edge of the filters that
//! exist: the diagonal of a non-symmetric K·C stays below it), and agree
//! with the time-varying form, which has no constraint, within 0.12σ.
//! The estimate's notes say when the last step was the constrained one.
//! A step that the program cannot give, or for which no steady-state filter with the current R exists
//! (R − C·P·Cᵀ not positive definite), cannot be evaluated, and the
//! solver cuts it (halvings, then Levenberg–Marquardt damping) until it
//! is feasible. A compensated F that violates the constraint is halved
//! until it does not; when no F gives a filter with the new R (an unstable
//! mode needs more gain than R's measurement-noise share allows), the R
//! update is undone for that iteration.
//!
//! Time-varying form (`gain = "time_varying"`): the filter in the loop is
//! the continuous–discrete extended Kalman filter of
//! [`extended_kalman::filter`] (Jategaonkar §7.2, Eqs. 7.11–7.19, the
//! filter the `ekf` method runs; the FVSysID programs of ch. 5 build only
//! the steady-state gain, and the book's equation numbers of the
//! time-varying form could not be checked here), with θ fixed:
//! x̃_k = step(x̂_{k−1}); P̃_k = Φ_k·P̂_{k−1}·Φ_kᵀ + Q_d with Φ_k, Q_d of the
//! model linearised at (t_{k−1}, x̂_{k−1}); S_k = C_k·P̃_k·C_kᵀ + G·Gᵀ,
//! K_k = P̃_k·C_kᵀ·S_k⁻¹ with C_k at (t_k, x̃_k); x̂_k = x̃_k + K_k·ν_k,
//! P̂_k in Joseph's form; P̂_0 = P0, the `initial_variance` setting
//! (default 0: the initial state known). The cost is the exact negative
//! log-likelihood ½·Σ_k (ν_kᵀS_k⁻¹ν_k + ln det S_k) (Jategaonkar Eq. 5.16).
//! S_k varies and depends on every unknown, so no innovation covariance
//! can be relaxed in closed form: the measurement noise G·Gᵀ (diagonal, G
//! one entry per output, §5.1's G) is the parameter, estimated with θ and
//! F by Fisher scoring. Each iteration's normal equations are
//! M = Σ_k (∂νᵀS⁻¹∂ν + ½·tr(S⁻¹∂S·S⁻¹∂S)) and the likelihood's gradient,
//! written as JᵀJ and Jᵀρ with rows L⁻¹·∂ν and vec(L⁻¹·∂S·L⁻ᵀ)/√2
//! (S = L·Lᵀ) and ρ = (L⁻¹ν, vec(I − L⁻¹ννᵀL⁻ᵀ)/√2), the derivatives by
//! forward differences of whole passes; the shared core sees the cost as
//! the squares of L⁻¹ν and √(ln det S_k − ln det D_k), D the floors of
//! G·Gᵀ (a hundredth of its value at the iteration's start, G² held above
//! them; S_k ≥ G·Gᵀ ≥ D, so ½·Σr² is −ln L less a constant). Each
//! re-weighting also proposes the relaxation of G·Gᵀ, one Fisher-scoring
//! step of the likelihood in G·Gᵀ with P̃ held, taken where it lowers the
//! cost (on noise-free data it reaches the vanishing noise in a few
//! iterations where the step linear in G halves it at each). G·Gᵀ is not
//! left to relaxation alone (with the compensation of F): on the 6-DOF
//! turbulence records that runs p's measurement noise to its floor while F
//! on p grows, the two trading along the likelihood's valley, up to the
//! iteration limit; estimated jointly, the step follows the valley. With G·Gᵀ
//! positive definite, S_k is, and the filter exists at every point: there
//! is no constraint on K·C and no compensation of F. The start (R, F's
//! factor) is the steady form's, with G·Gᵀ in R's place and the pass's
//! −ln L in place of ½·Σ N_o·ln R_oo; the Cramér–Rao bounds come from M,
//! G's entries among the unknowns (their values and bounds in the notes).
//! Measured: noise-free ATTAS lateral within 3.1e-6 (steady 3.1e-6); on a
//! linear model its likelihood and innovations are adskalman's to 1e-9
//! (`tests/estimators/filter_error.rs`); with the gust filter's states started
//! unknown (`tests/estimators/linear_models.rs`) the RMS error/σ of the α column of
//! A is 1.29 against the steady form's 1.78; each fit costs about 25
//! times the steady form's (a covariance propagated at every point in
//! every pass, and a pass per unknown for the Jacobian: the steady
//! form's sensitivity equations would here need those of the covariance
//! recursion, the model's second derivatives).
//!
//! Exact fits (time-varying gain): on measurements without noise the
//! likelihood (Eq. 5.16) wants G·Gᵀ at zero, and where the states tie
//! outputs exactly (β and n_y through CY) S_k has an eigenvalue of order
//! G², whose ln det falls without end. Each G² is held at a rounding
//! floor, `NOISE_ROUNDING` of its output's variance about its mean
//! (`FilterErrorFit::floors`): where it reaches the floor with the
//! likelihood's gradient asking for less, its row and column of the
//! normal equations are zero, so the step and the convergence test are
//! the other unknowns' (`FilterErrorFit::held_at_rounding`), its bound
//! infinite, and a note names the outputs fitted to rounding. Measured on
//! the ATTAS lateral flight in turbulence recorded without measurement
//! noise: converged in 19 iterations, the CY derivatives within
//! 3·10⁻⁶–4.4·10⁻⁴ relative and 1.5σ, every derivative within 2.03σ
//! (`tests/estimators/filter_error.rs`); with the steady gain's floor (10⁻²⁴ of the
//! mean square) the fit ended `diverged`, S_k not positive definite.
//!
//! Sensitivities (steady gain): the filter's own sensitivity equations,
//! carried through one pass for every unknown u (θ's free entries and F;
//! Jategaonkar §5.5's gradient of the innovations, with the model's exact
//! step derivative):
//! - prediction: S̃_k = ∂x̃_k/∂u through the integration step,
//!   S̃_k = Φ_k·Ŝ_{k−1} + ∂step/∂u, the step's exact derivative
//!   ([`StateSpaceModel::step_sensitivity`]: for the 6-DOF view, the RK4
//!   step of Ṡ = (∂f/∂x)·S + ∂f/∂θ with the model linearised at its four
//!   stages, output error's exact Jacobian, Jategaonkar §4.6); an F entry
//!   does not enter f;
//! - outputs: ∂ỹ_k/∂u = C_k·S̃_k + ∂h/∂θ at (t_k, x̃_k), and
//!   ∂ν_k/∂u = −∂ỹ_k/∂u;
//! - correction: Ŝ_k = S̃_k + K·∂ν_k/∂u + (∂K/∂u)·ν_k, over the outputs
//!   measured at the point; S is zero before the first correction (the
//!   initial state is not an unknown);
//! - ∂K/∂u_j: central differences of the steady-state gain (the model
//!   relinearised at the first point for a parameter, the Riccati equation
//!   solved again; one-sided where the filter does not exist on one side),
//!   step 10⁻⁶·max(|u_j|, typical_j), the shared core's (typical 10⁻³ for
//!   an aerodynamic parameter, a tenth of the start value for an F entry),
//!   as FVSysID perturbs the gain with the parameters.
//!
//! The Jacobian is then the derivative of the discrete filter up to ∂K's
//! O(h²) difference: on the ATTAS lateral record in turbulence within
//! 3·10⁻⁷ of each column's norm of central differences of whole passes,
//! closer than forward differences of whole passes (within 9·10⁻⁷;
//! `sensitivity_jacobian_is_the_filters_derivative` in
//! `tests/estimators/filter_error.rs`). A model that does not propagate sensitivities
//! (the linear structures' exact discretisation, a test's own model) gets
//! forward differences of whole filter passes instead, one pass per
//! unknown, each perturbed u with its own linearisation, Riccati solution
//! and gain (backward where the forward pass is infeasible: an iterate on
//! the constraint; [`FilterErrorFit::difference_jacobian`]).
//! Cramér–Rao bounds are the square roots of
//! the diagonal of M⁻¹, M = Σ (∂ν/∂θ)ᵀ R⁻¹ (∂ν/∂θ) at the optimum, the F
//! entries among the unknowns; only the aerodynamic parameters (with the
//! aerodynamic block of M⁻¹) are the estimate's parameters, scored against
//! the truth; F with its bounds is in the notes and details.
//! Convergence: the Gauss–Newton step's predicted decrease of the whitened
//! cost below 10⁻⁴ (a step under 0.014σ), as output error.
//!
//! Start: the aerodynamic parameters from equation error's estimate (as
//! output error; the seed paper 002 starts its filter error method near
//! the equation-error estimates, finding it sensitive to its start), else the model file's values. The initial
//! state is the record's first sample (the filter corrects it, so it is not
//! an unknown). R starts from the innovations with no process noise (the
//! output-error residuals; where that simulation departs, an unstable
//! mode, from the measurements' variances), F from a scale where the process noise over one
//! sample period Δt equals the output residual level seen through C,
//! F_ref,i = (Σ_j C_ji²/R_jj)^{−½}/√Δt, times the factor among 1, 0.3,
//! 0.1, 0.03, 0.01 with the lowest cost ½·Σ N_o·ln R_oo after two R
//! updates.

use crate::estimate::{Estimate, OutputFit};
use crate::estimator::{
    Estimator, MethodInfo, MissingChannel, Refusal, Settings, merge_settings, parse_settings,
    setting_infos,
};
use crate::linear_structure::LinearStructure;
use crate::methods::equation_error;
use crate::methods::output_error::{self, Start};
use crate::model::input_timing::{self, InputInterpolation};
use crate::model::observations::Observations;
use crate::model::state_space::{DrivenStateSpace, Jacobians, StateSpaceModel};
use crate::problem::EstimationProblem;
use crate::solver::extended_kalman::{self, Discretisation, Keep, Noise};
use crate::structure::{ModelStructure, Structure};
use aeroid_core::error::{Error, Result};
use aeroid_numerics::gauss_newton::{self, LeastSquaresProblem, Options};
use aeroid_numerics::kalman::{self, Gaussian, SteadyState};
use aeroid_record::FlightRecord;
use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::BTreeMap;

/// Method name in estimates.
pub const METHOD: &str = "fem";

/// Convergence: the Gauss–Newton step's predicted decrease of the whitened
/// cost, ½·ΔθᵀMΔθ ≤ 1e-4, a step under 0.014σ (as output error).
const CONVERGED_DECREASE: f64 = 1e-4;

/// The rounding floor of each entry of G·Gᵀ with the time-varying gain,
/// as a fraction of its output's variance about its mean: G at 10⁻⁴ of
/// the output's spread (module documentation, "Exact fits"). Where the
/// states tie outputs exactly (β and n_y through CY), the innovation
/// covariance S_k = C·P̃·Cᵀ + G·Gᵀ has an eigenvalue of order G²; the
/// scoring's ∂S/∂u, forward differences of whole passes at a relative step
/// of 10⁻⁶, carries a rounding error of about 10⁻¹⁰·|S|, which must stay
/// small beside it. Measured on the noise-free ATTAS lateral record in
/// turbulence: at 10⁻¹² and 10⁻¹⁰ the predicted decrease stalls at
/// 1.9·10³ and 1.4·10³ while the cost stays (iteration limit); at 10⁻⁸ the
/// fit converges in 19 iterations. With the floor at 10⁻²⁴ of the mean
/// square, as the steady gain's, S_k lost positive definiteness
/// (`diverged`).
const NOISE_ROUNDING: f64 = 1e-8;

/// The factors of F_ref tried for the start of F (module documentation).
const START_FACTORS: [f64; 5] = [1.0, 0.3, 0.1, 0.03, 0.01];

/// States that are not driven by process noise by default: attitude,
/// heading and altitude are kinematic integrals, χ is internal.
const NOISELESS_STATES: [&str; 5] = ["roll", "pitch", "yaw", "altitude", "chi"];

/// Settings of a filter-error run: the `[methods.fem]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilterErrorOptions {
    pub start: Start,
    pub max_iterations: usize,
    /// Integration step (s); None: the fastest compared channel's period.
    #[serde(
        deserialize_with = "aeroid_core::units::optional_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub step: Option<f64>,
    /// How each input is interpolated inside an integration step
    /// ([`InputInterpolation`]; default: chosen per input from its samples).
    pub interpolation: InputInterpolation,
    /// The integrated states driven by process noise (one F entry each);
    /// None: every integrated state but roll, pitch, yaw, altitude and χ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub process_noise: Option<Vec<String>>,
    /// The filter in the loop: the steady-state gain of the system
    /// linearised at the first point, or the time-varying extended filter.
    pub gain: Gain,
    /// With the time-varying gain: the variance of the initial state's
    /// error, per integrated state (P0 diagonal; a state not named starts
    /// known, variance 0).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub initial_variance: BTreeMap<String, f64>,
    /// The steady gain's innovation covariance R: diagonal, or full where
    /// every output shares one time base ([`InnovationCovariance`]); not
    /// set: full with the steady gain ([`FilterErrorOptions::innovation_form`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub innovation_covariance: Option<InnovationForm>,
    /// Fit only this time window (s) of the record; default the whole record.
    #[serde(skip)]
    pub window: Option<(f64, f64)>,
}

/// The steady gain's innovation covariance R (`innovation_covariance`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InnovationForm {
    /// One variance per output.
    Diagonal,
    /// R = (1/N)·Σ ν·νᵀ whole, where every grid point with a measurement
    /// measures every output (else diagonal, with a note).
    Full,
}

/// The filter in the filter error method's loop (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Gain {
    /// The steady-state gain of the model linearised at the first grid
    /// point, the innovation covariance R estimated by relaxation.
    #[default]
    Steady,
    /// The extended Kalman filter, its covariance propagated with the model
    /// linearised at each point, the measurement noise G·Gᵀ estimated by
    /// relaxation.
    TimeVarying,
}

impl Default for FilterErrorOptions {
    fn default() -> Self {
        FilterErrorOptions {
            start: Start::default(),
            max_iterations: 30,
            step: None,
            interpolation: InputInterpolation::default(),
            process_noise: None,
            gain: Gain::default(),
            initial_variance: BTreeMap::new(),
            innovation_covariance: None,
            window: None,
        }
    }
}

impl FilterErrorOptions {
    /// Reads and checks a `[methods.fem]` table.
    pub fn read(settings: &Settings) -> Result<FilterErrorOptions> {
        let options: FilterErrorOptions = parse_settings(METHOD, settings)?;
        if options
            .step
            .is_some_and(|step| !(step > 0.0 && step.is_finite()))
        {
            return Err(Error::Other(format!(
                "[methods.{METHOD}]: step must be positive"
            )));
        }
        if options.max_iterations == 0 {
            return Err(Error::Other(format!(
                "[methods.{METHOD}]: max_iterations must be at least 1"
            )));
        }
        check_initial_variance(METHOD, options.gain, &options.initial_variance)?;
        options.interpolation.check_controls(METHOD)?;
        if options.gain == Gain::TimeVarying
            && options.innovation_covariance == Some(InnovationForm::Full)
        {
            return Err(Error::Other(format!(
                "[methods.{METHOD}] innovation_covariance = \"full\" needs gain = \"steady\": the time-varying filter's innovation covariance C·P̃·Cᵀ + G·Gᵀ is full already"
            )));
        }
        Ok(options)
    }

    /// The form of R: as set, else full with the steady gain (the
    /// time-varying gain's innovation covariance is full already).
    pub fn innovation_form(&self) -> InnovationForm {
        self.innovation_covariance.unwrap_or(match self.gain {
            Gain::Steady => InnovationForm::Full,
            Gain::TimeVarying => InnovationForm::Diagonal,
        })
    }

    /// The options a model file's `[methods.fem]` table sets.
    pub fn for_structure(structure: &ModelStructure) -> Result<FilterErrorOptions> {
        FilterErrorOptions::read(&merge_settings(METHOD, &[&structure.methods]))
    }
}

/// Checks an `initial_variance` table: finite variances not below zero,
/// and only with the time-varying gain (the steady-state filter has no
/// initial covariance).
fn check_initial_variance(
    method: &str,
    gain: Gain,
    initial_variance: &BTreeMap<String, f64>,
) -> Result<()> {
    if gain == Gain::Steady && !initial_variance.is_empty() {
        return Err(Error::Other(format!(
            "[methods.{method}] initial_variance needs gain = \"time_varying\": the steady-state filter has no initial covariance"
        )));
    }
    match initial_variance
        .iter()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
    {
        Some((name, v)) => Err(Error::Other(format!(
            "[methods.{method}] initial_variance.{name} = {v}: a variance must be finite and not below zero"
        ))),
        None => Ok(()),
    }
}

/// P0 = diag of `initial_variance` over the states `names`; an error
/// naming a key that is not a state.
fn initial_covariance(
    method: &str,
    names: &[&str],
    initial_variance: &BTreeMap<String, f64>,
) -> Result<DMatrix<f64>> {
    let mut covariance = DMatrix::zeros(names.len(), names.len());
    for (name, &variance) in initial_variance {
        let i = names.iter().position(|n| n == name).ok_or_else(|| {
            Error::Other(format!(
                "[methods.{method}] initial_variance: '{name}' is not an integrated state of the model ({})",
                names.join(", ")
            ))
        })?;
        covariance[(i, i)] = variance;
    }
    Ok(covariance)
}

/// Filter error as a registered method.
pub struct FilterError;

impl Estimator for FilterError {
    fn name(&self) -> &'static str {
        METHOD
    }

    fn info(&self) -> MethodInfo {
        MethodInfo {
            title: "filter error: maximum likelihood with a steady-state extended Kalman filter in the loop, for flights with turbulence",
            paper: "Maine & Iliff, \"Identification of dynamic systems\" (NASA RP-1138, 1985); Jategaonkar, \"Flight Vehicle System Identification\", 2nd ed., ch. 5",
            equations: "innovations ν = z − ỹ of x̃_k = step(x̂_{k−1}), x̂ = x̃ + K·ν, K = P·Cᵀ·R⁻¹ (Jategaonkar §5.5, Eq. 5.48), P from the discrete Riccati equation of the model linearised at the first point; cost ½·Σ(νᵀR⁻¹ν + ln det R), R = (1/N)·Σ ν·νᵀ (whole where the outputs share one time base, fitted from the diagonal R's estimate; diagonal with innovation_covariance = \"diagonal\" or on a multi-rate record), Gauss–Newton on θ and F with R fixed, F compensated after each R update (Eq. 5.41), diag(K·C) ≤ 1 (§5.3); Cramér–Rao bounds from M = Σ (∂ν/∂θ)ᵀR⁻¹(∂ν/∂θ). gain = \"time_varying\": the EKF in the loop (Jategaonkar §7.2, Eqs. 7.11–7.19), P̃_k = Φ_k·P̂_{k−1}·Φ_kᵀ + Q_d, K_k = P̃_k·C_kᵀ·(C_k·P̃_k·C_kᵀ + G·Gᵀ)⁻¹, cost ½·Σ(νᵀS_k⁻¹ν + ln det S_k), θ, F and G by Fisher scoring",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls)",
            settings: setting_infos(
                &FilterErrorOptions::default(),
                &[
                    (
                        "start",
                        "\"ee\": equation error's estimates where they converge; \"model\": the model file's values",
                    ),
                    ("max_iterations", "Gauss–Newton iterations at most"),
                    (
                        "step",
                        "integration step, e.g. \"0.04 s\"; none: the fastest compared channel's period",
                    ),
                    (
                        "interpolation",
                        "inputs inside an integration step: \"auto\" (each input held where its samples are piecewise constant, linear where it ramps or moves; said in the notes), \"zoh\" (hold), \"linear\", or a table by channel, e.g. { aileron = \"linear\" }",
                    ),
                    (
                        "process_noise",
                        "the integrated states driven by process noise, one F entry each; none: all but roll, pitch, yaw, altitude and chi",
                    ),
                    (
                        "gain",
                        "\"steady\": the steady-state gain of the model linearised at the first point, R by relaxation; \"time_varying\": the extended Kalman filter, covariance propagated at every point, G·Gᵀ by relaxation",
                    ),
                    (
                        "initial_variance",
                        "with gain = \"time_varying\": the initial state's error variance per state, e.g. { z1 = 5.8 }; states not named start known",
                    ),
                    (
                        "innovation_covariance",
                        "with gain = \"steady\": \"full\" (the default; R = (1/N)·Σ ν·νᵀ whole where every output shares one time base, fitted from the diagonal R's estimate: honest bounds where outputs share a state's prediction error, e.g. β and n_y) or \"diagonal\" (one variance per output)",
                    ),
                ],
            ),
        }
    }

    fn check_settings(&self, settings: &Settings) -> Result<()> {
        FilterErrorOptions::read(settings).map(|_| ())
    }

    fn starts_from(&self) -> Option<&'static str> {
        Some(equation_error::METHOD)
    }

    fn fits_tied_parameters(&self) -> bool {
        true
    }

    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate> {
        let options = FilterErrorOptions::read(&problem.settings)?;
        crate::estimator::one_record(METHOD, problem)?;
        match &problem.structure {
            Structure::SixDof(structure) => {
                filter_error_from(problem.record(), structure, &options, start)
            }
            Structure::Linear(structure) => {
                crate::estimator::refuse_for_linear(
                    METHOD,
                    &problem.settings,
                    &structure.name,
                    &[
                        (
                            "start",
                            "a linear model's fit starts from its file's values: only \"model\"",
                        ),
                        (
                            "interpolation",
                            "a linear model states its inputs' interpolation in its file",
                        ),
                    ],
                )?;
                linear_fit(
                    METHOD,
                    problem.record(),
                    structure,
                    &LinearFitOptions {
                        max_iterations: options.max_iterations,
                        step: options.step,
                        window: options.window,
                        gain: options.gain,
                        initial_variance: options.initial_variance.clone(),
                        innovation_covariance: options.innovation_form(),
                        process_noise: Some(
                            options
                                .process_noise
                                .clone()
                                .unwrap_or_else(|| structure.states.clone()),
                        ),
                    },
                )
            }
        }
    }
}

/// What one steady-state filter pass gives.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyPass {
    /// ν = z − ỹ at every measurement, in the observations' order (grid
    /// point after grid point, each point's outputs as listed there).
    pub innovations: Vec<f64>,
    /// ỹ at every measurement, in the same order.
    pub predicted: Vec<f64>,
    /// ½·Σ_k (ν_kᵀR⁻¹ν_k + ln det R) over the measurements (without 2π).
    pub negative_log_likelihood: f64,
    /// P, K and R of the filter.
    pub steady: SteadyState,
    /// G·Gᵀ = R − C·P·Cᵀ.
    pub measurement_noise: DMatrix<f64>,
    /// C = ∂h/∂x at the first grid point, where the gain was computed.
    pub output_matrix: DMatrix<f64>,
}

/// The steady-state filter's innovation covariance R (Jategaonkar
/// Eq. 5.37, R = (1/N)·Σ ν·νᵀ): a full matrix where every grid point with
/// a measurement measures every output (one time base; the innovations of
/// outputs that share a state's prediction error are correlated: β and
/// n_y through β), else its diagonal (outputs on different time bases,
/// each correcting alone).
#[derive(Debug, Clone, PartialEq)]
pub struct InnovationCovariance {
    matrix: DMatrix<f64>,
    /// L⁻¹ (R = L·Lᵀ) and ln det R of a full R; None for a diagonal one.
    whitening: Option<(DMatrix<f64>, f64)>,
}

impl InnovationCovariance {
    /// R = diag(`variances`).
    pub fn diagonal(variances: &DVector<f64>) -> InnovationCovariance {
        InnovationCovariance {
            matrix: DMatrix::from_diagonal(variances),
            whitening: None,
        }
    }

    /// A full R; an error when it is not positive definite.
    pub fn full(matrix: DMatrix<f64>) -> Result<InnovationCovariance> {
        let (root, log_det) = lower_root(matrix.as_view())?;
        let n = root.nrows();
        let inverse = root
            .solve_lower_triangular(&DMatrix::identity(n, n))
            .ok_or_else(|| Error::Other("a singular innovation covariance".into()))?;
        Ok(InnovationCovariance {
            matrix,
            whitening: Some((inverse, log_det)),
        })
    }

    /// R.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.matrix
    }

    /// R's diagonal, each output's innovation variance.
    pub fn variances(&self) -> DVector<f64> {
        self.matrix.diagonal()
    }

    /// Rows in the observations' order (one per measurement) whitened in
    /// place: each grid point's block by L⁻¹ where R is full and the point
    /// measures every output, else each row by 1/√R_oo. ½ of the squared
    /// sum of whitened innovations is ½·Σ νᵀR⁻¹ν.
    fn whiten(&self, observations: &Observations, rows: &mut DMatrix<f64>) {
        let outputs = self.matrix.nrows();
        let mut row = 0;
        for present in &observations.at {
            match &self.whitening {
                Some((inverse, _)) if present.len() == outputs => {
                    // The block in the outputs' order, whitened, put back.
                    let mut block = DMatrix::zeros(outputs, rows.ncols());
                    for (i, &(o, _)) in present.iter().enumerate() {
                        block.row_mut(o).copy_from(&rows.row(row + i));
                    }
                    let whitened = inverse * block;
                    for (i, &(o, _)) in present.iter().enumerate() {
                        rows.row_mut(row + i).copy_from(&whitened.row(o));
                    }
                }
                _ => {
                    for (i, &(o, _)) in present.iter().enumerate() {
                        let scale = 1.0 / self.matrix[(o, o)].sqrt();
                        rows.row_mut(row + i).scale_mut(scale);
                    }
                }
            }
            row += present.len();
        }
    }
}

/// One pass of the steady-state filter (module documentation) over
/// `observations` on the model's grid, from `initial` at grid point 0,
/// with parameters `theta`, process-noise distribution F = diag(`distribution`)
/// (one entry per state, zero for a state without noise) and innovation
/// covariance R ([`InnovationCovariance`]). With no process noise
/// the gain is zero and the pass is the model's simulation. An error when
/// the model cannot be evaluated, no steady-state filter has this R, or
/// the constraint diag(K·C) ≤ 1 is violated.
pub fn steady_state_pass<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &DVector<f64>,
    distribution: &DVector<f64>,
    innovation: &InnovationCovariance,
    observations: &Observations,
) -> Result<SteadyPass> {
    let (n, outputs) = (model.state_count(), model.output_count());
    let variances = innovation.variances();
    if initial.len() != n
        || distribution.len() != n
        || variances.len() != outputs
        || observations.at.len() != model.len()
        || model.len() < 2
    {
        return Err(Error::Other(format!(
            "the filter's sizes do not agree: {n} states, {outputs} outputs on {} grid points; initial state of {}, {} F entries, {} variances, observations on {} points",
            model.len(),
            initial.len(),
            distribution.len(),
            variances.len(),
            observations.at.len()
        )));
    }
    if !variances.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return Err(Error::Other(
            "the innovation variances must be positive and finite".into(),
        ));
    }
    let start = model.time(0);
    let jacobians = model.jacobians(start, initial.as_slice(), theta)?;
    let (steady, measurement_noise) = steady_gain(
        &jacobians,
        distribution,
        innovation,
        (model.time(1) - start) * observations.stride() as f64,
    )?;
    let c = jacobians.outputs_by_state;
    let kc = &steady.gain * &c;
    if let Some(i) = (0..n).find(|&i| kc[(i, i)] > 1.0) {
        return Err(Error::Other(format!(
            "the gain violates diag(K·C) ≤ 1 (Jategaonkar §5.3): entry {i} is {:.4}",
            kc[(i, i)]
        )));
    }
    let count: usize = observations.at.iter().map(Vec::len).sum();
    let mut pass = SteadyPass {
        innovations: Vec::with_capacity(count),
        predicted: Vec::with_capacity(count),
        negative_log_likelihood: 0.0,
        steady,
        measurement_noise,
        output_matrix: c,
    };
    filter_steadily(
        model,
        theta,
        initial,
        innovation,
        observations,
        &mut pass,
        None,
    )?;
    Ok(pass)
}

/// The steady-state filter of the model linearised as `jacobians` (at the
/// first grid point): K, P and R (Jategaonkar Eq. 5.48) with process noise
/// F·Fᵀ, F = diag(`distribution`), discretised over `interval` (the
/// interval between an output's corrections), and G·Gᵀ = R − C·P·Cᵀ. With
/// no process noise the gain is zero.
fn steady_gain(
    jacobians: &crate::model::state_space::Jacobians,
    distribution: &DVector<f64>,
    innovation: &InnovationCovariance,
    interval: f64,
) -> Result<(SteadyState, DMatrix<f64>)> {
    let a = &jacobians.rates_by_state;
    let c = &jacobians.outputs_by_state;
    let (n, outputs) = (a.nrows(), c.nrows());
    let r = innovation.matrix().clone();
    if distribution.iter().all(|f| *f == 0.0) {
        let steady = SteadyState {
            covariance: DMatrix::zeros(n, n),
            gain: DMatrix::zeros(n, outputs),
            innovation_covariance: r.clone(),
        };
        return Ok((steady, r));
    }
    let spectral = DMatrix::from_diagonal(&distribution.map(|f| f * f));
    let discrete = kalman::discretise(a, &DMatrix::zeros(n, 0), Some(&spectral), interval);
    kalman::steady_state_for_innovation(&discrete.transition, c, &discrete.process_noise, &r)
}

/// The sensitivities a steady-state pass carries (Jategaonkar §5.5 style:
/// the filter's own sensitivity equations): the unknowns' `columns` (the
/// parameter each is, None for an F entry), ∂K/∂u_j for each, and the
/// rows ∂ν/∂u written, one per measurement.
struct Tangent<'a> {
    columns: &'a [Option<usize>],
    gains: &'a [DMatrix<f64>],
    rows: DMatrix<f64>,
}

/// The steady-state filter's pass over `observations` with `pass`'s gain,
/// writing its innovations, predictions and likelihood into `pass`; with a
/// `tangent`, the sensitivities S = ∂x/∂u through it (module
/// documentation): returns false when the model does not propagate them
/// ([`StateSpaceModel::step_sensitivity`]).
fn filter_steadily<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &DVector<f64>,
    innovation: &InnovationCovariance,
    observations: &Observations,
    pass: &mut SteadyPass,
    mut tangent: Option<&mut Tangent<'_>>,
) -> Result<bool> {
    let (n, outputs) = (model.state_count(), model.output_count());
    let m = tangent.as_ref().map_or(0, |t| t.columns.len());
    let variances = innovation.variances();
    let log_variances = variances.map(f64::ln);
    let mut innovations = DVector::zeros(outputs);
    let mut sensitivity = DMatrix::<f64>::zeros(n, m);
    let mut output_sensitivity = DMatrix::<f64>::zeros(outputs, m);
    let mut correction = DMatrix::<f64>::zeros(n, m);
    let mut linear = crate::model::state_space::Jacobians::empty();
    let mut predicted = DVector::zeros(outputs);
    let mut whitened = DVector::zeros(outputs);
    let mut row = 0;
    let mut state = initial.clone();
    let mut next = DVector::zeros(n);
    for (k, present) in observations.at.iter().enumerate() {
        if k > 0 {
            match tangent {
                Some(ref tangent) => {
                    let stepped = model
                        .step_sensitivity(
                            k - 1,
                            state.as_slice(),
                            theta,
                            tangent.columns,
                            &mut sensitivity,
                        )
                        .map_err(|e| at_time(e, model.time(k - 1)))?;
                    let Some(stepped) = stepped else {
                        return Ok(false);
                    };
                    state = stepped;
                }
                None => {
                    model
                        .step_into(k - 1, state.as_slice(), theta, &mut next)
                        .map_err(|e| at_time(e, model.time(k - 1)))?;
                    std::mem::swap(&mut state, &mut next);
                }
            }
        }
        if present.is_empty() {
            continue;
        }
        let t = model.time(k);
        match tangent {
            Some(ref tangent) => {
                model.jacobians_into(
                    t,
                    state.as_slice(),
                    theta,
                    &mut linear,
                    Some(&mut predicted),
                )?;
                // ∂ỹ/∂u = C·S̃ + ∂h/∂θ
                output_sensitivity.gemm(1.0, &linear.outputs_by_state, &sensitivity, 0.0);
                for (j, column) in tangent.columns.iter().enumerate() {
                    if let Some(p) = *column {
                        output_sensitivity.column_mut(j).axpy(
                            1.0,
                            &linear.outputs_by_parameter.column(p),
                            1.0,
                        );
                    }
                }
                correction.fill(0.0);
            }
            None => model.outputs_into(t, state.as_slice(), theta, &mut predicted)?,
        }
        // ½·(νᵀR⁻¹ν + ln det R) over the outputs measured here: with R
        // full at a point that measures them all, else output by output.
        let joint = match &innovation.whitening {
            Some((inverse, log_det)) if present.len() == outputs => Some((inverse, *log_det)),
            _ => None,
        };
        for &(o, z) in present {
            let innovation = z - predicted[o];
            innovations[o] = innovation;
            pass.innovations.push(innovation);
            pass.predicted.push(predicted[o]);
            if joint.is_none() {
                pass.negative_log_likelihood +=
                    0.5 * (innovation * innovation / variances[o] + log_variances[o]);
            }
            state.axpy(innovation, &pass.steady.gain.column(o), 1.0);
            if let Some(ref mut tangent) = tangent {
                // ∂ν/∂u = −∂ỹ/∂u; Ŝ = S̃ + K·∂ν + ∂K·ν
                let gain = pass.steady.gain.column(o);
                for j in 0..m {
                    let d_innovation = -output_sensitivity[(o, j)];
                    tangent.rows[(row, j)] = d_innovation;
                    correction.column_mut(j).axpy(d_innovation, &gain, 1.0);
                    correction
                        .column_mut(j)
                        .axpy(innovation, &tangent.gains[j].column(o), 1.0);
                }
            }
            row += 1;
        }
        if let Some((inverse, log_det)) = joint {
            inverse.mul_to(&innovations, &mut whitened);
            pass.negative_log_likelihood += 0.5 * (whitened.norm_squared() + log_det);
        }
        if tangent.is_some() {
            sensitivity += &correction;
        }
        if !state.iter().all(|v| v.is_finite()) {
            return Err(Error::Other(format!(
                "the filter's state went non-finite at t = {t} s"
            )));
        }
    }
    Ok(true)
}

/// What one pass of the time-varying filter gives.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeVaryingPass {
    /// ν = z − ỹ at every measurement, in the observations' order.
    pub innovations: Vec<f64>,
    /// ỹ at every measurement, in the same order.
    pub predicted: Vec<f64>,
    /// ½·Σ_k (ν_kᵀS_k⁻¹ν_k + ln det S_k) over the grid points with
    /// measurements (without 2π), S_k = C_k·P̃_k·C_kᵀ + G·Gᵀ.
    pub negative_log_likelihood: f64,
    /// The output of each innovation, in the same order.
    outputs: Vec<usize>,
    /// At each grid point with measurements: where its innovations start,
    /// their number m, where its S_k (m × m, column-major) starts in
    /// `covariances`.
    spans: Vec<(usize, usize, usize)>,
    /// The S_k, grid point after grid point.
    covariances: Vec<f64>,
}

impl TimeVaryingPass {
    /// At each grid point with measurements: the outputs measured, ν and
    /// S_k over them.
    pub fn updates(
        &self,
    ) -> impl ExactSizeIterator<Item = (&[usize], DVectorView<'_, f64>, DMatrixView<'_, f64>)> + '_
    {
        self.spans.iter().map(|&(start, m, at)| {
            (
                &self.outputs[start..start + m],
                DVectorView::from_slice(&self.innovations[start..start + m], m),
                DMatrixView::from_slice(&self.covariances[at..at + m * m], m, m),
            )
        })
    }
}

/// One pass of the time-varying (extended) filter over `observations`:
/// the continuous–discrete EKF of [`extended_kalman::filter`] from
/// (`initial`, P0 = `initial_covariance`) at grid point 0 with parameters
/// `theta`, process noise F·Fᵀ, F = diag(`distribution`), and measurement
/// noise G·Gᵀ = diag(`measurement_noise`). An error when the model cannot
/// be evaluated or a covariance breaks down.
pub fn time_varying_pass<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &Gaussian,
    distribution: &DVector<f64>,
    measurement_noise: &DVector<f64>,
    observations: &Observations,
) -> Result<TimeVaryingPass> {
    if distribution.len() != model.state_count() {
        return Err(Error::Other(format!(
            "the filter's sizes do not agree: {} states, {} F entries",
            model.state_count(),
            distribution.len()
        )));
    }
    if !measurement_noise.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return Err(Error::Other(
            "the measurement noise variances must be positive and finite".into(),
        ));
    }
    let noise = Noise {
        process: DMatrix::from_diagonal(&distribution.map(|f| f * f)),
        measurement: measurement_noise.clone(),
    };
    // The likelihood and the updates are all the pass reads.
    let filtered = extended_kalman::filter_with(
        model,
        theta,
        initial.clone(),
        &noise,
        observations,
        Discretisation::Exact,
        Keep::UPDATES,
    )?;
    // Every buffer reserved once: no allocation per grid point.
    let count: usize = observations.at.iter().map(Vec::len).sum();
    let points = observations.at.iter().filter(|p| !p.is_empty()).count();
    let squares: usize = observations.at.iter().map(|p| p.len() * p.len()).sum();
    let mut pass = TimeVaryingPass {
        innovations: Vec::with_capacity(count),
        predicted: Vec::with_capacity(count),
        negative_log_likelihood: filtered.negative_log_likelihood,
        outputs: Vec::with_capacity(count),
        spans: Vec::with_capacity(points),
        covariances: Vec::with_capacity(squares),
    };
    for (present, update) in observations.at.iter().zip(filtered.measured.iter()) {
        let Some(update) = update else { continue };
        pass.spans.push((
            pass.innovations.len(),
            present.len(),
            pass.covariances.len(),
        ));
        for (i, &(o, z)) in present.iter().enumerate() {
            pass.innovations.push(update.innovation[i]);
            pass.predicted.push(z - update.innovation[i]);
            pass.outputs.push(o);
        }
        pass.covariances
            .extend(update.innovation_covariance.iter().copied());
    }
    Ok(pass)
}

/// L of S = L·Lᵀ and ln det S; an error when S is not positive definite.
fn lower_root(covariance: DMatrixView<'_, f64>) -> Result<(DMatrix<f64>, f64)> {
    let root = covariance
        .clone_owned()
        .cholesky()
        .ok_or_else(|| Error::Other("an innovation covariance is not positive definite".into()))?
        .unpack();
    let log_det = 2.0 * root.diagonal().iter().map(|d| d.ln()).sum::<f64>();
    Ok((root, log_det))
}

/// R's diagonal and, where it is full, the whole R.
type Relaxed = (DVector<f64>, Option<InnovationCovariance>);

fn at_time(error: Error, t: f64) -> Error {
    Error::Other(format!("at t = {t} s: {error}"))
}

/// A filter-error fit of any state-space model: its unknowns are the free
/// entries of θ followed by the F entries of the noisy states.
pub struct FilterErrorFit<'a, M: StateSpaceModel + ?Sized> {
    model: &'a M,
    observations: &'a Observations,
    initial: DVector<f64>,
    /// Every parameter of the model (the fixed ones at their values).
    theta: DVector<f64>,
    /// The indices of the estimated parameters in θ.
    free: Vec<usize>,
    /// The states driven by process noise (indices into x).
    noisy: Vec<usize>,
    /// The output of each measurement, in the observations' order.
    outputs: Vec<usize>,
    /// The measured values, in the same order.
    measured: Vec<f64>,
    /// R's diagonal, the current innovation variances.
    variances: DVector<f64>,
    /// The full R (steady gain, one time base: [`InnovationCovariance`]),
    /// its diagonal `variances`; None where R is diagonal.
    full: Option<InnovationCovariance>,
    /// Whether every grid point with a measurement measures every output.
    one_time_base: bool,
    /// Whether R is to be full where it can ([`InnovationForm::Full`]).
    full_wanted: bool,
    /// R (diagonal and full) before the last update and the C of that
    /// update's pass, for the compensation of F.
    previous: Option<(Relaxed, DMatrix<f64>)>,
    /// F_ref of each F entry at the start: an entry below [`COLLAPSED`] of
    /// it is zero (see [`FilterErrorFit::split`]).
    scale: Vec<f64>,
    /// The filter in the loop; with [`Gain::TimeVarying`], `variances`
    /// holds G·Gᵀ (diagonal) instead of R.
    gain: Gain,
    /// P0, the initial state's error covariance (time-varying gain only).
    initial_covariance: DMatrix<f64>,
    /// Time-varying gain, once started: G (one entry per output, G·Gᵀ =
    /// diag(G²)) is among the unknowns, after F.
    joint: bool,
    /// The lower bound of each entry of G·Gᵀ in the joint fit, a hundredth
    /// of its value at the last re-weighting (see
    /// [`FilterErrorFit::time_varying_residuals`]).
    noise_floor: DVector<f64>,
    /// In the joint fit: the relaxed G·Gᵀ proposed at the last
    /// re-weighting, taken by [`LeastSquaresProblem::compensate`] where it
    /// lowers the cost.
    proposed: Option<DVector<f64>>,
    /// Steady gain: the Jacobian by whole passes differenced even where
    /// the model propagates sensitivities.
    differences: bool,
    /// The last pass, with the θ, F and noise it was run with: the solver
    /// asks for the same pass more than once an iteration (the step's
    /// residuals, then the re-weighting at that point; the compensated F's
    /// check, then its residuals).
    last_pass: RefCell<Option<KeptPass>>,
    /// Whether the last Gauss–Newton step was constrained by diag(K·C) ≤ 1.
    constrained: bool,
    /// The unknowns' names ([`FilterErrorFit::with_names`]); empty: by position.
    names: Vec<String>,
}

/// A pass kept with the θ, F and noise it was run with.
type KeptPass = (
    DVector<f64>,
    DVector<f64>,
    DVector<f64>,
    Option<InnovationCovariance>,
    FilterPass,
);

/// A pass of the filter in the loop.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterPass {
    Steady(SteadyPass),
    TimeVarying(TimeVaryingPass),
}

impl FilterPass {
    /// ν at every measurement, in the observations' order.
    pub fn innovations(&self) -> &[f64] {
        match self {
            FilterPass::Steady(pass) => &pass.innovations,
            FilterPass::TimeVarying(pass) => &pass.innovations,
        }
    }

    /// ỹ at every measurement, in the same order.
    pub fn predicted(&self) -> &[f64] {
        match self {
            FilterPass::Steady(pass) => &pass.predicted,
            FilterPass::TimeVarying(pass) => &pass.predicted,
        }
    }

    /// The negative log-likelihood of the pass (without 2π).
    pub fn negative_log_likelihood(&self) -> f64 {
        match self {
            FilterPass::Steady(pass) => pass.negative_log_likelihood,
            FilterPass::TimeVarying(pass) => pass.negative_log_likelihood,
        }
    }
}

/// The fraction of F_ref (module documentation) below which an F entry is
/// taken as zero. F enters only through F² (Q = F·Fᵀ), so F = 0 is where
/// the likelihood's derivative in F vanishes, and where the data want no
/// process noise on a state the Gauss–Newton step, linear in F, keeps
/// predicting a decrease from F² below zero that it cannot realise: F only
/// halves at each iteration. An entry at 10⁻³ of F_ref puts a process
/// noise of 10⁻⁶ of the residual level into each step (a gain of order
/// 10⁻³); set to zero, its column of the Jacobian is zero and the solver's
/// SVD leaves it out, so it no longer holds up convergence (its bound is
/// then infinite: no process noise found on that state).
const COLLAPSED: f64 = 1e-3;

/// What a filter-error fit returns.
#[derive(Debug, Clone)]
pub struct FitResult {
    pub solution: gauss_newton::Solution,
    /// The unknowns where the iterations started.
    pub start: DVector<f64>,
    /// R's diagonal (steady gain; G·Gᵀ's, time-varying) at the solution.
    pub variances: DVector<f64>,
    /// The full R at the solution, where it is full ([`InnovationCovariance`]).
    pub full: Option<InnovationCovariance>,
    /// The pass at the solution (None when it cannot be evaluated).
    pub pass: Option<FilterPass>,
    /// The start factor of F_ref chosen (module documentation).
    pub start_factor: f64,
    /// Whether the last Gauss–Newton step was the one constrained by
    /// diag(K·C) ≤ 1: the constraint active at the solution.
    pub constrained: bool,
    /// Why R is diagonal where a full R was asked for: the fit with the
    /// full R did not converge, or was not tried ([`FilterErrorFit::fit`]).
    pub full_refused: Option<String>,
}

impl FitResult {
    /// The steady filter's R at the solution (full or diagonal).
    pub fn innovation_covariance(&self) -> InnovationCovariance {
        self.full
            .clone()
            .unwrap_or_else(|| InnovationCovariance::diagonal(&self.variances))
    }
}

impl<'a, M: StateSpaceModel + ?Sized> FilterErrorFit<'a, M> {
    /// A fit of `model` to `observations` from `initial`, with `theta`
    /// (every parameter; `free` says which are estimated) and F entries
    /// for the states `noisy` (none: output error, the filter being the
    /// simulation).
    pub fn new(
        model: &'a M,
        observations: &'a Observations,
        initial: DVector<f64>,
        theta: DVector<f64>,
        free: Vec<usize>,
        noisy: Vec<usize>,
    ) -> Result<Self> {
        let (n, parameters) = (model.state_count(), model.parameter_count());
        if theta.len() != parameters
            || free.iter().any(|&i| i >= parameters)
            || noisy.iter().any(|&i| i >= n)
        {
            return Err(Error::Other(
                "a filter-error fit's parameters or noisy states do not match the model".into(),
            ));
        }
        let (outputs, measured) = observations.at.iter().flatten().copied().unzip();
        Ok(FilterErrorFit {
            model,
            observations,
            initial,
            theta,
            free,
            noisy,
            outputs,
            measured,
            variances: DVector::from_element(model.output_count(), 1.0),
            full: None,
            one_time_base: observations
                .at
                .iter()
                .all(|present| present.is_empty() || present.len() == model.output_count()),
            full_wanted: false,
            previous: None,
            scale: Vec::new(),
            gain: Gain::Steady,
            initial_covariance: DMatrix::zeros(n, n),
            joint: false,
            noise_floor: DVector::zeros(model.output_count()),
            proposed: None,
            differences: false,
            last_pass: RefCell::new(None),
            constrained: false,
            names: Vec::new(),
        })
    }

    /// The fit with its unknowns named (the free parameters, then F's and
    /// G's entries), for the messages that name them.
    pub fn with_names(mut self, names: Vec<String>) -> Self {
        self.names = names;
        self
    }

    /// The fit with the time-varying (extended) filter in the loop, started
    /// with the initial state's error covariance P0 = `initial_covariance`.
    pub fn with_time_varying_gain(mut self, initial_covariance: DMatrix<f64>) -> Result<Self> {
        let n = self.model.state_count();
        if initial_covariance.shape() != (n, n) {
            return Err(Error::Other(format!(
                "the initial covariance is {:?} for {n} states",
                initial_covariance.shape()
            )));
        }
        self.gain = Gain::TimeVarying;
        self.initial_covariance = initial_covariance;
        Ok(self)
    }

    /// The fit with a full innovation covariance R where every output
    /// shares one time base ([`InnovationForm::Full`]; steady gain).
    pub fn with_full_innovation_covariance(mut self) -> Self {
        self.full_wanted = true;
        self
    }

    /// The fit with R of the `form` asked for; where a full R is asked for
    /// with process noise on a record whose outputs do not share one time
    /// base, a note in `notes` says R is diagonal.
    pub fn with_innovation_form(mut self, form: InnovationForm, notes: &mut Vec<String>) -> Self {
        if form == InnovationForm::Full {
            self = self.with_full_innovation_covariance();
            if !self.one_time_base && self.gain == Gain::Steady && !self.noisy.is_empty() {
                notes.push(
                    "R is diagonal: the outputs are not all measured at the same instants, and a full R (innovation_covariance = \"full\") needs one time base".into(),
                );
            }
        }
        self
    }

    /// Whether R is full ([`FilterErrorFit::with_full_innovation_covariance`]
    /// on a record whose outputs share one time base).
    pub fn full_innovation_covariance(&self) -> bool {
        self.full_wanted && self.one_time_base
    }

    /// The fit with the steady gain's Jacobian by forward differences of
    /// whole passes ([`FilterErrorFit::difference_jacobian`]) instead of
    /// the filter's sensitivity equations: the reference the sensitivities
    /// are checked against.
    pub fn with_difference_jacobian(mut self) -> Self {
        self.differences = true;
        self
    }

    /// The unknowns' count: free parameters, F entries and, in the joint
    /// fit of the time-varying gain, G entries.
    fn unknown_count(&self) -> usize {
        self.free.len() + self.noisy.len() + self.joint_count()
    }

    /// The G entries among the unknowns.
    fn joint_count(&self) -> usize {
        if self.joint {
            self.model.output_count()
        } else {
            0
        }
    }

    /// The measurement-noise variances the filter is given at the
    /// unknowns u: G² (each at least its [`FilterErrorFit::noise_floor`])
    /// in the joint fit, else the current R or G·Gᵀ.
    fn noise_of(&self, unknowns: &DVector<f64>) -> DVector<f64> {
        if !self.joint {
            return self.variances.clone();
        }
        let first = self.free.len() + self.noisy.len();
        DVector::from_fn(self.model.output_count(), |o, _| {
            (unknowns[first + o] * unknowns[first + o]).max(self.noise_floor[o])
        })
    }

    /// θ and the F diagonal of the unknowns u.
    fn split(&self, unknowns: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let mut theta = self.theta.clone();
        for (j, &i) in self.free.iter().enumerate() {
            theta[i] = unknowns[j];
        }
        let mut distribution = DVector::zeros(self.model.state_count());
        for (j, &i) in self.noisy.iter().enumerate() {
            let value = unknowns[self.free.len() + j];
            let scale = self.scale.get(j).copied().unwrap_or(0.0);
            distribution[i] = if value.abs() < COLLAPSED * scale {
                0.0
            } else {
                value
            };
        }
        (theta, distribution)
    }

    /// The unknowns of θ and F (and, in the joint fit, G = √(G·Gᵀ) of the
    /// current variances).
    fn join(&self, theta: &DVector<f64>, distribution: &DVector<f64>) -> DVector<f64> {
        DVector::from_iterator(
            self.unknown_count(),
            self.free
                .iter()
                .map(|&i| theta[i])
                .chain(self.noisy.iter().map(|&i| distribution[i]))
                .chain(
                    self.variances
                        .iter()
                        .take(self.joint_count())
                        .map(|v| v.sqrt()),
                ),
        )
    }

    /// The filter pass at the unknowns u with the current R (steady gain)
    /// or G·Gᵀ (time-varying gain).
    pub fn pass(&self, unknowns: &DVector<f64>) -> Result<FilterPass> {
        let (theta, distribution) = self.split(unknowns);
        let noise = self.noise_of(unknowns);
        if let Some((t, d, n, full, pass)) = &*self.last_pass.borrow()
            && *t == theta
            && *d == distribution
            && *n == noise
            && *full == self.full
        {
            return Ok(pass.clone());
        }
        let pass = self.pass_at(&theta, &distribution, &noise)?;
        *self.last_pass.borrow_mut() =
            Some((theta, distribution, noise, self.full.clone(), pass.clone()));
        Ok(pass)
    }

    /// The filter pass at (θ, F = diag(`distribution`)) with `noise` the
    /// R (steady gain) or G·Gᵀ (time-varying gain) it is given.
    fn pass_at(
        &self,
        theta: &DVector<f64>,
        distribution: &DVector<f64>,
        noise: &DVector<f64>,
    ) -> Result<FilterPass> {
        match self.gain {
            Gain::Steady => steady_state_pass(
                self.model,
                theta.as_slice(),
                &self.initial,
                distribution,
                &self.innovation_covariance(noise),
                self.observations,
            )
            .map(FilterPass::Steady),
            Gain::TimeVarying => time_varying_pass(
                self.model,
                theta.as_slice(),
                &Gaussian {
                    mean: self.initial.clone(),
                    covariance: self.initial_covariance.clone(),
                },
                distribution,
                noise,
                self.observations,
            )
            .map(FilterPass::TimeVarying),
        }
    }

    /// The steady filter's R: the full R where it is kept (its diagonal
    /// `variances`), else diag(`variances`).
    fn innovation_covariance(&self, variances: &DVector<f64>) -> InnovationCovariance {
        self.full
            .clone()
            .unwrap_or_else(|| InnovationCovariance::diagonal(variances))
    }

    /// The steady filter's R from a pass's innovations: the diagonal
    /// ([`FilterErrorFit::variances_of`]) and, where a full R is wanted, with
    /// the steady gain, process noise and one time base, the full R = (1/N)·Σ ν·νᵀ with that
    /// diagonal (None where it is not positive definite: the diagonal
    /// serves). Without process noise the fit is output error, whose R is
    /// diagonal as the `oem` method's.
    fn covariance_of(&self, innovations: &[f64]) -> Relaxed {
        let variances = self.variances_of(innovations);
        let outputs = self.model.output_count();
        if self.gain != Gain::Steady
            || !self.full_wanted
            || self.noisy.is_empty()
            || !self.one_time_base
            || outputs < 2
        {
            return (variances, None);
        }
        let mut sum = DMatrix::zeros(outputs, outputs);
        let mut count = 0usize;
        let mut at = 0;
        for present in &self.observations.at {
            if present.is_empty() {
                continue;
            }
            let mut nu = DVector::zeros(outputs);
            for (i, &(o, _)) in present.iter().enumerate() {
                nu[o] = innovations[at + i];
            }
            sum.ger(1.0, &nu, &nu, 1.0);
            count += 1;
            at += present.len();
        }
        let mut full = sum / count.max(1) as f64;
        full.set_diagonal(&variances);
        (variances, InnovationCovariance::full(full).ok())
    }

    /// The diagonal R of a pass's innovations: each output's mean square,
    /// floored (see [`FilterErrorFit::floors`]).
    fn variances_of(&self, innovations: &[f64]) -> DVector<f64> {
        let count = self.model.output_count();
        let mut sums = vec![(0.0, 0usize); count];
        for (&o, &nu) in self.outputs.iter().zip(innovations) {
            sums[o].0 += nu * nu;
            sums[o].1 += 1;
        }
        DVector::from_iterator(
            count,
            sums.iter()
                .zip(self.floors().iter())
                .map(|(&(innovations, n), &floor)| (innovations / n.max(1) as f64).max(floor)),
        )
    }

    /// Each output's floor of its variance. Steady gain: 10⁻²⁴ of its
    /// measurements' mean square, so that a noise-free fit stays finite.
    /// Time-varying gain: the rounding floor of G·Gᵀ, [`NOISE_ROUNDING`] of
    /// the output's variance about its mean (module documentation, "Exact
    /// fits").
    fn floors(&self) -> DVector<f64> {
        if self.gain == Gain::TimeVarying {
            return self.measured_variances() * NOISE_ROUNDING;
        }
        let count = self.model.output_count();
        let mut sums = vec![(0.0, 0usize); count];
        for (&o, &z) in self.outputs.iter().zip(&self.measured) {
            sums[o].0 += z * z;
            sums[o].1 += 1;
        }
        DVector::from_iterator(
            count,
            sums.iter()
                .map(|&(measured, n)| 1e-24 * (measured / n.max(1) as f64).max(1e-300)),
        )
    }

    /// The relaxation step of G·Gᵀ = diag(V) for the time-varying gain
    /// (module documentation): one Fisher-scoring step of the likelihood in
    /// V with the predicted covariances P̃_k held, ΔV = M⁻¹·g,
    /// g_o = ½·Σ_k ((S⁻¹νν ᵀS⁻¹)_oo − (S⁻¹)_oo), M_op = ½·Σ_k ((S⁻¹)_op)²
    /// over the grid points where o (and p) are measured; a step is cut to
    /// keep V above a tenth of its value, and V above its floor.
    fn measurement_noise_of(&self, pass: &TimeVaryingPass) -> DVector<f64> {
        let count = self.model.output_count();
        let mut gradient = DVector::<f64>::zeros(count);
        let mut information = DMatrix::<f64>::zeros(count, count);
        for (rows, innovation, covariance) in pass.updates() {
            let Some(inverse) = covariance.clone_owned().cholesky().map(|c| c.inverse()) else {
                continue;
            };
            let weighted = &inverse * innovation;
            for (i, &o) in rows.iter().enumerate() {
                gradient[o] += 0.5 * (weighted[i] * weighted[i] - inverse[(i, i)]);
                for (j, &p) in rows.iter().enumerate() {
                    information[(o, p)] += 0.5 * inverse[(i, j)] * inverse[(i, j)];
                }
            }
        }
        let step = match information.clone().cholesky() {
            Some(cholesky) => cholesky.solve(&gradient),
            None => DVector::from_fn(count, |o, _| {
                if information[(o, o)] > 0.0 {
                    gradient[o] / information[(o, o)]
                } else {
                    0.0
                }
            }),
        };
        let floors = self.floors();
        DVector::from_fn(count, |o, _| {
            let old = self.variances[o];
            (old + step[o]).max(0.1 * old).max(floors[o])
        })
    }

    /// In the joint fit, the unknowns with G from the relaxation step
    /// proposed at the last re-weighting, when that lowers the negative
    /// log-likelihood (None otherwise): the relaxation moves G·Gᵀ to its
    /// likelihood's optimum with the predicted covariances held in one step,
    /// where the Gauss–Newton step, linear in G, would take many on
    /// noise-free data.
    fn relax_jointly(&mut self, unknowns: &DVector<f64>) -> Option<DVector<f64>> {
        let proposed = self.proposed.take()?;
        let first = self.free.len() + self.noisy.len();
        let mut relaxed = unknowns.clone();
        for (o, v) in proposed.iter().enumerate() {
            relaxed[first + o] = v.max(self.noise_floor[o]).sqrt();
        }
        let cost = |fit: &mut Self, u: &DVector<f64>| {
            fit.residuals(u)
                .map(|r| r.norm_squared())
                .unwrap_or(f64::INFINITY)
        };
        (cost(self, &relaxed) < cost(self, unknowns)).then_some(relaxed)
    }

    /// In the joint fit, the unknowns of the entries of G whose G² is at
    /// its rounding floor ([`FilterErrorFit::floors`]) with the likelihood's
    /// `gradient` asking for less: those outputs are fitted to rounding, and
    /// their G is held where it is (its row and column of the normal
    /// equations zero: no step, and an infinite bound).
    fn held_at_rounding(&self, unknowns: &DVector<f64>, gradient: &DVector<f64>) -> Vec<usize> {
        if !self.joint {
            return Vec::new();
        }
        let first = self.free.len() + self.noisy.len();
        let floors = self.floors();
        (0..self.joint_count())
            .map(|o| first + o)
            .filter(|&j| {
                let g = unknowns[j];
                g * g <= floors[j - first] * (1.0 + 1e-6) && gradient[j] * g >= 0.0
            })
            .collect()
    }

    /// The outputs whose G² is at its rounding floor at the unknowns u
    /// (time-varying gain; none otherwise).
    pub fn noise_at_rounding(&self, unknowns: &DVector<f64>) -> Vec<usize> {
        if !self.joint {
            return Vec::new();
        }
        let first = self.free.len() + self.noisy.len();
        let floors = self.floors();
        (0..self.joint_count())
            .filter(|&o| {
                let g = unknowns[first + o];
                g * g <= floors[o] * (1.0 + 1e-6)
            })
            .collect()
    }

    /// The joint fit's noise floors: a hundredth of `variances`, at least
    /// [`FilterErrorFit::floors`].
    fn noise_floors(&self, variances: &DVector<f64>) -> DVector<f64> {
        let floors = self.floors();
        DVector::from_fn(variances.len(), |o, _| (0.01 * variances[o]).max(floors[o]))
    }

    /// The relaxation of the noise covariance the filter is given: R from
    /// the innovations (steady gain), a scoring step of G·Gᵀ (time-varying).
    fn relaxed(&self, pass: &FilterPass) -> Relaxed {
        match pass {
            FilterPass::Steady(pass) => self.covariance_of(&pass.innovations),
            FilterPass::TimeVarying(pass) => (self.measurement_noise_of(pass), None),
        }
    }

    /// The time-varying pass's whitened residuals: at each grid point with
    /// measurements L⁻¹·ν (S = L·Lᵀ) and √(ln det S − ln det D) over the
    /// outputs measured there, D the diagonal of the noise floors
    /// (S ≥ G·Gᵀ ≥ D, so the root is real); ½ of their squares summed is
    /// the negative log-likelihood less ½·Σ_k ln det D, a constant between
    /// re-weightings.
    fn time_varying_residuals(&self, pass: &TimeVaryingPass) -> Result<DVector<f64>> {
        let mut residuals = Vec::with_capacity(pass.innovations.len() + pass.spans.len());
        for (rows, innovation, covariance) in pass.updates() {
            let (root, log_det) = lower_root(covariance)?;
            let whitened = root
                .solve_lower_triangular(&innovation)
                .ok_or_else(|| Error::Other("a singular innovation covariance".into()))?;
            residuals.extend(whitened.iter());
            let noise: f64 = rows.iter().map(|&o| self.noise_floor[o].ln()).sum();
            residuals.push((log_det - noise).max(0.0).sqrt());
        }
        Ok(DVector::from_vec(residuals))
    }

    /// The normal equations of the time-varying pass at the unknowns u by
    /// Fisher scoring (module documentation): J holds at each grid point
    /// L⁻¹·∂ν/∂u_j and vec(L⁻¹·∂S/∂u_j·L⁻ᵀ)/√2 (L from S = L·Lᵀ at u), the
    /// pseudo-residual ρ = (w, vec(I − w·wᵀ)/√2) with w = L⁻¹·ν, so that
    /// Jᵀρ is the gradient of the negative log-likelihood and JᵀJ its
    /// Fisher information Σ_k (∂νᵀS⁻¹∂ν + ½·tr(S⁻¹∂S·S⁻¹∂S)). The
    /// derivatives by forward differences of whole passes (backward where
    /// the forward pass fails), steps as [`LeastSquaresProblem::jacobian`].
    fn fisher_scoring(
        &self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> Result<gauss_newton::NormalEquations> {
        let FilterPass::TimeVarying(here) = self.pass(unknowns)? else {
            return Err(Error::Other(
                "fisher_scoring needs the time-varying gain".into(),
            ));
        };
        let roots = here
            .updates()
            .map(|(_, _, covariance)| lower_root(covariance).map(|(root, _)| root))
            .collect::<Result<Vec<_>>>()?;
        let mut pseudo = Vec::new();
        for ((_, innovation, _), root) in here.updates().zip(&roots) {
            let w = root.solve_lower_triangular(&innovation).unwrap_or_default();
            pseudo.extend(w.iter());
            let m = w.len();
            for b in 0..m {
                for a in 0..m {
                    let identity = if a == b { 1.0 } else { 0.0 };
                    pseudo.push((identity - w[a] * w[b]) / std::f64::consts::SQRT_2);
                }
            }
        }
        let pseudo = DVector::from_vec(pseudo);
        let mut columns = Vec::with_capacity(unknowns.len());
        for j in 0..unknowns.len() {
            let h = options.difference_step(unknowns, j);
            let mut moved = unknowns.clone();
            moved[j] += h;
            let (moved_pass, step) = match self.pass(&moved) {
                Ok(pass) => (pass, h),
                Err(_) => {
                    moved[j] = unknowns[j] - h;
                    (self.pass(&moved)?, -h)
                }
            };
            let FilterPass::TimeVarying(moved_pass) = moved_pass else {
                return Err(Error::Other(
                    "fisher_scoring needs the time-varying gain".into(),
                ));
            };
            let mut column = Vec::with_capacity(pseudo.len());
            for (((_, nu, s), (_, moved_nu, moved_s)), root) in
                here.updates().zip(moved_pass.updates()).zip(&roots)
            {
                let d_innovation = (moved_nu - nu) / step;
                let d_covariance = (moved_s - s) / step;
                let a = root
                    .solve_lower_triangular(&d_innovation)
                    .unwrap_or_default();
                column.extend(a.iter());
                let half = root
                    .solve_lower_triangular(&d_covariance)
                    .unwrap_or_default();
                let b = root
                    .solve_lower_triangular(&half.transpose())
                    .unwrap_or_default();
                column.extend(b.iter().map(|v| v / std::f64::consts::SQRT_2));
            }
            columns.push(DVector::from_vec(column));
        }
        let jacobian = DMatrix::from_columns(&columns);
        Ok(gauss_newton::NormalEquations {
            gradient: jacobian.tr_mul(&pseudo),
            information: jacobian.tr_mul(&jacobian),
        })
    }

    /// Each output's variance about its mean over its measurements (a
    /// floor of 10⁻¹² of its mean square), the start of R when the model
    /// cannot be simulated without the filter.
    fn measured_variances(&self) -> DVector<f64> {
        let count = self.model.output_count();
        let mut sums = vec![(0.0, 0.0, 0usize); count];
        for (&o, &z) in self.outputs.iter().zip(&self.measured) {
            sums[o].0 += z;
            sums[o].1 += z * z;
            sums[o].2 += 1;
        }
        DVector::from_iterator(
            count,
            sums.iter().map(|&(sum, square, n)| {
                let n = n.max(1) as f64;
                let mean_square = square / n;
                (mean_square - (sum / n).powi(2)).max(1e-12 * mean_square.max(1e-300))
            }),
        )
    }

    /// ½·Σ_o N_o·ln R_oo (R diagonal) or ½·N·ln det R (R full, N the
    /// grid points measured): the likelihood with R estimated, up to a
    /// constant.
    fn determinant_cost(&self) -> f64 {
        if let Some((_, log_det)) = self.full.as_ref().and_then(|full| full.whitening.as_ref()) {
            let points = self
                .observations
                .at
                .iter()
                .filter(|p| !p.is_empty())
                .count();
            return 0.5 * points as f64 * log_det;
        }
        let mut counts = vec![0usize; self.model.output_count()];
        for &o in &self.outputs {
            counts[o] += 1;
        }
        counts
            .iter()
            .zip(self.variances.iter())
            .map(|(&n, r)| 0.5 * n as f64 * r.ln())
            .sum()
    }

    /// F_ref (module documentation): the process noise whose one-step
    /// spread equals the residual level seen through C = ∂h/∂x at the
    /// first point.
    fn reference_distribution(&self, c: &DMatrix<f64>) -> DVector<f64> {
        let step = (self.model.time(1) - self.model.time(0)) * self.observations.stride() as f64;
        let mut reference = DVector::zeros(self.model.state_count());
        for &i in &self.noisy {
            let information: f64 = (0..c.nrows())
                .map(|j| c[(j, i)] * c[(j, i)] / self.variances[j])
                .sum();
            reference[i] = if information > 0.0 {
                1.0 / (information * step).sqrt()
            } else {
                1e-3
            };
        }
        reference
    }

    /// Sets R from the innovations with no process noise at θ and chooses
    /// the start of F (module documentation); returns the start unknowns
    /// and the factor chosen.
    fn start(&mut self, theta: &DVector<f64>) -> Result<(DVector<f64>, f64)> {
        let zero = DVector::zeros(self.model.state_count());
        // R starts diagonal, from the simulation's output errors: those of
        // a model without its filter drift together, and a full R of them
        // would weigh the filter's first innovations by correlations that
        // are the simulation's, not the filter's.
        self.full = None;
        match self.pass(&self.join(theta, &zero)) {
            Ok(simulation) => self.variances = self.variances_of(simulation.innovations()),
            // A simulation that departs (an unstable mode) is no reason to
            // give up a filter that would hold it: R starts from the
            // measurements' own variances.
            Err(_) if !self.noisy.is_empty() => self.variances = self.measured_variances(),
            Err(error) => return Err(error),
        }
        if self.noisy.is_empty() {
            return Ok((self.join(theta, &zero), 0.0));
        }
        let start = self.model.time(0);
        let c = self
            .model
            .jacobians(start, self.initial.as_slice(), theta.as_slice())?
            .outputs_by_state;
        let reference = self.reference_distribution(&c);
        let simulated = (self.variances.clone(), self.full.clone());
        let mut best: Option<(f64, f64, Relaxed)> = None;
        let mut failure = None;
        for factor in START_FACTORS {
            (self.variances, self.full) = simulated.clone();
            let unknowns = self.join(theta, &(&reference * factor));
            let relaxed = (0..2).try_for_each(|_| {
                let pass = self.pass(&unknowns)?;
                (self.variances, self.full) = self.relaxed(&pass);
                Ok::<(), Error>(())
            });
            match relaxed.and_then(|_| self.pass(&unknowns)) {
                Ok(pass) => {
                    let cost = match self.gain {
                        Gain::Steady => self.determinant_cost(),
                        Gain::TimeVarying => pass.negative_log_likelihood(),
                    };
                    if best.as_ref().is_none_or(|(c, _, _)| cost < *c) {
                        best = Some((cost, factor, (self.variances.clone(), self.full.clone())));
                    }
                }
                Err(error) => failure = Some(error),
            }
        }
        match best {
            Some((_, factor, relaxed)) => {
                (self.variances, self.full) = relaxed;
                Ok((self.join(theta, &(&reference * factor)), factor))
            }
            None => Err(failure.unwrap_or_else(|| Error::Other("no start for F".into()))),
        }
    }

    /// ∂r/∂u by forward differences of whole filter passes (backward
    /// where the forward pass is infeasible: an iterate on the constraint
    /// diag(K·C) ≤ 1 or at the edge of the filters that exist with this
    /// R), one pass per unknown: the Jacobian of a model that does not
    /// propagate sensitivities ([`StateSpaceModel::step_sensitivity`]).
    pub fn difference_jacobian(
        &mut self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> std::result::Result<DMatrix<f64>, String> {
        let here = self.residuals(unknowns)?;
        let mut columns = Vec::with_capacity(unknowns.len());
        for j in 0..unknowns.len() {
            let h = options.difference_step(unknowns, j);
            let mut moved = unknowns.clone();
            moved[j] += h;
            let column = match self.residuals(&moved) {
                Ok(forward) => (forward - &here) / h,
                Err(_) => {
                    moved[j] = unknowns[j] - h;
                    (&here - self.residuals(&moved)?) / h
                }
            };
            columns.push(column);
        }
        Ok(DMatrix::from_columns(&columns))
    }

    /// ∂r/∂u of the steady-state filter by its sensitivity equations
    /// (module documentation) in one pass for every unknown; None when the
    /// model does not propagate sensitivities. ∂K/∂u_j by central
    /// differences of the gain (one-sided where the filter does not exist
    /// on one side), with the steps of [`Options::difference_step`].
    pub fn sensitivity_jacobian(
        &self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> Result<Option<DMatrix<f64>>> {
        let (theta, distribution) = self.split(unknowns);
        let start = self.model.time(0);
        let (interval, here) = self.first_point(&theta)?;
        let innovation = self.innovation_covariance(&self.variances);
        let gain_at = |moved: &DVector<f64>, j: usize| -> Result<DMatrix<f64>> {
            let (theta, distribution) = self.split(moved);
            let moved_jacobians;
            let jacobians = if j < self.free.len() {
                moved_jacobians =
                    self.model
                        .jacobians(start, self.initial.as_slice(), theta.as_slice())?;
                &moved_jacobians
            } else {
                &here
            };
            Ok(
                steady_gain(jacobians, &distribution, &innovation, interval)?
                    .0
                    .gain,
            )
        };
        let gain = gain_at(unknowns, unknowns.len())?;
        let mut gains = Vec::with_capacity(unknowns.len());
        for j in 0..unknowns.len() {
            let h = options.difference_step(unknowns, j);
            let mut moved = unknowns.clone();
            moved[j] = unknowns[j] + h;
            let forward = gain_at(&moved, j);
            moved[j] = unknowns[j] - h;
            let backward = gain_at(&moved, j);
            gains.push(match (forward, backward) {
                (Ok(forward), Ok(backward)) => (forward - backward) / (2.0 * h),
                (Ok(forward), Err(_)) => (forward - &gain) / h,
                (Err(_), Ok(backward)) => (&gain - backward) / h,
                (Err(error), Err(_)) => return Err(error),
            });
        }
        let columns: Vec<Option<usize>> = self
            .free
            .iter()
            .map(|&i| Some(i))
            .chain(self.noisy.iter().map(|_| None))
            .collect();
        let (steady, measurement_noise) = steady_gain(&here, &distribution, &innovation, interval)?;
        let mut pass = SteadyPass {
            innovations: Vec::with_capacity(self.outputs.len()),
            predicted: Vec::with_capacity(self.outputs.len()),
            negative_log_likelihood: 0.0,
            steady,
            measurement_noise,
            output_matrix: here.outputs_by_state,
        };
        let mut tangent = Tangent {
            columns: &columns,
            gains: &gains,
            rows: DMatrix::zeros(self.outputs.len(), columns.len()),
        };
        if !filter_steadily(
            self.model,
            theta.as_slice(),
            &self.initial,
            &innovation,
            self.observations,
            &mut pass,
            Some(&mut tangent),
        )? {
            return Ok(None);
        }
        let mut jacobian = tangent.rows;
        innovation.whiten(self.observations, &mut jacobian);
        Ok(Some(jacobian))
    }

    /// diag(K·C) of the steady-state filter at the unknowns u (K and C at
    /// the first grid point, with the current R).
    fn gain_products(&self, unknowns: &DVector<f64>) -> Result<DVector<f64>> {
        let (theta, distribution) = self.split(unknowns);
        let (interval, jacobians) = self.first_point(&theta)?;
        let innovation = self.innovation_covariance(&self.variances);
        let (steady, _) = steady_gain(&jacobians, &distribution, &innovation, interval)?;
        Ok((steady.gain * &jacobians.outputs_by_state).diagonal())
    }

    /// The sample period the steady gain spans and the model's Jacobians
    /// at the first grid point with θ, where the steady gain is taken.
    fn first_point(&self, theta: &DVector<f64>) -> Result<(f64, Jacobians)> {
        let start = self.model.time(0);
        let interval = (self.model.time(1) - start) * self.observations.stride() as f64;
        let jacobians = self
            .model
            .jacobians(start, self.initial.as_slice(), theta.as_slice())?;
        Ok((interval, jacobians))
    }

    /// The Gauss–Newton step subject to diag(K·C) ≤ 1 (Jategaonkar §5.3,
    /// FVSysID's `kcle1`; module documentation): None when the
    /// unconstrained step keeps to it, at its end and, where an entry is
    /// near 1 ([`NEAR_ACTIVE`]), linearised (or there is no gain), else the
    /// solution of the quadratic program min gᵀΔ + ½·ΔᵀMΔ subject to
    /// diag(K·C)(u) + A·Δ ≤ [`GAIN_LIMIT`], A = ∂diag(K·C)/∂u by central
    /// differences of the gain, by the active-set method over the states
    /// with a gain; None (the step is then cut as any infeasible one) when
    /// it fails.
    fn gain_constrained_step(
        &self,
        unknowns: &DVector<f64>,
        gradient: &DVector<f64>,
        information: &DMatrix<f64>,
        unconstrained: &DVector<f64>,
        options: &Options,
    ) -> Option<DVector<f64>> {
        if self.gain != Gain::Steady || self.noisy.is_empty() {
            return None;
        }
        let target = unknowns + unconstrained;
        let crosses = self
            .gain_products(&target)
            .map_or(true, |products| products.iter().any(|p| *p > 1.0));
        let here = self.gain_products(unknowns).ok()?;
        if !crosses && here.max() < NEAR_ACTIVE {
            return None;
        }
        let (n, m) = (here.len(), unknowns.len());
        let mut slopes = DMatrix::zeros(n, m);
        for j in 0..m {
            let h = options.difference_step(unknowns, j);
            let mut moved = unknowns.clone();
            moved[j] = unknowns[j] + h;
            let forward = self.gain_products(&moved);
            moved[j] = unknowns[j] - h;
            let backward = self.gain_products(&moved);
            let column = match (forward, backward) {
                (Ok(forward), Ok(backward)) => (forward - backward) / (2.0 * h),
                (Ok(forward), Err(_)) => (forward - &here) / h,
                (Err(_), Ok(backward)) => (&here - backward) / h,
                (Err(_), Err(_)) => return None,
            };
            slopes.set_column(j, &column);
        }
        let rows: Vec<usize> = (0..n).filter(|&i| slopes.row(i).amax() > 0.0).collect();
        let bounds = DVector::from_fn(n, |i, _| GAIN_LIMIT - here[i]);
        let linearised = &slopes * unconstrained;
        if !crosses && rows.iter().all(|&i| linearised[i] <= bounds[i]) {
            return None;
        }
        // Second-order correction (Nocedal & Wright, "Numerical
        // Optimization", §18.3): diag(K·C) curves up towards 1, so the step
        // to the linearised boundary crosses the true one; each correction
        // moves the bound of a constraint the step holds by its overshoot
        // (or, where no filter exists at the step's end, halves it).
        let mut bounds = bounds;
        let mut step = active_set_step(gradient, information, &slopes, &bounds, &rows)?;
        for _ in 0..CORRECTIONS {
            let reached = &slopes * &step;
            let held: Vec<usize> = rows
                .iter()
                .copied()
                .filter(|&i| reached[i] >= bounds[i] - 1e-9 * bounds[i].abs().max(1e-12))
                .collect();
            match self.gain_products(&(unknowns + &step)) {
                Ok(products) if products.iter().all(|p| *p <= 1.0) => break,
                Ok(products) => {
                    for &i in &held {
                        bounds[i] -= (products[i] - GAIN_LIMIT).max(0.0);
                    }
                }
                Err(_) => {
                    for &i in &held {
                        bounds[i] *= 0.5;
                    }
                }
            }
            if held.is_empty() {
                break;
            }
            step = active_set_step(gradient, information, &slopes, &bounds, &rows)?;
        }
        Some(step)
    }

    /// Fits from `theta` (every parameter) with the solver `options`
    /// (bounds of the free parameters; those of F are set here). Where R
    /// is to be full ([`FilterErrorFit::full_innovation_covariance`], with
    /// the steady gain and process noise), in two stages: the fit with a
    /// diagonal R, then, from its converged estimate, the fit with the
    /// full R (its diagonal the same, so F needs no compensation); where
    /// the second stage does not converge, the first stage's estimate is
    /// the result, with the reason ([`FitResult::full_refused`]).
    pub fn fit(&mut self, theta: &DVector<f64>, options: Options) -> Result<FitResult> {
        if !(self.full_innovation_covariance()
            && self.gain == Gain::Steady
            && !self.noisy.is_empty()
            && self.model.output_count() > 1)
        {
            return self.fit_once(theta, options);
        }
        self.full_wanted = false;
        let diagonal = self.fit_once(theta, options.clone());
        self.full_wanted = true;
        let mut diagonal = diagonal?;
        if !diagonal.solution.status.is_success() {
            diagonal.full_refused = Some(format!(
                "not tried: the fit with a diagonal R, its first stage, did not converge ({})",
                diagonal.solution.status
            ));
            return Ok(diagonal);
        }
        let options = self.prepared(&diagonal.start, options);
        let full = self
            .pass(&diagonal.solution.theta)
            .map(|pass| self.relaxed(&pass).1);
        let refused = match full {
            Ok(Some(full)) => 'full: {
                self.full = Some(full);
                self.previous = None;
                self.constrained = false;
                // With the full R the filter at the diagonal R's F need not
                // exist (R − C·P·Cᵀ no longer positive definite): F is
                // halved until it does, as after an R update.
                let Some(start) = self.feasible(diagonal.solution.theta.clone()) else {
                    break 'full "no F gives a steady-state filter with the full R at the diagonal R's estimate".to_string();
                };
                let solution = gauss_newton::solve(self, &start, &options);
                if solution.status.is_success() {
                    let mut history = diagonal.solution.history.clone();
                    history.extend(solution.history.iter().cloned());
                    let pass = self.pass(&solution.theta).ok();
                    return Ok(FitResult {
                        constrained: self.constrained,
                        variances: self.noise_of(&solution.theta),
                        full: self.full.clone(),
                        solution: gauss_newton::Solution {
                            history,
                            ..solution
                        },
                        pass,
                        full_refused: None,
                        ..diagonal
                    });
                }
                format!(
                    "the fit with the full R from the diagonal R's estimate did not converge ({})",
                    solution.status
                )
            }
            Ok(None) => {
                "the innovations' covariance at the diagonal R's estimate is not positive definite"
                    .into()
            }
            Err(error) => format!("no filter pass at the diagonal R's estimate ({error})"),
        };
        self.full = None;
        self.variances = diagonal.variances.clone();
        *self.last_pass.borrow_mut() = None;
        diagonal.full_refused = Some(refused);
        Ok(diagonal)
    }

    /// `unknowns` with F halved until a filter exists with the current R
    /// (at most 40 times); None when none does.
    fn feasible(&self, mut unknowns: DVector<f64>) -> Option<DVector<f64>> {
        for _ in 0..40 {
            if self.pass(&unknowns).is_ok() {
                return Some(unknowns);
            }
            for j in self.free.len()..unknowns.len() {
                unknowns[j] *= 0.5;
            }
        }
        None
    }

    /// The solver options with F's (and G's) typical values and bounds
    /// set from the `start` unknowns.
    fn prepared(&self, start: &DVector<f64>, mut options: Options) -> Options {
        let aero = self.free.len();
        options.typical.resize(self.unknown_count(), 1e-3);
        options
            .bounds
            .resize(self.unknown_count(), (f64::NEG_INFINITY, f64::INFINITY));
        for j in aero..self.unknown_count() {
            options.typical[j] = (0.1 * start[j]).max(f64::MIN_POSITIVE);
        }
        options
    }

    /// One fit from `theta` with R as `full_wanted` says (module
    /// documentation).
    fn fit_once(&mut self, theta: &DVector<f64>, options: Options) -> Result<FitResult> {
        let (start, start_factor) = self.start(theta)?;
        let aero = self.free.len();
        self.scale = start
            .iter()
            .skip(aero)
            .map(|f| f.abs() / start_factor)
            .collect();
        // F enters only through F·Fᵀ: its sign means nothing, so it is not
        // bounded (a bound at zero would project steps, which need not
        // then descend); its magnitude is reported.
        let mut options = self.prepared(&start, options);
        let mut start = start;
        if self.gain == Gain::TimeVarying {
            // The joint fit of θ, F and G (module documentation).
            self.joint = true;
            self.noise_floor = self.noise_floors(&self.variances);
            let (theta, distribution) = self.split(&start);
            start = self.join(&theta, &distribution);
            options.typical.resize(self.unknown_count(), 1e-3);
            options
                .bounds
                .resize(self.unknown_count(), (f64::NEG_INFINITY, f64::INFINITY));
            for j in self.unknown_count() - self.joint_count()..self.unknown_count() {
                options.typical[j] = (0.1 * start[j]).max(f64::MIN_POSITIVE);
            }
        }
        self.constrained = false;
        let solution = gauss_newton::solve(self, &start, &options);
        let pass = self.pass(&solution.theta).ok();
        Ok(FitResult {
            constrained: self.constrained,
            variances: self.noise_of(&solution.theta),
            full: self.full.clone(),
            solution,
            start,
            pass,
            start_factor,
            full_refused: None,
        })
    }
}

impl<M: StateSpaceModel + ?Sized> LeastSquaresProblem for FilterErrorFit<'_, M> {
    fn unknown_name(&self, index: usize) -> Option<String> {
        self.names.get(index).cloned()
    }

    /// The innovations whitened by R ([`InnovationCovariance`]: L⁻¹·ν at a
    /// point where R is full, ν/√R_oo otherwise; steady gain); the time-varying
    /// pass's whitened residuals (`FilterErrorFit::time_varying_residuals`).
    fn residuals(&mut self, unknowns: &DVector<f64>) -> std::result::Result<DVector<f64>, String> {
        let pass = match self.pass(unknowns).map_err(|e| e.to_string())? {
            FilterPass::Steady(pass) => pass,
            FilterPass::TimeVarying(pass) => {
                return self
                    .time_varying_residuals(&pass)
                    .map_err(|e| e.to_string());
            }
        };
        let innovation = self.innovation_covariance(&self.variances);
        let mut residuals =
            DMatrix::from_column_slice(pass.innovations.len(), 1, &pass.innovations);
        innovation.whiten(self.observations, &mut residuals);
        Ok(residuals.column(0).into_owned())
    }

    /// Forward differences of whole filter passes (module documentation);
    /// where the forward pass is infeasible (an iterate on the constraint
    /// diag(K·C) ≤ 1 or at the edge of the filters that exist with this
    /// R), the backward difference.
    fn jacobian(
        &mut self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> std::result::Result<DMatrix<f64>, String> {
        if self.gain == Gain::Steady
            && !self.differences
            && let Some(jacobian) = self
                .sensitivity_jacobian(unknowns, options)
                .map_err(|e| e.to_string())?
        {
            return Ok(jacobian);
        }
        self.difference_jacobian(unknowns, options)
    }

    /// R = (1/N)·Σ ν·νᵀ ([`InnovationCovariance`]) at the current (θ, F) (steady gain);
    /// a scoring step of G·Gᵀ (time-varying gain). Either is followed by
    /// the compensation of F ([`LeastSquaresProblem::compensate`]) with C
    /// at the first grid point.
    fn reweight(&mut self, unknowns: &DVector<f64>) -> std::result::Result<bool, String> {
        if self.joint {
            // G is estimated with θ and F; its floors move, and the
            // relaxation step of G·Gᵀ is proposed to `compensate`.
            let noise = self.noise_of(unknowns);
            self.noise_floor = self.noise_floors(&noise);
            let FilterPass::TimeVarying(pass) = self.pass(unknowns).map_err(|e| e.to_string())?
            else {
                return Ok(false);
            };
            self.variances = noise;
            self.proposed = Some(self.measurement_noise_of(&pass));
            return Ok(true);
        }
        let pass = self.pass(unknowns).map_err(|e| e.to_string())?;
        let (variances, full) = self.relaxed(&pass);
        let changed = variances != self.variances || full != self.full;
        let previous = (
            std::mem::replace(&mut self.variances, variances),
            std::mem::replace(&mut self.full, full),
        );
        let output_matrix = match pass {
            FilterPass::Steady(pass) => pass.output_matrix,
            FilterPass::TimeVarying(_) => {
                let (theta, _) = self.split(unknowns);
                self.model
                    .jacobians(
                        self.model.time(0),
                        self.initial.as_slice(),
                        theta.as_slice(),
                    )
                    .map_err(|e| e.to_string())?
                    .outputs_by_state
            }
        };
        self.previous = Some((previous, output_matrix));
        Ok(changed)
    }

    /// JᵀJ and Jᵀr of [`LeastSquaresProblem::jacobian`] (steady gain);
    /// Fisher scoring (`FilterErrorFit::fisher_scoring`, time-varying).
    fn normal_equations(
        &mut self,
        unknowns: &DVector<f64>,
        residuals: &DVector<f64>,
        options: &Options,
    ) -> std::result::Result<gauss_newton::NormalEquations, String> {
        match self.gain {
            Gain::Steady => {
                let jacobian = self.jacobian(unknowns, options)?;
                Ok(gauss_newton::NormalEquations {
                    gradient: jacobian.tr_mul(residuals),
                    information: jacobian.tr_mul(&jacobian),
                })
            }
            Gain::TimeVarying => {
                let mut normal = self
                    .fisher_scoring(unknowns, options)
                    .map_err(|e| e.to_string())?;
                for j in self.held_at_rounding(unknowns, &normal.gradient) {
                    normal.gradient[j] = 0.0;
                    normal.information.row_mut(j).fill(0.0);
                    normal.information.column_mut(j).fill(0.0);
                }
                Ok(normal)
            }
        }
    }

    /// F compensated for the R update (Jategaonkar Eq. 5.41, FVSysID's
    /// `fcompn`), then halved while the filter it gives is infeasible.
    /// When no F gives a filter with the new R (an unstable mode needs a
    /// gain that R's measurement-noise share cannot carry), the R update
    /// is undone: the iteration goes on with the R before it.
    fn compensate(&mut self, unknowns: &DVector<f64>) -> Option<DVector<f64>> {
        if self.joint {
            return self.relax_jointly(unknowns);
        }
        let ((old, old_full), c) = self.previous.take()?;
        if self.noisy.is_empty() {
            return None;
        }
        let mut compensated = unknowns.clone();
        for (j, &i) in self.noisy.iter().enumerate() {
            let (mut weighted, mut plain) = (0.0, 0.0);
            for o in 0..c.nrows() {
                let w = c[(o, i)] * c[(o, i)] / old[o];
                weighted += w * (self.variances[o] / old[o]).sqrt();
                plain += w;
            }
            if plain > 0.0 {
                compensated[self.free.len() + j] *= weighted / plain;
            }
        }
        if let Some(feasible) = self.feasible(compensated) {
            return Some(feasible);
        }
        self.variances = old;
        self.full = old_full;
        None
    }

    /// The Gauss–Newton step subject to diag(K·C) ≤ 1
    /// (`FilterErrorFit::gain_constrained_step`).
    fn constrained_step(
        &mut self,
        unknowns: &DVector<f64>,
        gradient: &DVector<f64>,
        information: &DMatrix<f64>,
        unconstrained: &DVector<f64>,
        options: &Options,
    ) -> Option<DVector<f64>> {
        let step =
            self.gain_constrained_step(unknowns, gradient, information, unconstrained, options);
        self.constrained = step.is_some();
        step
    }
}

/// Where the constrained step puts diag(K·C) on an active constraint: just
/// inside 1, where R − C·P·Cᵀ, the channel's measurement noise, is still
/// positive (at 1 it vanishes and the steady-state filter is singular).
const GAIN_LIMIT: f64 = 1.0 - 1e-6;

/// The second-order corrections of a constrained step at most
/// ([`FilterErrorFit::gain_constrained_step`]).
const CORRECTIONS: usize = 4;

/// Where diag(K·C) has an entry at least this, the Gauss–Newton step is
/// checked against the constraint linearised, not only at its end: the
/// feasible set need not be convex, and a step whose end keeps to the
/// constraint can cross it on the way.
const NEAR_ACTIVE: f64 = 0.9;

/// The minimiser of gᵀΔ + ½·ΔᵀMΔ subject to A_i·Δ ≤ b_i for the rows i in
/// `rows`, by the active-set method (Nocedal & Wright, "Numerical
/// Optimization", §16.5): starting from the constraints the unconstrained
/// step violates, each equality-constrained program is solved through its
/// KKT system (M Jacobi-scaled, solved by SVD so that unknowns with no
/// effect drop out); a constraint with a negative multiplier is released,
/// the most violated one added, until the step keeps to every constraint
/// with multipliers not below zero. None when that does not settle.
fn active_set_step(
    gradient: &DVector<f64>,
    information: &DMatrix<f64>,
    slopes: &DMatrix<f64>,
    bounds: &DVector<f64>,
    rows: &[usize],
) -> Option<DVector<f64>> {
    let m = gradient.len();
    let scale = gauss_newton::unit_diagonal_scale(information);
    let scaled = DMatrix::from_fn(m, m, |i, j| information[(i, j)] * scale[i] * scale[j]);
    let solve = |active: &[usize]| -> Option<(DVector<f64>, DVector<f64>)> {
        let size = m + active.len();
        let mut kkt = DMatrix::zeros(size, size);
        let mut right = DVector::zeros(size);
        kkt.view_mut((0, 0), (m, m)).copy_from(&scaled);
        for j in 0..m {
            right[j] = -gradient[j] * scale[j];
        }
        for (r, &i) in active.iter().enumerate() {
            let row = DVector::from_fn(m, |j, _| slopes[(i, j)] * scale[j]);
            let norm = row.norm();
            if norm == 0.0 {
                return None;
            }
            for j in 0..m {
                kkt[(m + r, j)] = row[j] / norm;
                kkt[(j, m + r)] = row[j] / norm;
            }
            right[m + r] = bounds[i] / norm;
        }
        let svd = kkt.svd(true, true);
        let threshold = svd.singular_values.max() * 1e-12;
        let solution = svd.solve(&right, threshold).ok()?;
        let delta = DVector::from_fn(m, |j, _| solution[j] * scale[j]);
        let multipliers = DVector::from_fn(active.len(), |r, _| solution[m + r]);
        Some((delta, multipliers))
    };
    let violation = |delta: &DVector<f64>, i: usize| (slopes.row(i) * delta)[0] - bounds[i];
    let (unconstrained, _) = solve(&[])?;
    let mut active: Vec<usize> = rows
        .iter()
        .copied()
        .filter(|&i| violation(&unconstrained, i) > 0.0)
        .collect();
    if active.is_empty() {
        // The linearisation keeps the step inside where the gain does not:
        // hold the most nearly active constraint.
        active.push(*rows.iter().max_by(|&&a, &&b| {
            violation(&unconstrained, a).total_cmp(&violation(&unconstrained, b))
        })?);
    }
    for _ in 0..4 * (rows.len() + 1) {
        let (delta, multipliers) = solve(&active)?;
        if let Some((r, _)) = multipliers
            .iter()
            .enumerate()
            .filter(|(_, l)| **l < 0.0)
            .min_by(|a, b| a.1.total_cmp(b.1))
        {
            active.remove(r);
            continue;
        }
        let tolerance = 1e-9;
        match rows
            .iter()
            .copied()
            .filter(|i| !active.contains(i))
            .map(|i| (i, violation(&delta, i)))
            .filter(|(_, v)| *v > tolerance)
            .max_by(|a, b| a.1.total_cmp(&b.1))
        {
            Some((i, _)) => active.push(i),
            None => return Some(delta),
        }
    }
    None
}

/// Fits `structure` to `record` by filter error.
pub fn filter_error(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FilterErrorOptions,
) -> Result<Estimate> {
    filter_error_from(record, structure, options, None)
}

/// The integrated states driven by process noise (indices into x).
fn noisy_states(view: &DrivenStateSpace, options: &FilterErrorOptions) -> Result<Vec<usize>> {
    let names = view.state_names();
    match &options.process_noise {
        None => Ok((0..names.len())
            .filter(|&i| !NOISELESS_STATES.contains(&names[i]))
            .collect()),
        Some(chosen) => chosen
            .iter()
            .map(|name| {
                names.iter().position(|n| n == name).ok_or_else(|| {
                    Error::Other(format!(
                        "[methods.{METHOD}] process_noise: '{name}' is not an integrated state of the model ({})",
                        names.join(", ")
                    ))
                })
            })
            .collect(),
    }
}

/// Filter error with equation error's estimate on the record given (else
/// computed when the start asks for it).
pub fn filter_error_from(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FilterErrorOptions,
    regression: Option<&Estimate>,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let free = free_parameters(
        METHOD,
        record,
        output_error::missing_channels(record, structure),
        &structure.name,
        &structure.free,
    )?;
    output_error::unsuitable(METHOD, structure)?;
    let (view, initial) = DrivenStateSpace::for_record(
        record,
        structure,
        &options.interpolation,
        options.step,
        options.window,
    )?;
    let noisy = noisy_states(&view, options)?;
    let step = view.time(1) - view.time(0);
    let observations =
        Observations::from_record(record, &structure.outputs, view.time(0), step, view.len())?;
    enough_data(METHOD, &observations, free.len() + noisy.len())?;
    let mut notes: Vec<String> = observations.note(step).into_iter().collect();
    notes.extend(view.simulation().notes.iter().cloned());
    let file = view.parameters();
    let state_names = view.state_names();
    let parameter_names = structure.aircraft.aero.parameters.names();
    let names = Names {
        parameters: free.iter().map(|&i| parameter_names[i].clone()).collect(),
        noise: noise_names(
            noisy.iter().map(|&i| state_names[i]),
            &structure.outputs,
            options.gain,
        ),
        states: state_names.iter().map(|s| s.to_string()).collect(),
    };
    let mut fit = FilterErrorFit::new(
        &view,
        &observations,
        initial,
        file.clone(),
        free.clone(),
        noisy.clone(),
    )?
    .with_names(names.unknowns());
    if options.gain == Gain::TimeVarying {
        let covariance =
            initial_covariance(METHOD, &view.state_names(), &options.initial_variance)?;
        fit = fit.with_time_varying_gain(covariance)?;
    }
    let mut fit = fit.with_innovation_form(options.innovation_form(), &mut notes);
    let solver = Options::maximum_likelihood(
        &free,
        &structure.bounds,
        options.max_iterations,
        CONVERGED_DECREASE,
    );
    let regression = match options.start {
        Start::EquationError => regression_start(record, structure, regression, &file, &mut notes),
        Start::Model => None,
    };
    let result = match regression {
        Some(theta) => match fit.fit(&theta, solver.clone()) {
            Ok(result) => {
                notes.push("started from equation error's estimates".into());
                Ok(result)
            }
            Err(error) => {
                notes.push(format!(
                    "started from the model file's values: no filter from equation error's estimates ({error})"
                ));
                fit.fit(&file, solver)
            }
        },
        None => fit.fit(&file, solver),
    }?;
    Ok(assemble(
        (METHOD, &structure.name, &structure.outputs),
        record,
        &fit,
        &result,
        &names,
        notes,
        started.elapsed().as_secs_f64(),
    ))
}

/// How [`linear_fit`] fits a linear structure.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinearFitOptions {
    pub max_iterations: usize,
    /// The grid step; None: the fastest output's period.
    pub step: Option<f64>,
    pub window: Option<(f64, f64)>,
    /// The states driven by process noise (filter error); None or empty:
    /// none, and the fit is output error (the filter is the simulation).
    pub process_noise: Option<Vec<String>>,
    /// The filter in the loop (filter error).
    pub gain: Gain,
    /// P0's diagonal by state name (time-varying gain).
    pub initial_variance: BTreeMap<String, f64>,
    /// The steady gain's R (with process noise).
    pub innovation_covariance: InnovationForm,
}

/// Output error (no process noise) or filter error on a linear structure:
/// the [`FilterErrorFit`] of its exact discrete model driven by the
/// record's input channels, from the file's parameter values, the initial
/// state the record's value of each state named like a channel (else 0).
/// `method` names the estimate.
pub(crate) fn linear_fit(
    method: &str,
    record: &FlightRecord,
    structure: &LinearStructure,
    options: &LinearFitOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let free = free_parameters(
        method,
        record,
        structure.missing_channels(record),
        &structure.name,
        &structure.free,
    )?;
    let noisy: Vec<usize> = options
        .process_noise
        .iter()
        .flatten()
        .map(|name| {
            structure.states.iter().position(|s| s == name).ok_or_else(|| {
                Error::Other(format!(
                    "[methods.{method}] process_noise: '{name}' is not a state of the model ({})",
                    structure.states.join(", ")
                ))
            })
        })
        .collect::<Result<_>>()?;
    let (model, initial) = structure.for_record(record, options.step, options.window)?;
    let step = model.time(1) - model.time(0);
    let observations =
        Observations::from_record(record, &structure.outputs, model.time(0), step, model.len())?;
    enough_data(method, &observations, free.len() + noisy.len())?;
    let mut notes: Vec<String> = observations.note(step).into_iter().collect();
    notes.push("linear model, started from the model file's values".to_string());
    notes.push(format!(
        "{} (the model file's `interpolation`)",
        input_timing::note(&model.input_timing)
    ));
    let theta = structure.parameter_values();
    let names = Names {
        parameters: free.iter().map(|&i| structure.names[i].clone()).collect(),
        noise: noise_names(
            noisy.iter().map(|&i| structure.states[i].as_str()),
            &structure.outputs,
            options.gain,
        ),
        states: structure.states.clone(),
    };
    let mut fit = FilterErrorFit::new(
        &model,
        &observations,
        initial,
        theta.clone(),
        free.clone(),
        noisy.clone(),
    )?
    .with_names(names.unknowns());
    if options.gain == Gain::TimeVarying {
        let names: Vec<&str> = structure.states.iter().map(String::as_str).collect();
        let covariance = initial_covariance(method, &names, &options.initial_variance)?;
        fit = fit.with_time_varying_gain(covariance)?;
    }
    let mut fit = fit.with_innovation_form(options.innovation_covariance, &mut notes);
    let mut solver = Options::maximum_likelihood(
        &free,
        &structure.bounds,
        options.max_iterations,
        CONVERGED_DECREASE,
    );
    for (j, &i) in free.iter().enumerate() {
        solver.typical[j] = 1e-3_f64.max(1e-2 * theta[i].abs());
    }
    let result = fit.fit(&theta, solver)?;
    Ok(assemble(
        (method, &structure.name, &structure.outputs),
        record,
        &fit,
        &result,
        &names,
        notes,
        started.elapsed().as_secs_f64(),
    ))
}

/// The free parameters' indices (`free` per parameter of model `model`),
/// or the refusal of `method`: channels `missing` from the record, or
/// nothing to estimate.
pub(crate) fn free_parameters(
    method: &str,
    record: &FlightRecord,
    missing: Vec<MissingChannel>,
    model: &str,
    free: &[bool],
) -> Result<Vec<usize>> {
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(method, missing, present) {
        return Err(Error::Refused(refusal));
    }
    let free: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    if free.is_empty() {
        return Err(Error::Refused(Refusal::NothingToEstimate {
            method: method.to_string(),
            model: model.to_string(),
        }));
    }
    Ok(free)
}

/// The refusal of `method` when `observations` hold fewer data than `unknowns`.
pub(crate) fn enough_data(
    method: &str,
    observations: &Observations,
    unknowns: usize,
) -> Result<()> {
    let data: usize = observations.counts().iter().sum();
    if data < unknowns {
        return Err(Error::Refused(Refusal::TooFewData {
            method: method.to_string(),
            data,
            unknowns,
        }));
    }
    Ok(())
}

/// Equation error's estimates as a start (the free parameters, within
/// their bounds, [`equation_error::start_estimate`]); None with a note
/// when there is none.
fn regression_start(
    record: &FlightRecord,
    structure: &ModelStructure,
    given: Option<&Estimate>,
    file: &DVector<f64>,
    notes: &mut Vec<String>,
) -> Option<DVector<f64>> {
    match equation_error::start_estimate(record, structure, given) {
        Ok(estimate) => {
            let names = structure.aircraft.aero.parameters.names();
            let mut theta = file.clone();
            for (i, name) in names.iter().enumerate() {
                if let (true, Some(p)) = (structure.free[i], estimate.parameter(name)) {
                    let (low, high) = structure.bounds[i];
                    theta[i] = p.value.clamp(low, high);
                }
            }
            Some(theta)
        }
        Err(reason) => {
            notes.push(format!("started from the model file's values: {reason}"));
            None
        }
    }
}

/// The names of the noise unknowns: F's entries of the `noisy` states and,
/// with the time-varying gain, G's of the `outputs`.
fn noise_names<'a>(
    noisy: impl Iterator<Item = &'a str>,
    outputs: &[String],
    gain: Gain,
) -> Vec<String> {
    let measurement = outputs.iter().take(if gain == Gain::TimeVarying {
        outputs.len()
    } else {
        0
    });
    noisy
        .map(|name| format!("F.{name}"))
        .chain(measurement.map(|name| format!("G.{name}")))
        .collect()
}

/// The names of a fit's unknowns: the free parameters, then F's entries
/// (and G's, time-varying gain).
struct Names {
    parameters: Vec<String>,
    noise: Vec<String>,
    /// The model's integrated states, in x's order.
    states: Vec<String>,
}

impl Names {
    /// Every unknown's name in θ's order.
    fn unknowns(&self) -> Vec<String> {
        self.parameters.iter().chain(&self.noise).cloned().collect()
    }
}

/// The estimate of a fit by `method` of model `name` with `outputs`: the
/// model's parameters with their block of the Cramér–Rao covariance; F and
/// R in the notes and details.
fn assemble<M: StateSpaceModel + ?Sized>(
    (method, name, outputs): (&str, &str, &[String]),
    record: &FlightRecord,
    fit: &FilterErrorFit<'_, M>,
    result: &FitResult,
    names: &Names,
    mut notes: Vec<String>,
    wall_time: f64,
) -> Estimate {
    let all: Vec<String> = names
        .parameters
        .iter()
        .chain(&names.noise)
        .cloned()
        .collect();
    let full = Estimate::from_solution(
        (method, name.to_string(), record.scenario.clone()),
        &all,
        &result.start,
        &result.solution,
    );
    let aero = names.parameters.len();
    let mut details = String::new();
    if !names.noise.is_empty() {
        details.push_str(match fit.gain {
            Gain::Steady => "process-noise distribution F (diagonal), Cramér–Rao σ:\n",
            Gain::TimeVarying => {
                "process-noise distribution F and measurement-noise G (diagonal), Cramér–Rao σ:\n"
            }
        });
    }
    for p in &full.parameters[aero..] {
        details.push_str(&format!(
            "  {} = {:.6e} ± {:.3e} (start {:.3e})\n",
            p.name,
            p.value.abs(),
            p.standard_error,
            p.start
        ));
    }
    details.push_str(match (fit.gain, &result.full) {
        (Gain::Steady, None) => "innovation covariance R (diagonal):\n",
        (Gain::Steady, Some(_)) => {
            "innovation covariance R (full, one time base): variances, then correlations:\n"
        }
        (Gain::TimeVarying, _) => "measurement noise G·Gᵀ (diagonal):\n",
    });
    for (name, r) in outputs.iter().zip(result.variances.iter()) {
        details.push_str(&format!("  {name}: {r:.6e}\n"));
    }
    if let Some(full) = result.full.as_ref().map(InnovationCovariance::matrix) {
        for a in 0..full.nrows() {
            for b in 0..a {
                let correlation = full[(a, b)] / (full[(a, a)] * full[(b, b)]).sqrt();
                details.push_str(&format!(
                    "  {} · {}: {correlation:+.3}\n",
                    outputs[a], outputs[b]
                ));
            }
        }
    }
    if !names.noise.is_empty() {
        notes.push(format!(
            "{} {}; F started at {} × F_ref",
            match fit.gain {
                Gain::Steady => "process noise",
                Gain::TimeVarying => "process and measurement noise",
            },
            full.parameters[aero..]
                .iter()
                .map(|p| format!(
                    "{} = {:.4e} ± {:.2e}",
                    p.name,
                    p.value.abs(),
                    p.standard_error
                ))
                .collect::<Vec<_>>()
                .join(", "),
            result.start_factor
        ));
    }
    if let (true, Some(FilterPass::Steady(pass))) = (result.constrained, &result.pass) {
        let products = (&pass.steady.gain * &pass.output_matrix).diagonal();
        let largest = products
            .iter()
            .zip(&names.states)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map(|(p, name)| format!("{name} ({p:.6})"))
            .unwrap_or_default();
        notes.push(format!(
            "the constraint diag(K·C) ≤ 1 (Jategaonkar §5.3) is active at the solution: the last Gauss–Newton step was the quadratic program constrained by it; largest entry after the last R update and F compensation {largest}"
        ));
    }
    if let Some(reason) = &result.full_refused {
        notes.push(format!("R is diagonal, not full: {reason}"));
    } else if result.full.is_some() {
        notes.push("R full, fitted from the estimate with a diagonal R".into());
    }
    let determinant = match &result.full {
        Some(full) => full.matrix().determinant(),
        None => result.variances.iter().product::<f64>(),
    };
    notes.push(match (fit.gain, &result.full) {
        (Gain::Steady, None) => format!(
            "R (innovation covariance) is diagonal; det(R) = {determinant:.4e} at the solution"
        ),
        (Gain::Steady, Some(_)) => format!(
            "R (innovation covariance) is full (every output on one time base; its correlations in the details); det(R) = {determinant:.4e} at the solution"
        ),
        (Gain::TimeVarying, _) => format!(
            "time-varying gain (extended Kalman filter in the loop); G·Gᵀ (measurement noise) is diagonal, det(G·Gᵀ) = {determinant:.4e} at the solution; P0 diagonal {}",
            fit.initial_covariance
                .diagonal()
                .iter()
                .map(|v| format!("{v:.3e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    });
    let exact = fit.noise_at_rounding(&result.solution.theta);
    if !exact.is_empty() {
        notes.push(format!(
            "fitted to rounding: G·Gᵀ of {} at its rounding floor ({NOISE_ROUNDING:e} of the output's variance), measurements without noise; G held there, its bound infinite",
            exact
                .iter()
                .map(|&o| outputs[o].as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let fits = result
        .pass
        .as_ref()
        .map(|pass| {
            (0..outputs.len())
                .map(|o| {
                    let (measured, predicted): (Vec<f64>, Vec<f64>) = fit
                        .outputs
                        .iter()
                        .zip(fit.measured.iter().zip(pass.predicted()))
                        .filter(|(output, _)| **output == o)
                        .map(|(_, (z, y))| (*z, *y))
                        .unzip();
                    OutputFit::new(&outputs[o], &measured, &predicted)
                })
                .collect()
        })
        .unwrap_or_default();
    Estimate {
        parameters: full.parameters[..aero].to_vec(),
        covariance: full.covariance[..aero]
            .iter()
            .map(|row| row[..aero].to_vec())
            .collect(),
        fits,
        wall_time,
        notes,
        details,
        ..full
    }
}
