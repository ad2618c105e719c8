//! The Jacobian of the innovations: the steady filter's sensitivity
//! equations (Jategaonkar §5.5, ∂K by central differences of the gain),
//! forward differences of whole passes, and, with the time-varying gain,
//! Fisher scoring's M = Σ_k (∂νᵀS⁻¹∂ν + ½·tr(S⁻¹∂S·S⁻¹∂S)).

use super::*;

impl<M: StateSpaceModel + ?Sized> FilterErrorFit<'_, M> {
    /// The normal equations of the time-varying pass at the unknowns u by
    /// Fisher scoring (docs/methods.md, Filter error): J holds at each grid point
    /// L⁻¹·∂ν/∂u_j and vec(L⁻¹·∂S/∂u_j·L⁻ᵀ)/√2 (L from S = L·Lᵀ at u), the
    /// pseudo-residual ρ = (w, vec(I − w·wᵀ)/√2) with w = L⁻¹·ν, so that
    /// Jᵀρ is the gradient of the negative log-likelihood and JᵀJ its
    /// Fisher information Σ_k (∂νᵀS⁻¹∂ν + ½·tr(S⁻¹∂S·S⁻¹∂S)). The
    /// derivatives by forward differences of whole passes (backward where
    /// the forward pass fails), steps as [`LeastSquaresObjective::jacobian`].
    pub(crate) fn fisher_scoring(
        &self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> Result<gauss_newton::NormalEquations> {
        let FilterPass::TimeVarying(here) = self.pass(unknowns)? else {
            return Err(Error::Method {
                reason: "fisher_scoring needs the time-varying gain".into(),
            });
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
                return Err(Error::Method {
                    reason: "fisher_scoring needs the time-varying gain".into(),
                });
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

    /// ∂r/∂u by forward differences of whole filter passes (backward
    /// where the forward pass is infeasible: an iterate on the constraint
    /// diag(K·C) ≤ 1 or at the edge of the filters that exist with this
    /// R), one pass per unknown: the Jacobian of a model that does not
    /// propagate sensitivities ([`StateSpaceModel::step_sensitivity`]).
    pub fn difference_jacobian(
        &mut self,
        unknowns: &DVector<f64>,
        options: &Options,
    ) -> crate::Result<DMatrix<f64>> {
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
    /// (docs/methods.md, Filter error) in one pass for every unknown; None when the
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

    /// The sample period the steady gain spans and the model's Jacobians
    /// at the first grid point with θ, where the steady gain is taken.
    pub(crate) fn first_point(&self, theta: &DVector<f64>) -> Result<(f64, Jacobians)> {
        let start = self.model.time(0);
        let interval = (self.model.time(1) - start) * self.observations.stride() as f64;
        let jacobians = self
            .model
            .jacobians(start, self.initial.as_slice(), theta.as_slice())?;
        Ok((interval, jacobians))
    }
}
