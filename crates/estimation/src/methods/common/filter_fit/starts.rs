//! Starts: R from the simulation without the filter, F = F_ref times the
//! factor with the lowest ½·Σ N_o·ln R_oo, F_ref,i = (Σ_j C_ji²/R_jj)^{−½}/√Δt;
//! θ from equation error's estimate.

use super::*;

/// The factors of F_ref tried for the start of F (docs/methods.md, Filter error).
pub(crate) const START_FACTORS: [f64; 5] = [1.0, 0.3, 0.1, 0.03, 0.01];

impl<M: StateSpaceModel + ?Sized> FilterErrorFit<'_, M> {
    /// F_ref (docs/methods.md, Filter error): the process noise whose one-step
    /// spread equals the residual level seen through C = ∂h/∂x at the
    /// first point.
    pub(crate) fn reference_distribution(&self, c: &DMatrix<f64>) -> DVector<f64> {
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
    /// the start of F (docs/methods.md, Filter error); returns the start unknowns
    /// and the factor chosen.
    pub(crate) fn start(&mut self, theta: &DVector<f64>) -> Result<(DVector<f64>, f64)> {
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
            None => Err(failure.unwrap_or_else(|| Error::Shape {
                reason: "no start for F".into(),
            })),
        }
    }
}

/// Equation error's estimates as a start (the free parameters, within
/// their bounds, [`start_estimate`]); None with a note
/// when there is none.
pub(crate) fn regression_start(
    record: &FlightRecord,
    structure: &ModelStructure,
    given: Option<&Estimate>,
    file: &DVector<f64>,
    notes: &mut Vec<String>,
) -> Option<DVector<f64>> {
    match start_estimate(record, structure, given) {
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
