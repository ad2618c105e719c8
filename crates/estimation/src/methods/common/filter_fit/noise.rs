//! The noise the filter is given between steps: R relaxed from the
//! innovations (Jategaonkar Eq. 5.37) and its floors; with the time-varying
//! gain, G·Gᵀ by a Fisher-scoring step of the likelihood (Eq. 5.16), its
//! rounding floors on noise-free data, and the whitened residuals
//! L⁻¹·ν, √(ln det S_k − ln det D) the solver sees.

use super::*;

/// The rounding floor of each entry of G·Gᵀ with the time-varying gain,
/// as a fraction of its output's variance about its mean: G at 10⁻⁴ of
/// the output's spread (docs/methods.md, Filter error, "Exact fits"). Where the
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
pub(crate) const NOISE_ROUNDING: f64 = 1e-8;

impl<M: StateSpaceModel + ?Sized> FilterErrorFit<'_, M> {
    /// The steady filter's R: the full R where it is kept (its diagonal
    /// `variances`), else diag(`variances`).
    pub(crate) fn innovation_covariance(&self, variances: &DVector<f64>) -> InnovationCovariance {
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
    pub(crate) fn covariance_of(&self, innovations: &[f64]) -> Relaxed {
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
    pub(crate) fn variances_of(&self, innovations: &[f64]) -> DVector<f64> {
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
    /// the output's variance about its mean (docs/methods.md, Filter error, "Exact
    /// fits").
    pub(crate) fn floors(&self) -> DVector<f64> {
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
    /// (docs/methods.md, Filter error): one Fisher-scoring step of the likelihood in
    /// V with the predicted covariances P̃_k held, ΔV = M⁻¹·g,
    /// g_o = ½·Σ_k ((S⁻¹νν ᵀS⁻¹)_oo − (S⁻¹)_oo), M_op = ½·Σ_k ((S⁻¹)_op)²
    /// over the grid points where o (and p) are measured; a step is cut to
    /// keep V above a tenth of its value, and V above its floor.
    pub(crate) fn measurement_noise_of(&self, pass: &TimeVaryingPass) -> DVector<f64> {
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
    pub(crate) fn relax_jointly(&mut self, unknowns: &DVector<f64>) -> Option<DVector<f64>> {
        let Relaxation::Joint { proposed } = &mut self.relaxation else {
            return None;
        };
        let proposed = proposed.take()?;
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
    pub(crate) fn held_at_rounding(
        &self,
        unknowns: &DVector<f64>,
        gradient: &DVector<f64>,
    ) -> Vec<usize> {
        if !self.joint() {
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
        if !self.joint() {
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
    pub(crate) fn noise_floors(&self, variances: &DVector<f64>) -> DVector<f64> {
        let floors = self.floors();
        DVector::from_fn(variances.len(), |o, _| (0.01 * variances[o]).max(floors[o]))
    }

    /// The relaxation of the noise covariance the filter is given: R from
    /// the innovations (steady gain), a scoring step of G·Gᵀ (time-varying).
    pub(crate) fn relaxed(&self, pass: &FilterPass) -> Relaxed {
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
    pub(crate) fn time_varying_residuals(&self, pass: &TimeVaryingPass) -> Result<DVector<f64>> {
        let mut residuals = Vec::with_capacity(pass.innovations.len() + pass.spans.len());
        for (rows, innovation, covariance) in pass.updates() {
            let (root, log_det) = lower_root(covariance)?;
            let whitened =
                root.solve_lower_triangular(&innovation)
                    .ok_or_else(|| Error::Numerical {
                        reason: "a singular innovation covariance".into(),
                    })?;
            residuals.extend(whitened.iter());
            let noise: f64 = rows.iter().map(|&o| self.noise_floor[o].ln()).sum();
            residuals.push((log_det - noise).max(0.0).sqrt());
        }
        Ok(DVector::from_vec(residuals))
    }

    /// Each output's variance about its mean over its measurements (a
    /// floor of 10⁻¹² of its mean square), the start of R when the model
    /// cannot be simulated without the filter.
    pub(crate) fn measured_variances(&self) -> DVector<f64> {
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
    pub(crate) fn determinant_cost(&self) -> f64 {
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
}
