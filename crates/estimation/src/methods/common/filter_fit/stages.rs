//! The fit in stages: with a diagonal R to convergence, then with the full
//! R from that estimate; each stage from its start, F's and G's typical
//! values set.

use super::*;

impl<M: StateSpaceModel + ?Sized> FilterErrorFit<'_, M> {
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
                self.relaxation = Relaxation::Between { previous: None };
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
    pub(crate) fn feasible(&self, mut unknowns: DVector<f64>) -> Option<DVector<f64>> {
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
    pub(crate) fn prepared(&self, start: &DVector<f64>, mut options: Options) -> Options {
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

    /// One fit from `theta` with R as `full_wanted` says (docs/methods.md,
    /// Filter error).
    pub(crate) fn fit_once(&mut self, theta: &DVector<f64>, options: Options) -> Result<FitResult> {
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
            // The joint fit of θ, F and G (docs/methods.md, Filter error).
            if !self.joint() {
                self.relaxation = Relaxation::Joint { proposed: None };
            }
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
