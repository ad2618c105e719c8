//! [`FilterErrorFit`]: the fit's state, its builders, the layout of its
//! unknowns (free θ, F, and in the joint fit G) and the filter pass at
//! them; [`FitResult`].

use super::*;

/// A filter-error fit of any state-space model: its unknowns are the free
/// entries of θ followed by the F entries of the noisy states.
pub struct FilterErrorFit<'a, M: StateSpaceModel + ?Sized> {
    pub(crate) model: &'a M,
    pub(crate) observations: &'a Observations,
    pub(crate) initial: DVector<f64>,
    /// Every parameter of the model (the fixed ones at their values).
    pub(crate) theta: DVector<f64>,
    /// The indices of the estimated parameters in θ.
    pub(crate) free: Vec<usize>,
    /// The states driven by process noise (indices into x).
    pub(crate) noisy: Vec<usize>,
    /// The output of each measurement, in the observations' order.
    pub(crate) outputs: Vec<usize>,
    /// The measured values, in the same order.
    pub(crate) measured: Vec<f64>,
    /// R's diagonal, the current innovation variances.
    pub(crate) variances: DVector<f64>,
    /// The full R (steady gain, one time base: [`InnovationCovariance`]),
    /// its diagonal `variances`; None where R is diagonal.
    pub(crate) full: Option<InnovationCovariance>,
    /// Whether every grid point with a measurement measures every output.
    pub(crate) one_time_base: bool,
    /// Whether R is to be full where it can ([`InnovationForm::Full`]).
    pub(crate) full_wanted: bool,
    /// F_ref of each F entry at the start: an entry below [`COLLAPSED`] of
    /// it is zero (see [`FilterErrorFit::split`]).
    pub(crate) scale: Vec<f64>,
    /// The filter in the loop; with [`Gain::TimeVarying`], `variances`
    /// holds G·Gᵀ (diagonal) instead of R.
    pub(crate) gain: Gain,
    /// P0, the initial state's error covariance (time-varying gain only).
    pub(crate) initial_covariance: DMatrix<f64>,
    /// How the noise is estimated: relaxed between the steps, or, with the
    /// time-varying gain once started, jointly with θ and F.
    pub(crate) relaxation: Relaxation,
    /// The lower bound of each entry of G·Gᵀ in the joint fit, a hundredth
    /// of its value at the last re-weighting (see
    /// [`FilterErrorFit::time_varying_residuals`]).
    pub(crate) noise_floor: DVector<f64>,
    /// Steady gain: the Jacobian by whole passes differenced even where
    /// the model propagates sensitivities.
    pub(crate) differences: bool,
    /// The last pass, with the θ, F and noise it was run with: the solver
    /// asks for the same pass more than once an iteration (the step's
    /// residuals, then the re-weighting at that point; the compensated F's
    /// check, then its residuals).
    pub(crate) last_pass: RefCell<Option<KeptPass>>,
    /// Whether the last Gauss–Newton step was constrained by diag(K·C) ≤ 1.
    pub(crate) constrained: bool,
    /// The unknowns' names ([`FilterErrorFit::with_names`]); empty: by position.
    pub(crate) names: Vec<String>,
}

/// How a fit estimates the noise it gives the filter, R (steady gain) or
/// G·Gᵀ (time-varying gain): the one state of [`FilterErrorFit`] that
/// changes how the solver's re-weighting and compensation act.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Relaxation {
    /// Relaxed in closed form between the Gauss–Newton steps (R = (1/N)·Σ
    /// ν·νᵀ, or a scoring step of G·Gᵀ), F compensated after each update
    /// (Jategaonkar Eq. 5.41). `previous`: R (diagonal and full) before
    /// the last update and the C of that update's pass, taken by
    /// [`LeastSquaresObjective::compensate`].
    Between {
        previous: Option<(Relaxed, DMatrix<f64>)>,
    },
    /// Time-varying gain, once started: G (one entry per output, G·Gᵀ =
    /// diag(G²)) is among the unknowns, after F. `proposed`: the relaxed
    /// G·Gᵀ proposed at the last re-weighting, taken by
    /// [`LeastSquaresObjective::compensate`] where it lowers the cost.
    Joint { proposed: Option<DVector<f64>> },
}

/// A pass kept with the θ, F and noise it was run with.
type KeptPass = (
    DVector<f64>,
    DVector<f64>,
    DVector<f64>,
    Option<InnovationCovariance>,
    FilterPass,
);

/// The fraction of F_ref (docs/methods.md, Filter error) below which an F entry is
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
    /// The start factor of F_ref chosen (docs/methods.md, Filter error).
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
            return Err(Error::Shape {
                reason: "a filter-error fit's parameters or noisy states do not match the model"
                    .into(),
            });
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
            scale: Vec::new(),
            gain: Gain::Steady,
            initial_covariance: DMatrix::zeros(n, n),
            relaxation: Relaxation::Between { previous: None },
            noise_floor: DVector::zeros(model.output_count()),
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
            return Err(Error::Shape {
                reason: format!(
                    "the initial covariance is {:?} for {n} states",
                    initial_covariance.shape()
                ),
            });
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
    pub(crate) fn unknown_count(&self) -> usize {
        self.free.len() + self.noisy.len() + self.joint_count()
    }

    /// Whether G is among the unknowns ([`Relaxation::Joint`]).
    pub(crate) fn joint(&self) -> bool {
        matches!(self.relaxation, Relaxation::Joint { .. })
    }

    /// The G entries among the unknowns.
    pub(crate) fn joint_count(&self) -> usize {
        if self.joint() {
            self.model.output_count()
        } else {
            0
        }
    }

    /// The measurement-noise variances the filter is given at the
    /// unknowns u: G² (each at least its [`FilterErrorFit::noise_floor`])
    /// in the joint fit, else the current R or G·Gᵀ.
    pub(crate) fn noise_of(&self, unknowns: &DVector<f64>) -> DVector<f64> {
        if !self.joint() {
            return self.variances.clone();
        }
        let first = self.free.len() + self.noisy.len();
        DVector::from_fn(self.model.output_count(), |o, _| {
            (unknowns[first + o] * unknowns[first + o]).max(self.noise_floor[o])
        })
    }

    /// θ and the F diagonal of the unknowns u.
    pub(crate) fn split(&self, unknowns: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
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
    pub(crate) fn join(&self, theta: &DVector<f64>, distribution: &DVector<f64>) -> DVector<f64> {
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
    pub(crate) fn pass_at(
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
}
