//! The one Gauss–Newton / Levenberg–Marquardt core that every iterative
//! estimator uses (output error now; filter error, ELM-GN, RELM-GN and neural
//! GN later). It minimises `J(θ) = ½·Σ r_i(θ)²` for a residual vector that the
//! problem has already weighted (whitened), so that for maximum-likelihood
//! output error with R the residual covariance, `r = R^{-1/2}·(z − y)` and
//! the information matrix is `M = Σ Jᵀ·R⁻¹·J` (Verma & Peyada 2020, Eqs. 5–10; the ELM + Gauss–Newton paper
//! Eqs. 14–22; Jategaonkar, "Flight Vehicle System Identification", §4.5).
//!
//! Each iteration: the problem may re-weight (output error re-estimates R;
//! filter error also compensates its process noise for the new R),
//! the normal equations Jᵀr and JᵀJ are formed (from the Jacobian,
//! analytic if the problem gives it, else by finite differences with a
//! documented relative step; or directly by a problem that knows a cheaper
//! way, [`LeastSquaresObjective::normal_equations`]), and the Gauss–Newton
//! step `Δθ = −(JᵀJ)⁻¹·Jᵀr` is solved by SVD (near-singular directions are
//! dropped, so unidentifiable combinations do not blow up). If the cost does
//! not fall, the step is halved (up to 10 times); if that fails, a
//! Levenberg–Marquardt step `(JᵀJ + λ·diag(JᵀJ))·Δθ = −Jᵀr` with growing λ is
//! tried. A problem whose Jacobian costs much more than its residuals may
//! hold it for a few iterations (simplified Gauss–Newton, steps
//! `Δθ = −(J₀ᵀJ₀)⁻¹·J₀ᵀr(θ)` on the held J₀, with the full step only), as
//! long as each step's predicted decrease falls to half the one before;
//! otherwise it is released and computed afresh (the chord method of
//! nonlinear equation solving). Parameters are projected onto their
//! bounds. A problem whose residuals cannot be evaluated (a simulation that
//! departs, a NaN) is reported as diverged with the last good estimate,
//! never a panic.
//!
//! The problem is separate from the solver: the problem computes residuals;
//! this module owns iteration, termination and the convergence history.

use crate::Status;
use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem in weighted residual form.
pub trait LeastSquaresObjective {
    /// Why the model cannot be evaluated at a θ (a departing simulation, a
    /// covariance that is not positive definite); the solver's own findings
    /// (residuals or sensitivities that are not finite) convert into it. A
    /// fit that meets one ends [`Status::Diverged`] with its message.
    type Error: std::fmt::Display + From<crate::Error>;

    /// Weighted residuals at θ; an error when the model cannot be evaluated there.
    fn residuals(&mut self, theta: &DVector<f64>) -> Result<DVector<f64>, Self::Error>;

    /// For a problem with inequality constraints on its unknowns (filter
    /// error's diag(K·C) ≤ 1): the Gauss–Newton step at θ subject to them,
    /// the minimiser of gᵀΔ + ½·ΔᵀMΔ (g the `gradient`, M the
    /// `information`) under the constraints linearised at θ, given the
    /// unconstrained step `unconstrained`; None to take the unconstrained
    /// step (no constraint active, or the constrained program failed). The
    /// solver halves the step it returns as any other and judges
    /// convergence by its predicted decrease.
    fn constrained_step(
        &mut self,
        _theta: &DVector<f64>,
        _gradient: &DVector<f64>,
        _information: &DMatrix<f64>,
        _unconstrained: &DVector<f64>,
        _options: &Options,
    ) -> Option<DVector<f64>> {
        None
    }

    /// The name of the unknown at `index` of θ (a parameter, an initial
    /// state, a noise entry), for the messages that name unknowns; None
    /// names it by its position.
    fn unknown_name(&self, _index: usize) -> Option<String> {
        None
    }

    /// Called at the start of each iteration with the current estimate and its
    /// unweighted state; a problem that re-estimates its weights (output error's
    /// R) does so here. Returns true when the weights changed.
    fn reweight(&mut self, _theta: &DVector<f64>) -> Result<bool, Self::Error> {
        Ok(false)
    }

    /// Called after a [`LeastSquaresObjective::reweight`] that changed the
    /// weights, for a problem whose parameters are tied to them (filter
    /// error: the process-noise matrix F is scaled with the change of the
    /// innovation covariance R, Jategaonkar, "Flight Vehicle System
    /// Identification", Eq. 5.41, so that the filter's gain, which depends
    /// on both, stays near where it was): the parameters to continue from,
    /// or None to keep θ. Also called after the last re-weighting at the
    /// solution, so the solution's θ is consistent with its weights.
    fn compensate(&mut self, _theta: &DVector<f64>) -> Option<DVector<f64>> {
        None
    }

    /// For a problem whose Jacobian is an approximation it can make exact
    /// (output error's grid-point linearisation): switch to the exact one
    /// from now on, returning true if that changed anything. The solver
    /// asks before a step whose predicted decrease is below
    /// [`Options::refine_below`], and before it stops (it then carries on
    /// with the refined Jacobian, except at the iteration limit, where the
    /// final information matrix is the refined one), so that a converged
    /// fit stops on the exact Jacobian.
    fn refine(&mut self) -> bool {
        false
    }

    /// For a problem whose Jacobian costs much more than its residuals
    /// (output error: a simulation with sensitivities against a plain one):
    /// keep the Jacobian just computed, whose step's predicted decrease is
    /// `predicted`, if the problem judges it good enough to steer by, and
    /// until [`LeastSquaresObjective::release`] (or a refinement, which
    /// releases it) evaluate residuals alone and return that Jacobian
    /// (re-weighted) from `jacobian`: simplified Gauss–Newton. Returns true
    /// when it holds. The solver then takes steps
    /// Δθ = −(J₀ᵀJ₀)⁻¹·J₀ᵀr(θ) while each predicted decrease is at most
    /// `HELD_CONTRACTION` of the one before, and releases it otherwise.
    fn hold(&mut self, _predicted: f64) -> bool {
        false
    }

    /// Ends a [`LeastSquaresObjective::hold`]: the next Jacobian is computed
    /// at its θ.
    fn release(&mut self) {}

    /// ∂r/∂θ. The default uses central differences with step
    /// h_j = relative_step·max(|θ_j|, typical_j) (see [`Options::relative_step`]).
    fn jacobian(
        &mut self,
        theta: &DVector<f64>,
        options: &Options,
    ) -> Result<DMatrix<f64>, Self::Error> {
        finite_difference_jacobian(self, theta, options)
    }

    /// The normal equations at θ with the `residuals` r just evaluated
    /// there: the gradient Jᵀr and the information matrix JᵀJ of the
    /// Jacobian at θ (or the held one, re-weighted). The default forms
    /// them from [`LeastSquaresObjective::jacobian`]. A problem that knows a
    /// cheaper way may override it (output error: JᵀJ is a weighted sum of
    /// per-output Gram matrices computed once per simulation, and Jᵀr a
    /// weighted sum of per-output products, with no weighted copy of J).
    fn normal_equations(
        &mut self,
        theta: &DVector<f64>,
        residuals: &DVector<f64>,
        options: &Options,
    ) -> Result<NormalEquations, Self::Error> {
        let jacobian = self.jacobian(theta, options)?;
        Ok(NormalEquations {
            gradient: jacobian.tr_mul(residuals),
            information: jacobian.tr_mul(&jacobian),
        })
    }
}

/// The Gauss–Newton normal equations at θ: (JᵀJ)·Δθ = −Jᵀr.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalEquations {
    /// Jᵀr, the gradient of the cost ½·rᵀr.
    pub gradient: DVector<f64>,
    /// JᵀJ, the information matrix for whitened residuals.
    pub information: DMatrix<f64>,
}

/// Solver settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    pub max_iterations: usize,
    /// Converged when the relative cost reduction of a step is below this twice
    /// in a row. 1e-8: with re-estimated weights (output error) the reduction
    /// at the optimum fluctuates around 1e-9 from rounding in the simulation.
    pub cost_tolerance: f64,
    /// Converged when every |Δθ_j| is below this times max(|θ_j|, typical_j).
    pub step_tolerance: f64,
    /// For residuals whitened by their noise (maximum likelihood, where
    /// JᵀJ is the information matrix): converged, without taking the step,
    /// when the Gauss–Newton step's predicted cost decrease
    /// ½·gᵀ(JᵀJ)⁻¹g = ½·ΔθᵀJᵀJΔθ is at most this. A decrease δ is a step of
    /// √(2δ) standard deviations in the information metric, so 1e-4 stops
    /// within 0.014σ of the optimum: statistically nothing, and it saves the
    /// iterations that only confirm convergence. None: not used (residuals
    /// whose scale means nothing).
    pub decrease_tolerance: Option<f64>,
    /// Ask the problem to [`LeastSquaresObjective::refine`] its Jacobian
    /// before a step whose predicted decrease is below this (None: never).
    pub refine_below: Option<f64>,
    /// Relative finite-difference step (default 1e-6: central differences
    /// then have truncation error ~h² and rounding error ~ε/h, both ~1e-12
    /// relative).
    pub relative_step: f64,
    /// Magnitude below which a parameter's step is not scaled by its value.
    pub typical: Vec<f64>,
    /// Lower and upper bound of each parameter.
    pub bounds: Vec<(f64, f64)>,
}

impl Options {
    pub fn new(parameter_count: usize) -> Self {
        Options {
            max_iterations: 50,
            cost_tolerance: 1e-8,
            step_tolerance: 1e-9,
            decrease_tolerance: None,
            refine_below: None,
            relative_step: 1e-6,
            typical: vec![1e-3; parameter_count],
            bounds: vec![(f64::NEG_INFINITY, f64::INFINITY); parameter_count],
        }
    }

    /// The settings of a maximum-likelihood fit of the parameters `free`
    /// (indices into `bounds`, the model's bounds of every parameter): at
    /// most `max_iterations`, each free parameter within its bounds, and
    /// converged at a predicted decrease of `decrease`
    /// ([`Options::decrease_tolerance`]).
    pub fn maximum_likelihood(
        free: &[usize],
        bounds: &[(f64, f64)],
        max_iterations: usize,
        decrease: f64,
    ) -> Self {
        Options {
            max_iterations,
            decrease_tolerance: Some(decrease),
            bounds: free.iter().map(|&i| bounds[i]).collect(),
            ..Options::new(free.len())
        }
    }

    fn project(&self, theta: &mut DVector<f64>) {
        for (value, (low, high)) in theta.iter_mut().zip(&self.bounds) {
            *value = value.clamp(*low, *high);
        }
    }

    fn scale(&self, theta: &DVector<f64>, j: usize) -> f64 {
        theta[j]
            .abs()
            .max(self.typical.get(j).copied().unwrap_or(1e-3))
    }

    /// The finite-difference step of unknown j: `relative_step`·max(|θ_j|, typical_j).
    pub fn difference_step(&self, theta: &DVector<f64>, j: usize) -> f64 {
        self.relative_step * self.scale(theta, j)
    }
}

/// One iteration's record.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Iteration {
    pub cost: f64,
    /// Step halvings (negative: number of Levenberg–Marquardt attempts) used.
    pub halvings: i32,
}

/// The result of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub theta: DVector<f64>,
    pub cost: f64,
    pub status: Status,
    pub history: Vec<Iteration>,
    /// Information matrix JᵀJ at the solution (weighted residuals; for a
    /// run that stopped on a held Jacobian, that Jacobian's, computed at an
    /// earlier iterate and weighted at the solution).
    pub information: DMatrix<f64>,
    /// Residuals at the solution.
    pub residuals: DVector<f64>,
}

impl Solution {
    /// A run whose model could not be evaluated: the last good θ and the reason.
    fn diverged(
        theta: DVector<f64>,
        history: Vec<Iteration>,
        reason: impl std::fmt::Display,
    ) -> Solution {
        Solution {
            information: DMatrix::zeros(theta.len(), theta.len()),
            residuals: DVector::zeros(0),
            theta,
            cost: f64::NAN,
            status: Status::Diverged(reason.to_string()),
            history,
        }
    }

    /// Cramér–Rao covariance (JᵀJ)⁻¹ by SVD pseudo-inverse; unidentifiable
    /// directions get infinite variance rather than a meaningless number.
    pub fn covariance(&self) -> DMatrix<f64> {
        pseudo_inverse_or_infinite(&self.information)
    }
}

/// Inverts a symmetric positive semi-definite matrix; rows/columns of parameters
/// in its numerical null space are set to infinity. The matrix is first scaled
/// to unit diagonal (a correlation-like matrix), so that the null-space test
/// finds collinear parameters, not merely parameters with small units.
pub fn pseudo_inverse_or_infinite(matrix: &DMatrix<f64>) -> DMatrix<f64> {
    let n = matrix.nrows();
    if matrix.iter().any(|v| !v.is_finite()) {
        // Nothing is known of a direction with a non-finite entry (and
        // the SVD of such a matrix never ends).
        return DMatrix::from_element(n, n, f64::INFINITY);
    }
    let scale = unit_diagonal_scale(matrix);
    let scaled = DMatrix::from_fn(n, n, |i, j| matrix[(i, j)] * scale[i] * scale[j]);
    let svd = scaled.svd(true, true);
    let threshold = svd.singular_values.max() * 1e-13 * n as f64;
    let (u, v_t) = (svd.u.as_ref().unwrap(), svd.v_t.as_ref().unwrap());
    let mut inverse = DMatrix::zeros(n, n);
    let mut unidentifiable: Vec<bool> = scale.iter().map(|s| !s.is_finite() || *s == 0.0).collect();
    for (k, &sigma) in svd.singular_values.iter().enumerate() {
        if sigma > threshold {
            inverse += v_t.row(k).transpose() * u.column(k).transpose() / sigma;
        } else {
            for (j, flag) in unidentifiable.iter_mut().enumerate() {
                *flag |= v_t[(k, j)].abs() > 1e-6;
            }
        }
    }
    let mut inverse = DMatrix::from_fn(n, n, |i, j| inverse[(i, j)] * scale[i] * scale[j]);
    for j in (0..n).filter(|&j| unidentifiable[j]) {
        inverse.row_mut(j).fill(f64::INFINITY);
        inverse.column_mut(j).fill(f64::INFINITY);
    }
    inverse
}

/// 1/√A_ii (1 where the diagonal is zero: a parameter with no effect).
pub fn unit_diagonal_scale(matrix: &DMatrix<f64>) -> DVector<f64> {
    matrix
        .diagonal()
        .map(|d| if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 })
}

fn cost_of(residuals: &DVector<f64>) -> f64 {
    0.5 * residuals.norm_squared()
}

/// Central-difference Jacobian of the problem's residuals.
pub fn finite_difference_jacobian<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    theta: &DVector<f64>,
    options: &Options,
) -> Result<DMatrix<f64>, P::Error> {
    let mut columns = Vec::with_capacity(theta.len());
    for j in 0..theta.len() {
        let h = options.difference_step(theta, j);
        let (mut plus, mut minus) = (theta.clone(), theta.clone());
        plus[j] += h;
        minus[j] -= h;
        let difference = problem.residuals(&plus)? - problem.residuals(&minus)?;
        columns.push(difference / (2.0 * h));
    }
    Ok(DMatrix::from_columns(&columns))
}

/// The most a step's predicted decrease on a held Jacobian may be, as a
/// fraction of the one before, for the Jacobian to stay held (see
/// [`LeastSquaresObjective::hold`]); also the fall on fresh Jacobians that
/// allows holding again after a release. Simplified Gauss–Newton converges
/// linearly, at a rate set by how far the Jacobian has moved since it was
/// computed. A held step costs a fraction of a fresh one (output error: a
/// plain simulation against 3.5 to 7), so it pays even where it gains less
/// per step; a half (0.7 of the distance per step) is where it has moved
/// too far to be worth keeping.
pub(crate) const HELD_CONTRACTION: f64 = 0.5;

/// Minimises the problem's cost from `start`.
pub fn solve<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    start: &DVector<f64>,
    options: &Options,
) -> Solution {
    let mut theta = start.clone();
    options.project(&mut theta);
    let mut history = Vec::new();
    let mut quiet_iterations = 0;
    let mut holding = Holding::new(problem);
    for _ in 0..options.max_iterations {
        let (
            residuals,
            cost,
            NormalEquations {
                gradient,
                information,
            },
        ) = match evaluate(problem, &mut theta, options) {
            Ok(evaluated) => evaluated,
            Err(reason) => return Solution::diverged(theta, history, reason),
        };
        let gauss_newton = gauss_newton_step(problem, &theta, gradient, &information, options);
        let predicted = gauss_newton.predicted;
        let converged = options.decrease_tolerance.is_some_and(|t| predicted <= t);
        if !holding.still_steers(predicted, converged) {
            // The held Jacobian no longer steers well: a fresh one at θ.
            holding.release(problem);
            continue;
        }
        let step = if converged {
            None
        } else {
            holding.decide(problem, predicted, options);
            improving_step(
                problem,
                &theta,
                &gauss_newton,
                &information,
                cost,
                holding.held.is_some(),
                options,
            )
        };
        let Some(step) = step else {
            if !converged && holding.held.is_some() {
                // The held Jacobian's step does not lower the cost: a fresh one.
                holding.release(problem);
                continue;
            }
            if holding.refine(problem) {
                continue;
            }
            // Converged at θ when the predicted decrease is below the
            // tolerance, whose residuals and Jacobian are at hand; where no
            // step lowers the cost while the Gauss–Newton step predicts a
            // decrease beyond the tolerance, the fit stalled short of a
            // minimum (from the start or after some iterations: a
            // constraint's boundary, a kink in the cost) and says so.
            let at_optimum = converged || predicted <= options.cost_tolerance * cost;
            return Solution {
                theta,
                cost,
                status: if at_optimum {
                    Status::Converged
                } else {
                    Status::NoProgress
                },
                history,
                information,
                residuals,
            };
        };
        history.push(Iteration {
            cost: step.cost,
            halvings: step.halvings,
        });
        let relative_change = (cost - step.cost) / cost.max(f64::MIN_POSITIVE);
        let small_step = (0..theta.len()).all(|j| {
            (step.theta[j] - theta[j]).abs() <= options.step_tolerance * options.scale(&theta, j)
        });
        theta = step.theta;
        quiet_iterations = if relative_change < options.cost_tolerance || small_step {
            quiet_iterations + 1
        } else {
            0
        };
        if quiet_iterations >= 2 || small_step {
            if holding.refine(problem) {
                quiet_iterations = 0;
                continue;
            }
            return finish(problem, theta, history, Status::Converged, options);
        }
    }
    // The information matrix at the limit is the refined one at θ.
    holding.refine(problem);
    problem.release();
    finish(problem, theta, history, Status::IterationLimit, options)
}

/// One evaluation at θ: re-weighting (and the compensating move of θ it
/// asks for), the residuals, the cost and the normal equations, each
/// checked finite.
fn evaluate<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    theta: &mut DVector<f64>,
    options: &Options,
) -> Result<(DVector<f64>, f64, NormalEquations), P::Error> {
    let changed = problem.reweight(theta)?;
    compensate(problem, theta, changed, options);
    let residuals = problem.residuals(theta)?;
    let cost = finite_cost(&residuals)?;
    let normal = problem.normal_equations(theta, &residuals, options)?;
    let normal = finite_normal(normal, |j| problem.unknown_name(j))?;
    Ok((residuals, cost, normal))
}

/// The Gauss–Newton step at θ, or the problem's constrained step where it
/// gives one.
fn gauss_newton_step<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    theta: &DVector<f64>,
    gradient: DVector<f64>,
    information: &DMatrix<f64>,
    options: &Options,
) -> GaussNewton {
    let gauss_newton = GaussNewton::of(gradient, information);
    match problem.constrained_step(
        theta,
        &gauss_newton.gradient,
        information,
        &gauss_newton.delta,
        options,
    ) {
        Some(delta) => GaussNewton::constrained(gauss_newton.gradient, information, delta),
        None => gauss_newton,
    }
}

/// The solver's record of a held Jacobian (simplified Gauss–Newton, see
/// [`LeastSquaresObjective::hold`]).
struct Holding {
    /// While the Jacobian is held: the last step's predicted decrease.
    held: Option<f64>,
    /// Whether the next fresh Jacobian may be held: at first, and after a
    /// step on a fresh Jacobian whose predicted decrease fell by
    /// HELD_CONTRACTION (Gauss–Newton converging), not after a release.
    may_hold: bool,
    /// The predicted decrease of the last step on a fresh Jacobian.
    fresh_predicted: Option<f64>,
}

impl Holding {
    /// Nothing held; the problem's Jacobian released.
    fn new<P: LeastSquaresObjective + ?Sized>(problem: &mut P) -> Holding {
        problem.release();
        Holding {
            held: None,
            may_hold: true,
            fresh_predicted: None,
        }
    }

    /// Whether a held Jacobian still steers (its step's `predicted`
    /// decrease fell by HELD_CONTRACTION, or the fit `converged`); on a
    /// fresh one, notes whether holding may start.
    fn still_steers(&mut self, predicted: f64, converged: bool) -> bool {
        match self.held {
            Some(previous) => {
                // (A NaN prediction keeps the hold, as a comparison would.)
                let bound = HELD_CONTRACTION * previous;
                converged || predicted.partial_cmp(&bound) != Some(std::cmp::Ordering::Greater)
            }
            None => {
                self.may_hold |= self
                    .fresh_predicted
                    .is_some_and(|p| predicted <= HELD_CONTRACTION * p);
                self.fresh_predicted = Some(predicted);
                true
            }
        }
    }

    /// Before a step: refines the Jacobian when the predicted decrease is
    /// below `refine_below` (which releases a held one), else holds it when
    /// held already or when the problem takes it.
    fn decide<P: LeastSquaresObjective + ?Sized>(
        &mut self,
        problem: &mut P,
        predicted: f64,
        options: &Options,
    ) {
        // A refinement releases a held Jacobian: the next simulation
        // brings the refined one.
        let refined = options.refine_below.is_some_and(|r| predicted <= r) && self.refine(problem);
        if !refined && (self.held.is_some() || (self.may_hold && problem.hold(predicted))) {
            self.held = Some(predicted);
        }
    }

    /// Ends a hold: the next Jacobian is fresh, and is not held at once.
    fn release<P: LeastSquaresObjective + ?Sized>(&mut self, problem: &mut P) {
        problem.release();
        (self.held, self.may_hold) = (None, false);
    }

    /// Asks the problem to refine its Jacobian; a refinement releases a
    /// held one.
    fn refine<P: LeastSquaresObjective + ?Sized>(&mut self, problem: &mut P) -> bool {
        let refined = problem.refine();
        if refined {
            self.held = None;
        }
        refined
    }
}

/// After a re-weighting that `changed` the weights, moves θ where the
/// problem's [`LeastSquaresObjective::compensate`] says (within the bounds).
fn compensate<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    theta: &mut DVector<f64>,
    changed: bool,
    options: &Options,
) {
    if let Some(compensated) = changed.then(|| problem.compensate(theta)).flatten() {
        *theta = compensated;
        options.project(theta);
    }
}

/// The normal equations if every entry is finite; else the unknowns whose
/// sensitivities are not (a model evaluated where it has no derivative:
/// the SVD of a matrix with a NaN never ends).
fn finite_normal(
    normal: NormalEquations,
    name: impl Fn(usize) -> Option<String>,
) -> Result<NormalEquations, crate::Error> {
    let n = normal.gradient.len();
    let column = |j: usize| normal.information.column(j).iter().all(|v| v.is_finite());
    if (0..n).all(|j| normal.gradient[j].is_finite() && column(j)) {
        return Ok(normal);
    }
    // A non-finite sensitivity spreads over its unknown's row and column
    // of JᵀJ: the unknowns are those whose own entries are not finite.
    let own = |j: usize| normal.gradient[j].is_finite() && normal.information[(j, j)].is_finite();
    let mut bad: Vec<usize> = (0..n).filter(|&j| !own(j)).collect();
    if bad.is_empty() {
        bad = (0..n).filter(|&j| !column(j)).collect();
    }
    let unknowns = bad
        .into_iter()
        .map(|j| name(j).unwrap_or_else(|| format!("#{j} (by position)")))
        .collect();
    Err(crate::Error::NonFiniteSensitivities { unknowns })
}

fn finite_cost(residuals: &DVector<f64>) -> Result<f64, crate::Error> {
    let cost = cost_of(residuals);
    if cost.is_finite() {
        Ok(cost)
    } else {
        Err(crate::Error::NonFiniteResiduals)
    }
}

struct Step {
    theta: DVector<f64>,
    cost: f64,
    halvings: i32,
}

/// The Gauss–Newton step at θ: the gradient Jᵀr, the step
/// Δθ = −(JᵀJ)⁻¹·Jᵀr and its predicted decrease ½·gᵀ(JᵀJ)⁻¹g.
struct GaussNewton {
    gradient: DVector<f64>,
    delta: DVector<f64>,
    predicted: f64,
}

impl GaussNewton {
    fn of(gradient: DVector<f64>, information: &DMatrix<f64>) -> GaussNewton {
        let delta = solve_symmetric(information, &(-&gradient));
        let predicted = -0.5 * gradient.dot(&delta);
        GaussNewton {
            gradient,
            delta,
            predicted,
        }
    }

    /// A step Δ other than the unconstrained one (a constrained step), its
    /// predicted decrease −(gᵀΔ + ½·ΔᵀMΔ).
    fn constrained(
        gradient: DVector<f64>,
        information: &DMatrix<f64>,
        delta: DVector<f64>,
    ) -> GaussNewton {
        let predicted = -(gradient.dot(&delta) + 0.5 * delta.dot(&(information * &delta)));
        GaussNewton {
            gradient,
            delta,
            predicted,
        }
    }
}

/// The Gauss–Newton step with halving, then Levenberg–Marquardt; None when
/// no step lowers the cost. On a `held` Jacobian only the full step is
/// tried (if it fails, the Jacobian is what has gone stale).
fn improving_step<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    theta: &DVector<f64>,
    gauss_newton: &GaussNewton,
    information: &DMatrix<f64>,
    cost: f64,
    held: bool,
    options: &Options,
) -> Option<Step> {
    let mut try_step = |delta: &DVector<f64>| {
        let mut candidate = theta + delta;
        options.project(&mut candidate);
        let candidate_cost = problem
            .residuals(&candidate)
            .ok()
            .map(|r| cost_of(&r))
            .filter(|c| c.is_finite())?;
        (candidate_cost < cost).then_some((candidate, candidate_cost))
    };
    let mut scale = 1.0;
    for halvings in 0..=10 {
        if let Some((theta, cost)) = try_step(&(&gauss_newton.delta * scale)) {
            return Some(Step {
                theta,
                cost,
                halvings,
            });
        }
        if held {
            return None;
        }
        scale *= 0.5;
    }
    let gradient = &gauss_newton.gradient;
    let diagonal =
        DMatrix::from_diagonal(&information.diagonal().map(|d| d.max(f64::MIN_POSITIVE)));
    let mut lambda = 1e-3;
    for attempt in 1..=12 {
        let delta = solve_symmetric(&(information + &diagonal * lambda), &(-gradient));
        if let Some((theta, cost)) = try_step(&delta) {
            return Some(Step {
                theta,
                cost,
                halvings: -attempt,
            });
        }
        lambda *= 10.0;
    }
    None
}

/// Solves A·x = b for symmetric positive semi-definite A by SVD of the
/// unit-diagonal scaled system (Jacobi scaling), dropping only directions that
/// are collinear, not ones whose parameters have small units.
fn solve_symmetric(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let n = a.nrows();
    if a.iter().any(|v| !v.is_finite()) {
        return DVector::from_element(n, f64::NAN);
    }
    let scale = unit_diagonal_scale(a);
    let scaled = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * scale[i] * scale[j]);
    let svd = scaled.svd(true, true);
    let threshold = svd.singular_values.max() * 1e-12;
    let y = svd
        .solve(&b.component_mul(&scale), threshold)
        .unwrap_or_else(|_| DVector::zeros(n));
    y.component_mul(&scale)
}

fn finish<P: LeastSquaresObjective + ?Sized>(
    problem: &mut P,
    mut theta: DVector<f64>,
    history: Vec<Iteration>,
    status: Status,
    options: &Options,
) -> Solution {
    let evaluated = problem
        .reweight(&theta)
        .map(|changed| compensate(problem, &mut theta, changed, options))
        .and_then(|_| problem.residuals(&theta))
        .and_then(|r| {
            let normal = problem.normal_equations(&theta, &r, options)?;
            Ok((r, normal))
        });
    match evaluated {
        Ok((residuals, normal)) => Solution {
            information: normal.information,
            cost: cost_of(&residuals),
            residuals,
            theta,
            status,
            history,
        },
        Err(reason) => Solution::diverged(theta, history, reason),
    }
}

#[cfg(test)]
mod tests;
