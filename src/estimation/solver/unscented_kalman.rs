//! One pass of the unscented Kalman filter with additive noise over any
//! state-space model ([`StateSpaceModel`]) and a record's observations on
//! its grid (Wan & van der Merwe, "The unscented Kalman filter for
//! nonlinear estimation", IEEE AS-SPCC 2000, Table 3 with additive noise;
//! Julier & Uhlmann, "A new extension of the Kalman filter to nonlinear
//! systems", SPIE 3068, 1997). The same [`Pass`] as the extended filter's
//! ([`super::extended_kalman`]), so that methods, smoothers and
//! likelihoods take either.
//!
//! Time update from grid point k − 1 to k: sigma points χ_i of
//! (x⁺_{k−1}, P⁺_{k−1}) ([`Unscented::points`], Wan & van der Merwe
//! Eq. 15), each propagated by the model's own integration step,
//! χ'_i = step(χ_i); x⁻ = Σ Wᵐ_i·χ'_i and
//! P⁻ = Σ Wᶜ_i·(χ'_i − x⁻)(χ'_i − x⁻)ᵀ + Q_d. The pass's transition is the
//! statistical linearisation Φ = P_{x'x}·P⁺⁻¹ with
//! P_{x'x} = Σ Wᶜ_i·(χ'_i − x⁻)(χ_i − x⁺)ᵀ, with which the RTS smoother's
//! gain is the unscented RTS smoother's (P_{xx'}·P⁻⁻¹). The process noise
//! Q_d = ∫₀ʰ e^{A·s}·Q_c·e^{Aᵀ·s} ds is taken by the trapezoidal rule with
//! that Φ, (Q_c + Φ·Q_c·Φᵀ)·h/2 (the UKF has no Jacobian), within O(h³)
//! of the extended filter's Van Loan Q_d.
//!
//! Measurement update at k with the outputs measured there: sigma points
//! of (x⁻, P⁻) (redrawn: the additive-noise form), Y_i = h(t_k, χ_i) (rows
//! of the measured outputs), ŷ = Σ Wᵐ_i·Y_i,
//! S = Σ Wᶜ_i·(Y_i − ŷ)(Y_i − ŷ)ᵀ + R,
//! P_xy = Σ Wᶜ_i·(χ_i − x⁻)(Y_i − ŷ)ᵀ, K = P_xy·S⁻¹ and
//! x⁺ = x⁻ + K·(z − ŷ). Wan & van der Merwe take P⁺ = P⁻ − K·S·Kᵀ; here
//! it is Joseph's form (I − K·H)·P⁻·(I − K·H)ᵀ + K·R·Kᵀ with the
//! statistical H = P_xyᵀ·P⁻⁻¹ (the pass's observation matrix), positive
//! semi-definite by construction. The two agree for a linear h and
//! differ by K·(H·P⁻·Hᵀ + R − S)·Kᵀ otherwise, a term of the order of the
//! unscented transform's correction to the linearised output covariance;
//! the subtractive form lost definiteness to rounding on a noise-free
//! record. A covariance that rounding has left short of positive definite
//! is loaded on its diagonal by at most 10⁻⁸ of itself before it is
//! factored ([`LOADS`]).

use crate::error::{Error, Result};
use crate::estimation::model::observations::Observations;
use crate::estimation::model::state_space::StateSpaceModel;
use crate::estimation::solver::extended_kalman::{Noise, Pass, at_time, check_sizes};
use crate::estimation::solver::kalman::{Gaussian, Measured, SigmaPoints, Unscented, Update};
use nalgebra::{Cholesky, DMatrix, DVector};

/// Runs the unscented filter from `initial` at grid point 0 with the
/// parameters `theta` (a model's own; none for an augmented model) and the
/// sigma-point scaling `unscented`. An error names the time where the
/// model departs or a covariance breaks down.
pub fn filter<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: Gaussian,
    noise: &Noise,
    observations: &Observations,
    unscented: &Unscented,
) -> Result<Pass> {
    let n = model.state_count();
    let len = model.len();
    check_sizes("unscented filter", model, &initial, noise, observations)?;
    let mut pass = Pass::with_capacity(len, model.output_count());
    let mut state = initial.mean;
    let mut covariance = initial.covariance;
    for k in 0..len {
        let t = model.time(k);
        if k > 0 {
            let previous = model.time(k - 1);
            let sigma = points(unscented, &state, &covariance).map_err(|e| at_time(e, previous))?;
            let moved = sigma
                .points
                .iter()
                .map(|point| model.step(k - 1, point.as_slice(), theta))
                .collect::<Result<Vec<_>>>()
                .map_err(|e| at_time(e, previous))?;
            let mean = sigma.mean_of(&moved);
            let cross = sigma.cross_covariance(&moved, &mean, &sigma.points, &state);
            let transition = match loaded(&covariance) {
                Some((_, c)) => c.solve(&cross.transpose()).transpose(),
                None => DMatrix::from_element(n, n, f64::NAN),
            };
            let spread = sigma.cross_covariance(&moved, &mean, &moved, &mean);
            let process = if transition.iter().all(|v| v.is_finite()) {
                (&noise.process + &transition * &noise.process * transition.transpose())
                    * (0.5 * (t - previous))
            } else {
                &noise.process * (t - previous)
            };
            covariance = symmetric(spread + process);
            state = mean;
            pass.transitions.push(transition);
        }
        pass.predicted.push(Gaussian {
            mean: state.clone(),
            covariance: covariance.clone(),
        });
        let present = &observations.at[k];
        if present.is_empty() {
            pass.measured.push(None);
        } else {
            let measured = measurement_update(
                model,
                theta,
                unscented,
                (t, present),
                noise,
                &mut state,
                &mut covariance,
            )
            .map_err(|e| at_time(e, t))?;
            pass.measured_at(k, present, measured);
        }
        pass.filtered_at(t, &state, &covariance)?;
    }
    Ok(pass)
}

/// The unscented measurement update of (x, P) with the outputs `present`
/// measured at t (module header).
fn measurement_update<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    unscented: &Unscented,
    (t, present): (f64, &[(usize, f64)]),
    noise: &Noise,
    state: &mut DVector<f64>,
    covariance: &mut DMatrix<f64>,
) -> Result<Measured> {
    let sigma = points(unscented, state, covariance)?;
    let outputs = sigma
        .points
        .iter()
        .map(|point| {
            let y = model.outputs(t, point.as_slice(), theta)?;
            Ok(DVector::from_iterator(
                present.len(),
                present.iter().map(|&(o, _)| y[o]),
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    let predicted = sigma.mean_of(&outputs);
    let measurement = DMatrix::from_diagonal(&DVector::from_iterator(
        present.len(),
        present.iter().map(|&(o, _)| noise.measurement[o]),
    ));
    let s = symmetric(
        sigma.cross_covariance(&outputs, &predicted, &outputs, &predicted) + &measurement,
    );
    let cross = sigma.cross_covariance(&sigma.points, state, &outputs, &predicted);
    let inverse = Cholesky::new(s.clone())
        .ok_or_else(|| {
            Error::Other(
                "the innovation covariance is not positive definite (a measurement noise variance of zero, or a covariance gone non-finite)".into(),
            )
        })?
        .inverse();
    let observation = match loaded(covariance) {
        Some((_, c)) => c.solve(&cross).transpose(),
        None => DMatrix::from_element(present.len(), state.len(), f64::NAN),
    };
    let gain = &cross * &inverse;
    let innovation = DVector::from_iterator(
        present.len(),
        present
            .iter()
            .zip(predicted.iter())
            .map(|(&(_, z), y)| z - y),
    );
    *state += &gain * &innovation;
    // Joseph's form with the statistical H (module header): positive
    // semi-definite by construction, where P⁻ − K·S·Kᵀ loses definiteness
    // to rounding once R is small against P⁻.
    let n = state.len();
    let reduce = DMatrix::identity(n, n) - &gain * &observation;
    *covariance = symmetric(
        &reduce * &*covariance * reduce.transpose() + &gain * &measurement * gain.transpose(),
    );
    Ok(Measured {
        observation,
        update: Update {
            innovation,
            innovation_covariance: s,
            innovation_inverse: inverse,
            gain,
        },
    })
}

/// Relative diagonal loads tried, in turn, on a covariance that rounding
/// has left short of positive definite (correlations within 10⁻¹⁶ of ±1
/// once R is small): a spread below 10⁻⁴ of each state's σ.
const LOADS: [f64; 4] = [0.0, 1e-12, 1e-10, 1e-8];

/// P + ε·diag(P) for the first ε of [`LOADS`] whose Cholesky factor
/// exists, with the factor; None when none does.
fn loaded(covariance: &DMatrix<f64>) -> Option<(DMatrix<f64>, Cholesky<f64, nalgebra::Dyn>)> {
    LOADS.iter().find_map(|&epsilon| {
        let matrix = covariance + DMatrix::from_diagonal(&(covariance.diagonal() * epsilon));
        Cholesky::new(matrix.clone()).map(|c| (matrix, c))
    })
}

/// The sigma points of (x̄, P), P loaded as [`loaded`] does when needed.
fn points(
    unscented: &Unscented,
    mean: &DVector<f64>,
    covariance: &DMatrix<f64>,
) -> Result<SigmaPoints> {
    match loaded(covariance) {
        Some((matrix, _)) => unscented.points(mean, &matrix),
        None => unscented.points(mean, covariance),
    }
}

fn symmetric(m: DMatrix<f64>) -> DMatrix<f64> {
    (&m + m.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::model::linear::LinearStateSpace;
    use crate::estimation::solver::extended_kalman;

    /// On a linear model the unscented transform is exact: the unscented
    /// pass is the (extended = linear) Kalman filter's, to rounding without
    /// process noise (a damped oscillator and a slow mode, two of three
    /// states measured, a dropout every fifth point). With process noise
    /// the unscented pass takes Q_d by the trapezoidal rule and the
    /// extended one exactly (Van Loan): the rule's relative error is about
    /// h²·‖2A‖²/12 ≈ 2e-3 at h = 0.01 (‖A‖ ≈ 8), the tolerance 5e-3.
    #[test]
    fn on_a_linear_model_it_is_the_kalman_filter() {
        let a = DMatrix::from_row_slice(3, 3, &[-1.2, 1.0, 0.0, -8.0, -2.1, 0.3, 0.0, 0.5, -0.05]);
        for (process, step, tolerance) in [(0.0, 0.05, 1e-10), (0.2, 0.01, 5e-3)] {
            let len = (10.0 / step) as usize;
            let model = LinearStateSpace::new(
                [
                    a.clone(),
                    DMatrix::zeros(3, 1),
                    DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
                    DMatrix::zeros(2, 1),
                ],
                Vec::new(),
                0.0,
                step,
                vec![DVector::zeros(1); len],
            )
            .unwrap();
            let at = (0..len)
                .map(|k| {
                    let t = k as f64 * step;
                    let mut here = vec![(0, (3.0 * t).sin() * 0.1)];
                    if k % 5 != 4 {
                        here.push((1, (0.7 * t).cos() * 0.05));
                    }
                    here
                })
                .collect();
            let observations = Observations {
                names: vec!["a".into(), "b".into()],
                at,
                moved: 0,
            };
            let initial = Gaussian {
                mean: DVector::from_vec(vec![0.05, -0.1, 0.02]),
                covariance: DMatrix::identity(3, 3) * 0.3,
            };
            let noise = Noise {
                process: DMatrix::identity(3, 3) * process,
                measurement: DVector::from_vec(vec![1e-3, 4e-4]),
            };
            let unscented = filter(
                &model,
                &[],
                initial.clone(),
                &noise,
                &observations,
                &Unscented::default(),
            )
            .unwrap();
            let extended =
                extended_kalman::filter(&model, &[], initial.clone(), &noise, &observations)
                    .unwrap();
            for (u, e) in unscented.filtered.iter().zip(&extended.filtered) {
                let error = (&u.mean - &e.mean).norm() / e.mean.norm().max(1e-3);
                assert!(error < tolerance, "Q {process}: mean {error:e}");
                let error = (&u.covariance - &e.covariance).norm() / e.covariance.norm();
                assert!(error < tolerance, "Q {process}: covariance {error:e}");
            }
            let error = (unscented.negative_log_likelihood - extended.negative_log_likelihood)
                .abs()
                / extended.negative_log_likelihood.abs();
            assert!(error < tolerance, "−ln L {error:e}");
        }
    }
}
