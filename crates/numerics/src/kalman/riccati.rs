//! The steady-state gain of a time-invariant system (the filter error
//! method's, Jategaonkar, "Flight Vehicle System Identification", 2nd ed.,
//! §5.3, Eq. 5.23): the predicted covariance P solving the discrete
//! algebraic Riccati equation
//! P = Φ·(P − P·Hᵀ·(H·P·Hᵀ + R)⁻¹·H·P)·Φᵀ + Q_d, by the structured
//! doubling algorithm (Chu, Fan & Lin, "A structure-preserving doubling
//! algorithm for discrete-time algebraic Riccati equations", Linear
//! Algebra Appl. 396, 2005, Eq. 2.5), quadratically convergent; and the
//! one for a given innovation covariance by Newton's method from it.

use crate::error::{Error, Result};
use nalgebra::{Cholesky, DMatrix, DVector};

/// The steady state of a time-invariant filter.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyState {
    /// The predicted covariance P solving the Riccati equation.
    pub covariance: DMatrix<f64>,
    /// K = P·Hᵀ·S⁻¹.
    pub gain: DMatrix<f64>,
    /// S = H·P·Hᵀ + R.
    pub innovation_covariance: DMatrix<f64>,
}

/// Doubling iterations before the Riccati solution is declared not found.
const DOUBLING_LIMIT: usize = 60;

/// The steady-state predicted covariance and gain of
/// x_{k+1} = Φ·x_k + w (Q_d), z = H·x + v (R), by the structured doubling
/// algorithm (module header). An error when it does not converge (Φ not
/// detectable through H, or a singular step).
pub fn steady_state(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    process_noise: &DMatrix<f64>,
    noise: &DMatrix<f64>,
) -> Result<SteadyState> {
    let n = transition.nrows();
    let noise_inverse = Cholesky::new(noise.clone())
        .ok_or_else(|| Error::NotPositiveDefinite {
            what: "the measurement noise covariance R".into(),
            why: "",
        })?
        .inverse();
    let identity = DMatrix::<f64>::identity(n, n);
    // The DARE X = AᵀXA − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q with A = Φᵀ, B = Hᵀ.
    let mut a = transition.transpose();
    let mut g = observation.transpose() * &noise_inverse * observation;
    let mut x = process_noise.clone();
    for _ in 0..DOUBLING_LIMIT {
        let w = &identity + &g * &x;
        let lu = w.lu();
        let solve = |m: &DMatrix<f64>| lu.solve(m);
        let (Some(wa), Some(wg)) = (solve(&a), solve(&g)) else {
            return Err(Error::Singular {
                reason: "the Riccati equation's doubling met a singular matrix".into(),
            });
        };
        let next_x = &x + a.transpose() * &x * &wa;
        let next_g = &g + &a * wg * a.transpose();
        let next_a = &a * wa;
        let change = (&next_x - &x).norm();
        x = (&next_x + next_x.transpose()) * 0.5;
        g = (&next_g + next_g.transpose()) * 0.5;
        a = next_a;
        if !x.iter().all(|v| v.is_finite()) {
            break;
        }
        if change <= 1e-14 * x.norm().max(f64::MIN_POSITIVE) {
            let s = observation * &x * observation.transpose() + noise;
            let s_inverse = Cholesky::new(s.clone())
                .ok_or_else(|| Error::NotPositiveDefinite {
                    what: "the steady-state innovation covariance".into(),
                    why: "",
                })?
                .inverse();
            let gain = &x * observation.transpose() * s_inverse;
            let closed_loop = transition * (&identity - &gain * observation);
            if !is_stable(closed_loop) {
                break;
            }
            return Ok(SteadyState {
                covariance: x,
                gain,
                innovation_covariance: s,
            });
        }
    }
    Err(Error::NoSolution { reason: "the steady-state Riccati equation has no solution: the system is not detectable through the outputs, or not stabilisable by the process noise".into() })
}

/// Newton iterations of [`steady_state_for_innovation`] before it gives up.
const NEWTON_LIMIT: usize = 50;

/// The steady state of a time-invariant filter whose innovation
/// covariance is given (the filter error method's R, Jategaonkar §5.3,
/// where R is estimated from the innovations and the measurement noise is
/// what is left of it, G·Gᵀ = R − H·P·Hᵀ, Eq. 5.13): the predicted
/// covariance P solving P = Φ·(P − P·Hᵀ·S⁻¹·H·P)·Φᵀ + Q_d, the gain
/// K = P·Hᵀ·S⁻¹, and the measurement noise V = S − H·P·Hᵀ it implies.
/// This P is the steady state of the ordinary filter ([`steady_state`])
/// with measurement noise V, whose innovation covariance is then S.
///
/// Solved by Newton's method on the matrix equation, from the steady state
/// with measurement noise S (whose P bounds the solution from above): the
/// derivative in the direction X is Φ·(L·X·Lᵀ − M·X·Mᵀ)·Φᵀ − X with
/// M = K·H and L = I − M, solved as an n²-dimensional linear system
/// (Kronecker form), until the equation's residual is below 10⁻¹³ of P.
/// An error when no such steady state exists: the iteration does not
/// converge, the filter is not stable, or V is not positive definite (an
/// eigenvalue of K·H at or above 1: process noise too large for S).
pub fn steady_state_for_innovation(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    process_noise: &DMatrix<f64>,
    innovation: &DMatrix<f64>,
) -> Result<(SteadyState, DMatrix<f64>)> {
    let n = transition.nrows();
    let innovation_inverse = Cholesky::new(innovation.clone())
        .ok_or_else(|| Error::NotPositiveDefinite {
            what: "the innovation covariance R".into(),
            why: "",
        })?
        .inverse();
    let weight = observation.transpose() * &innovation_inverse * observation;
    let identity = DMatrix::<f64>::identity(n, n);
    let residual_of = |p: &DMatrix<f64>| {
        transition * (p - p * &weight * p) * transition.transpose() + process_noise - p
    };
    let mut p = steady_state(transition, observation, process_noise, innovation)?.covariance;
    let mut residual = residual_of(&p);
    let mut converged = false;
    for _ in 0..NEWTON_LIMIT {
        if residual.norm() <= 1e-13 * p.norm().max(f64::MIN_POSITIVE) {
            converged = true;
            break;
        }
        let m = &p * &weight;
        let left = transition * (&identity - &m);
        let right = transition * &m;
        let jacobian = left.kronecker(&left)
            - right.kronecker(&right)
            - DMatrix::<f64>::identity(n * n, n * n);
        let rhs = DVector::from_column_slice((-&residual).as_slice());
        let Some(step) = jacobian.lu().solve(&rhs) else {
            break;
        };
        let step = DMatrix::from_column_slice(n, n, step.as_slice());
        let next = &p + (&step + step.transpose()) * 0.5;
        if !next.iter().all(|v| v.is_finite()) {
            break;
        }
        p = next;
        residual = residual_of(&p);
    }
    let refuse = |why: &str| {
        Err(Error::NoSolution {
            reason: format!("no steady-state filter has this innovation covariance: {why}"),
        })
    };
    if !converged {
        return refuse("the Riccati equation's Newton iteration did not converge");
    }
    let gain = &p * observation.transpose() * &innovation_inverse;
    let noise = innovation - observation * &p * observation.transpose();
    let noise = (&noise + noise.transpose()) * 0.5;
    if Cholesky::new(noise.clone()).is_none() {
        return refuse(
            "the measurement noise R − H·P·Hᵀ is not positive definite (K·H has an eigenvalue at or above 1)",
        );
    }
    if !is_stable(transition * (&identity - &gain * observation)) {
        return refuse("the filter it defines is not stable");
    }
    Ok((
        SteadyState {
            covariance: p,
            gain,
            innovation_covariance: innovation.clone(),
        },
        noise,
    ))
}

/// Whether every eigenvalue of a transition matrix lies inside the unit
/// circle: its 2³⁰th power (by squaring) vanishes.
fn is_stable(mut matrix: DMatrix<f64>) -> bool {
    for _ in 0..30 {
        matrix = &matrix * &matrix;
        let norm = matrix.norm();
        if !norm.is_finite() || norm > 1e100 {
            return false;
        }
    }
    matrix.norm() < 1e-6
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::discretise::discretise;
    use crate::kalman::predict::predict_covariance;
    use crate::kalman::testing::{assert_close, system};
    use crate::kalman::update::update;

    #[test]
    fn steady_state_solves_the_riccati_equation_and_is_the_filters_limit() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.04);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-4, 4e-4]));
        let s = steady_state(&d.transition, &h, &d.process_noise, &r).unwrap();
        let p = &s.covariance;
        let gain_term = p * h.transpose() * (&h * p * h.transpose() + &r).try_inverse().unwrap();
        let residual = &d.transition * (p - &gain_term * &h * p) * d.transition.transpose()
            + &d.process_noise
            - p;
        assert!(residual.norm() <= 1e-12 * p.norm(), "{residual}");
        // The time-varying filter's covariance converges to it.
        let mut state = DVector::zeros(3);
        let mut covariance = DMatrix::identity(3, 3);
        for _ in 0..3000 {
            covariance = predict_covariance(&covariance, &d.transition, &d.process_noise);
            let predicted = covariance.clone();
            update(&mut state, &mut covariance, &h, &r, DVector::zeros(2)).unwrap();
            if (&predicted - p).norm() < 1e-13 * p.norm() {
                break;
            }
        }
        let predicted = predict_covariance(&covariance, &d.transition, &d.process_noise);
        assert_close(&predicted, p, 1e-10, "limit of the filter");
    }

    /// The steady state with a given innovation covariance S: P solves
    /// its Riccati equation, and it is the ordinary steady state with the
    /// measurement noise it implies, whose innovation covariance is S (to
    /// 1e-10: the two solvers' tolerances, 1e-13 and 1e-14 of P, after
    /// rounding). An S smaller than the process noise allows is refused.
    #[test]
    fn steady_state_for_an_innovation_covariance_is_the_ordinary_one_with_its_noise() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.04);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let s = DMatrix::from_diagonal(&DVector::from_vec(vec![0.02, 4e-3]));
        let (steady, v) =
            steady_state_for_innovation(&d.transition, &h, &d.process_noise, &s).unwrap();
        let p = &steady.covariance;
        let weight = h.transpose() * s.clone().try_inverse().unwrap() * &h;
        let residual =
            &d.transition * (p - p * &weight * p) * d.transition.transpose() + &d.process_noise - p;
        assert!(residual.norm() <= 1e-12 * p.norm(), "{residual}");
        let ordinary = steady_state(&d.transition, &h, &d.process_noise, &v).unwrap();
        assert_close(&ordinary.covariance, p, 1e-10, "P");
        assert_close(&ordinary.innovation_covariance, &s, 1e-10, "S");
        assert_close(&ordinary.gain, &steady.gain, 1e-10, "K");
        let small = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-6, 1e-7]));
        assert!(steady_state_for_innovation(&d.transition, &h, &d.process_noise, &small).is_err());
    }

    #[test]
    fn steady_state_of_an_undetectable_system_is_refused() {
        // A growing mode that no output sees.
        let phi = DMatrix::from_row_slice(2, 2, &[1.1, 0.0, 0.0, 0.5]);
        let h = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2) * 0.1;
        let r = DMatrix::identity(1, 1) * 0.01;
        assert!(steady_state(&phi, &h, &q, &r).is_err());
    }
}
