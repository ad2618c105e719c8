//! The gain constraint diag(K·C) ≤ 1 (Jategaonkar §5.3, FVSysID's `kcle1`):
//! the Gauss–Newton step as the quadratic program min gᵀΔ + ½·ΔᵀMΔ subject
//! to the constraint linearised, by the active-set method (Nocedal &
//! Wright, "Numerical Optimization", §16.5) with second-order corrections
//! (§18.3).

use super::*;

impl<M: StateSpaceModel + ?Sized> FilterErrorFit<'_, M> {
    /// diag(K·C) of the steady-state filter at the unknowns u (K and C at
    /// the first grid point, with the current R).
    pub(crate) fn gain_products(&self, unknowns: &DVector<f64>) -> Result<DVector<f64>> {
        let (theta, distribution) = self.split(unknowns);
        let (interval, jacobians) = self.first_point(&theta)?;
        let innovation = self.innovation_covariance(&self.variances);
        let (steady, _) = steady_gain(&jacobians, &distribution, &innovation, interval)?;
        Ok((steady.gain * &jacobians.outputs_by_state).diagonal())
    }

    /// The Gauss–Newton step subject to diag(K·C) ≤ 1 (Jategaonkar §5.3,
    /// FVSysID's `kcle1`; docs/methods.md, Filter error): None when the
    /// unconstrained step keeps to it, at its end and, where an entry is
    /// near 1 ([`NEAR_ACTIVE`]), linearised (or there is no gain), else the
    /// solution of the quadratic program min gᵀΔ + ½·ΔᵀMΔ subject to
    /// diag(K·C)(u) + A·Δ ≤ [`GAIN_LIMIT`], A = ∂diag(K·C)/∂u by central
    /// differences of the gain, by the active-set method over the states
    /// with a gain; None (the step is then cut as any infeasible one) when
    /// it fails.
    pub(crate) fn gain_constrained_step(
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
}

/// Where the constrained step puts diag(K·C) on an active constraint: just
/// inside 1, where R − C·P·Cᵀ, the channel's measurement noise, is still
/// positive (at 1 it vanishes and the steady-state filter is singular).
pub(crate) const GAIN_LIMIT: f64 = 1.0 - 1e-6;

/// The second-order corrections of a constrained step at most
/// ([`FilterErrorFit::gain_constrained_step`]).
pub(crate) const CORRECTIONS: usize = 4;

/// Where diag(K·C) has an entry at least this, the Gauss–Newton step is
/// checked against the constraint linearised, not only at its end: the
/// feasible set need not be convex, and a step whose end keeps to the
/// constraint can cross it on the way.
pub(crate) const NEAR_ACTIVE: f64 = 0.9;

/// The minimiser of gᵀΔ + ½·ΔᵀMΔ subject to A_i·Δ ≤ b_i for the rows i in
/// `rows`, by the active-set method (Nocedal & Wright, "Numerical
/// Optimization", §16.5): starting from the constraints the unconstrained
/// step violates, each equality-constrained program is solved through its
/// KKT system (M Jacobi-scaled, solved by SVD so that unknowns with no
/// effect drop out); a constraint with a negative multiplier is released,
/// the most violated one added, until the step keeps to every constraint
/// with multipliers not below zero. None when that does not settle.
pub(crate) fn active_set_step(
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
