//! [`FilterErrorFit`] as the shared Gauss–Newton core's problem: whitened
//! residuals, the Jacobian, the relaxation of R (Jategaonkar Eq. 5.37), the
//! compensation of F (Eq. 5.41, FVSysID's `fcompn`) and the constrained
//! step.

use super::*;

impl<M: StateSpaceModel + ?Sized> LeastSquaresObjective for FilterErrorFit<'_, M> {
    type Error = crate::Error;

    fn unknown_name(&self, index: usize) -> Option<String> {
        self.names.get(index).cloned()
    }

    /// The innovations whitened by R ([`InnovationCovariance`]: L⁻¹·ν at a
    /// point where R is full, ν/√R_oo otherwise; steady gain); the time-varying
    /// pass's whitened residuals (`FilterErrorFit::time_varying_residuals`).
    fn residuals(&mut self, unknowns: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let pass = match self.pass(unknowns)? {
            FilterPass::Steady(pass) => pass,
            FilterPass::TimeVarying(pass) => {
                return self.time_varying_residuals(&pass);
            }
        };
        let innovation = self.innovation_covariance(&self.variances);
        let mut residuals =
            DMatrix::from_column_slice(pass.innovations.len(), 1, &pass.innovations);
        innovation.whiten(self.observations, &mut residuals);
        Ok(residuals.column(0).into_owned())
    }

    /// Forward differences of whole filter passes (docs/methods.md, Filter error);
    /// where the forward pass is infeasible (an iterate on the constraint
    /// diag(K·C) ≤ 1 or at the edge of the filters that exist with this
    /// R), the backward difference.
    fn jacobian(
        &mut self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> crate::Result<DMatrix<f64>> {
        if self.gain == Gain::Steady
            && !self.differences
            && let Some(jacobian) = self.sensitivity_jacobian(unknowns, options)?
        {
            return Ok(jacobian);
        }
        self.difference_jacobian(unknowns, options)
    }

    /// R = (1/N)·Σ ν·νᵀ ([`InnovationCovariance`]) at the current (θ, F) (steady gain);
    /// a scoring step of G·Gᵀ (time-varying gain). Either is followed by
    /// the compensation of F ([`LeastSquaresObjective::compensate`]) with C
    /// at the first grid point.
    fn reweight(&mut self, unknowns: &DVector<f64>) -> crate::Result<bool> {
        if self.joint() {
            // G is estimated with θ and F; its floors move, and the
            // relaxation step of G·Gᵀ is proposed to `compensate`.
            let noise = self.noise_of(unknowns);
            self.noise_floor = self.noise_floors(&noise);
            let FilterPass::TimeVarying(pass) = self.pass(unknowns)? else {
                return Ok(false);
            };
            self.variances = noise;
            self.relaxation = Relaxation::Joint {
                proposed: Some(self.measurement_noise_of(&pass)),
            };
            return Ok(true);
        }
        let pass = self.pass(unknowns)?;
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
                    )?
                    .outputs_by_state
            }
        };
        self.relaxation = Relaxation::Between {
            previous: Some((previous, output_matrix)),
        };
        Ok(changed)
    }

    /// JᵀJ and Jᵀr of [`LeastSquaresObjective::jacobian`] (steady gain);
    /// Fisher scoring (`FilterErrorFit::fisher_scoring`, time-varying).
    fn normal_equations(
        &mut self,
        unknowns: &DVector<f64>,
        residuals: &DVector<f64>,
        options: &Options,
    ) -> crate::Result<gauss_newton::NormalEquations> {
        match self.gain {
            Gain::Steady => {
                let jacobian = self.jacobian(unknowns, options)?;
                Ok(gauss_newton::NormalEquations {
                    gradient: jacobian.tr_mul(residuals),
                    information: jacobian.tr_mul(&jacobian),
                })
            }
            Gain::TimeVarying => {
                let mut normal = self.fisher_scoring(unknowns, options)?;
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
        let previous = match &mut self.relaxation {
            Relaxation::Joint { .. } => return self.relax_jointly(unknowns),
            Relaxation::Between { previous } => previous.take(),
        };
        let ((old, old_full), c) = previous?;
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
