//! One pass of the square-root unscented Kalman filter with additive noise
//! over any state-space model ([`StateSpaceModel`]) and a record's
//! observations on its grid (R. van der Merwe & E. A. Wan, "The
//! square-root unscented Kalman filter for state and parameter
//! estimation", ICASSP 2001, Algorithm 3.1; the unscented transform of
//! Wan & van der Merwe, "The unscented Kalman filter for nonlinear
//! estimation", IEEE AS-SPCC 2000, Eq. 15, and Julier & Uhlmann, SPIE
//! 3068, 1997). The same [`Pass`] as the extended filter's
//! ([`super::extended_kalman`]), so that methods, smoothers and
//! likelihoods take either.
//!
//! The filter carries the mean x and a lower-triangular Cholesky factor S
//! of the covariance, P = S·Sᵀ, never P itself: every covariance it forms
//! is a product S·Sᵀ, positive semi-definite by construction. Weights and
//! the scale c = √(n + λ) are the scaled transform's ([`Unscented::points`]):
//! χ₀ = x, χ_i = x + c·s_i, χ_{n+i} = x − c·s_i (s_i the columns of S),
//! W_i = 1/(2c²) for i ≥ 1, W₀ᵐ = λ/c², W₀ᶜ = W₀ᵐ + 1 − α² + β.
//!
//! Algorithm 3.1: S₀ = chol(P₀). Time update (`time_update`): the sigma
//! points through the model's step, x⁻ = Σ Wᵐ_i·χ'_i,
//! S⁻ = qr([√W₁·(χ'_{1…2n} − x⁻), √Q_d])ᵀ, then
//! S⁻ = cholupdate(S⁻, χ'₀ − x⁻, W₀ᶜ); Q_d = (Q_c + Φ·Q_c·Φᵀ)·h/2 by the
//! trapezoidal rule, Φ the statistical linearisation P_{x'x}·P⁺⁻¹, a
//! central difference of the sigma points. Measurement update
//! (`measurement_update`): Y_i = h(t_k, χ_i), ŷ = Σ Wᵐ_i·Y_i,
//! S_y = qr([√W₁·(Y_{1…2n} − ŷ), √R])ᵀ updated by Y₀ − ŷ,
//! K = (P_xy/S_yᵀ)/S_y, x⁺ = x⁻ + K·(z − ŷ), S⁺ = cholupdate(S⁻, K·S_y, −1).
//! A downdate that would leave a factor not positive definite is an
//! [`aeroid_numerics::Error::Downdate`] naming the step and time, never a
//! repaired factor. The pass keeps the statistical H = P_xyᵀ·P⁻⁻¹ and the innovation
//! covariance S_y·S_yᵀ.
//!
//! On a linear model the transform is exact and the pass is the linear
//! Kalman filter's with the trapezoidal Q_d (tests/estimators/kalman_oracle.rs).
//! No step allocates (`Work`; tests/no_allocation.rs). The user reference
//! is docs/methods.md, "Augmented-state unscented Kalman filter".

use crate::error::{Error, Result};
use crate::model::observations::Observations;
use crate::model::state_space::{Points, StateSpaceModel};
use crate::solver::extended_kalman::Innovation;
use crate::solver::extended_kalman::{Noise, Pass, at_time, check_sizes};
use aeroid_numerics::kalman::{
    Gaussian, Unscented, UpdateWorkspace, multiply, resize, resize_vector,
};
use nalgebra::{Cholesky, DMatrix, DVector};

mod factors;

use factors::{
    central_difference_into, cholupdate, covariance_into, multiply_lower, process_root,
    solve_right_lower, triangularise, weighted_mean, zeroth_point,
};

/// Runs the unscented filter from `initial` at grid point 0 with the
/// parameters `theta` (a model's own; none for an augmented model) and the
/// sigma-point scaling `unscented`. An error names the time where the
/// model departs or a covariance factor breaks down.
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
    let weights = Weights::of(unscented, n)?;
    let process = process_root(&noise.process)?;
    let mut work = Work::new(n, process.ncols(), model.output_count());
    let mut pass = Pass::with_capacity(len, model.output_count());
    let mut state = initial.mean;
    let mut factor = Cholesky::new(initial.covariance)
        .ok_or_else(|| Error::Numerical {
            reason: "the UKF's initial covariance is not positive definite".into(),
        })?
        .unpack();
    for k in 0..len {
        let t = model.time(k);
        if k > 0 {
            let previous = model.time(k - 1);
            time_update(
                model,
                theta,
                (k, previous, t - previous),
                &weights,
                &process,
                &mut state,
                &mut factor,
                &mut work,
            )?;
            pass.transitions.push(&work.transition);
        }
        covariance_into(&factor, &mut work.covariance);
        pass.predicted.push_parts(&state, Some(&work.covariance));
        let present = &observations.at[k];
        if present.is_empty() {
            pass.measured.push(None);
        } else {
            measurement_update(
                model,
                theta,
                &weights,
                (t, present),
                noise,
                &mut state,
                &mut factor,
                &mut work,
            )?;
            keep_update(&mut pass, k, present, &work);
            covariance_into(&factor, &mut work.covariance);
        }
        pass.filtered_at(t, &state, Some(&work.covariance))?;
    }
    Ok(pass)
}

/// Keeps the measurement update at grid point k of the outputs `present`
/// (in its rows' order) from the buffers it was made in: its likelihood
/// term, each output's innovation and H, ν, S, S⁻¹ and K.
fn keep_update(pass: &mut Pass, k: usize, present: &[(usize, f64)], work: &Work) {
    let update = &work.update;
    let innovation = &work.innovation;
    pass.negative_log_likelihood += 0.5 * update.log_likelihood_term(innovation);
    for (i, &(o, _)) in present.iter().enumerate() {
        pass.innovations[o].push(Innovation {
            k,
            value: innovation[i],
            variance: update.innovation_covariance[(i, i)],
        });
    }
    pass.measured.push_update(
        &work.observation,
        innovation,
        &update.innovation_covariance,
        &update.innovation_inverse,
        &update.gain,
    );
}

/// The sigma points' scale and weights (module header).
struct Weights {
    /// c = √(n + λ).
    scale: f64,
    /// W₀ᵐ.
    mean_zero: f64,
    /// W₀ᶜ.
    covariance_zero: f64,
    /// W_i, i ≥ 1 (mean and covariance alike).
    other: f64,
}

impl Weights {
    /// The weights of `unscented`'s sigma points in n dimensions, read from
    /// its points of (0, I): χ₁ = c·e₁.
    fn of(unscented: &Unscented, n: usize) -> Result<Weights> {
        if n == 0 {
            return Err(Error::Shape {
                reason: "the UKF's model has no states".into(),
            });
        }
        let unit = unscented.points(&DVector::zeros(n), &DMatrix::identity(n, n))?;
        Ok(Weights {
            scale: unit.points[1][0],
            mean_zero: unit.mean_weights[0],
            covariance_zero: unit.covariance_weights[0],
            other: unit.mean_weights[1],
        })
    }
}

/// A pass's buffers, allocated once: sigma points, propagated points and
/// outputs as columns (2n + 1 of each), the time update's compound matrix
/// (its transpose, at most 2n + 2r rows of n), its second differences (n
/// rows of the p changing states), the leading rows of the central
/// difference Φ is solved from, Φ and Φ·G, the covariance S·Sᵀ, and the
/// measurement update's compound matrix (2n + m rows of at most m
/// columns) and its products. Matrices whose shape depends on p or m
/// keep their storage when it changes (`kalman::resize`): a pass
/// allocates nothing per grid point (tests/no_allocation.rs).
///
/// Every product of the measurement update (ŷ, S_y, H, P_xy, K, K·S_y, S,
/// S⁻¹, ν), Φ, Φ·G and S·Sᵀ lives here; what the pass keeps goes from
/// these into buffers reserved once per pass
/// ([`aeroid_numerics::kalman::kept`]). The products and triangular solves
/// are written for the shapes at hand (S lower triangular, a few rows), and
/// these kernels and the rank-one updates are compiled for AVX2 where the
/// CPU has it (`simd::wide`: the same numbers bit for bit).
struct Work {
    points: DMatrix<f64>,
    moved: DMatrix<f64>,
    outputs: DMatrix<f64>,
    compound: DMatrix<f64>,
    curvature: DMatrix<f64>,
    curvature_factor: DMatrix<f64>,
    leading: DMatrix<f64>,
    measured: DMatrix<f64>,
    vector: DVector<f64>,
    /// Every output of each sigma point (`outputs` holds the measured ones).
    all_outputs: DMatrix<f64>,
    /// Φ of the last time update (n × n).
    transition: DMatrix<f64>,
    /// Φ·G (n × r).
    moved_noise: DMatrix<f64>,
    /// S·Sᵀ of the last factor (n × n).
    covariance: DMatrix<f64>,
    /// ŷ (m).
    predicted: DVector<f64>,
    /// ν = z − ŷ (m).
    innovation: DVector<f64>,
    /// S_y (m × m, lower).
    innovation_factor: DMatrix<f64>,
    /// E = H·S⁻, then H (m × n).
    observation: DMatrix<f64>,
    /// Eᵀ (n × m).
    difference: DMatrix<f64>,
    /// P_xy = S⁻·Eᵀ (n × m).
    cross: DMatrix<f64>,
    /// P_xyᵀ solved for Kᵀ (m × n).
    solved: DMatrix<f64>,
    /// K·S_y (n × m).
    spread: DMatrix<f64>,
    /// S_y⁻¹ (m × m).
    inverse_factor: DMatrix<f64>,
    /// The transpose of S_y or of S_y⁻¹ (m × m).
    transposed: DMatrix<f64>,
    /// S = S_y·S_yᵀ, S⁻¹, K and ln det S of the last measurement update.
    update: UpdateWorkspace,
}

impl Work {
    fn new(n: usize, noise_columns: usize, outputs: usize) -> Work {
        let count = 2 * n + 1;
        let m = outputs;
        Work {
            points: DMatrix::zeros(n, count),
            moved: DMatrix::zeros(n, count),
            outputs: DMatrix::zeros(outputs, count),
            compound: DMatrix::zeros(2 * n + 2 * noise_columns, n),
            curvature: DMatrix::zeros(n, n),
            curvature_factor: DMatrix::zeros(n, n),
            leading: DMatrix::zeros(n, n),
            measured: DMatrix::zeros(2 * n + outputs, outputs),
            vector: DVector::zeros(n.max(outputs)),
            all_outputs: DMatrix::zeros(outputs, count),
            transition: DMatrix::zeros(n, n),
            moved_noise: DMatrix::zeros(n, noise_columns),
            covariance: DMatrix::zeros(n, n),
            predicted: DVector::zeros(m),
            innovation: DVector::zeros(m),
            innovation_factor: DMatrix::zeros(m, m),
            observation: DMatrix::zeros(m, n),
            difference: DMatrix::zeros(n, m),
            cross: DMatrix::zeros(n, m),
            solved: DMatrix::zeros(m, n),
            spread: DMatrix::zeros(n, m),
            inverse_factor: DMatrix::zeros(m, m),
            transposed: DMatrix::zeros(m, m),
            update: UpdateWorkspace::default(),
        }
    }

    /// Gives the measurement update's buffers the shape of m measured
    /// outputs over n states.
    fn measuring(&mut self, n: usize, m: usize) {
        resize_vector(&mut self.predicted, m);
        resize_vector(&mut self.innovation, m);
        for matrix in [
            &mut self.innovation_factor,
            &mut self.inverse_factor,
            &mut self.transposed,
            &mut self.update.innovation_covariance,
            &mut self.update.innovation_inverse,
        ] {
            resize(matrix, m, m);
        }
        for matrix in [&mut self.observation, &mut self.solved] {
            resize(matrix, m, n);
        }
        for matrix in [
            &mut self.difference,
            &mut self.cross,
            &mut self.spread,
            &mut self.update.gain,
        ] {
            resize(matrix, n, m);
        }
    }

    /// The sigma points of (x, S) into `points`.
    fn draw(&mut self, weights: &Weights, mean: &DVector<f64>, factor: &DMatrix<f64>) {
        let n = mean.len();
        self.points.column_mut(0).copy_from(mean);
        for i in 0..n {
            for r in 0..n {
                let d = weights.scale * factor[(r, i)];
                self.points[(r, 1 + i)] = mean[r] + d;
                self.points[(r, 1 + n + i)] = mean[r] - d;
            }
        }
    }

    /// The number p of leading states the step moved: every sigma point's
    /// states p… came through it unchanged (the constant parameters of an
    /// augmented model), so that Φ's rows p… are the identity's and the
    /// propagated spread's columns p… are S⁺'s own (`time_update`).
    fn moving(&self) -> usize {
        let n = self.points.nrows();
        let mut p = 0;
        for (before, after) in self
            .points
            .as_slice()
            .chunks_exact(n)
            .zip(self.moved.as_slice().chunks_exact(n))
        {
            // The last state this point moved, looked for above p only.
            if let Some(r) = (p..n).rev().find(|&r| before[r] != after[r]) {
                p = r + 1;
            }
        }
        p
    }
}

/// The time update from grid point k − 1 (at `previous`, a step h before
/// k) to k, in place; the statistical transition Φ into `work.transition`.
///
/// Sigma points of (x⁺, S⁺), each propagated by the model's own
/// integration step, χ'_i = step(χ_i) (all in one call,
/// [`StateSpaceModel::step_points_into`]); x⁻ = Σ Wᵐ_i·χ'_i;
/// S⁻ = qr([√W₁·(χ'_{1…2n} − x⁻), √Q_d])ᵀ, the triangular factor of the QR
/// decomposition of the compound matrix's transpose (a Householder
/// triangularisation in place, `triangularise`); then
/// S⁻ = cholupdate(S⁻, χ'₀ − x⁻, W₀ᶜ), an update when W₀ᶜ ≥ 0 and a
/// downdate when W₀ᶜ < 0 (with κ = 0, W₀ᶜ = 2 + β − α² − 1/α²: at β = 2
/// negative for α below 0.52, −0.25 at the method's default α = 0.5).
///
/// The process noise Q_d = ∫₀ʰ e^{A·s}·Q_c·e^{Aᵀ·s} ds is taken by the
/// trapezoidal rule (Q_c + Φ·Q_c·Φᵀ)·h/2 (the UKF has no Jacobian), within
/// O(h³) of the extended filter's Van Loan Q_d; its square root enters the
/// compound matrix as the columns √(h/2)·[G, Φ·G] with G·Gᵀ = Q_c. Φ is the
/// statistical linearisation P_{x'x}·P⁺⁻¹ with
/// P_{x'x} = Σ Wᶜ_i·(χ'_i − x⁻)(χ_i − x⁺)ᵀ; with these sigma points it is
/// the central difference Φ·S⁺ = (χ'_{1…n} − χ'_{n+1…2n})/(2c), one
/// triangular solve, and it is the pass's transition (with it the RTS
/// smoother's gain is the unscented RTS smoother's, P_{xx'}·P⁻⁻¹).
///
/// The compound matrix is taken in an equivalent form with fewer rows. Its
/// rows for χ'_{1+i} and χ'_{1+n+i}, rotated together by 45° (an
/// orthogonal change, so the same S⁻), are the central difference
/// d_i = (χ'_{1+i} − χ'_{1+n+i})/(2c), column i of Φ·S⁺, and the second
/// difference e_i = (χ'_{1+i} + χ'_{1+n+i} − 2x⁻)/(2c). States the step
/// leaves unchanged in every sigma point (the constant parameters of an
/// augmented model, the states p… of n; `Work::moving`) have d_i = s_i
/// (their rows of S⁺ itself), e_i = 0 and rows of Φ the identity's: Φ's
/// other p rows are one triangular solve, and the n second differences,
/// non-zero in p columns only, enter as the p rows of their own triangular
/// factor, so the QR works on n + p (+ noise) rows instead of 2n. The
/// result is the algorithm's to rounding.
#[allow(clippy::too_many_arguments)]
// A time update at every grid point of the pass: the sigma points' step, mean, compound QR and Φ share the pass's work buffers; split, each step would take them all.
fn time_update<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    (k, previous, h): (usize, f64, f64),
    weights: &Weights,
    process: &DMatrix<f64>,
    state: &mut DVector<f64>,
    factor: &mut DMatrix<f64>,
    work: &mut Work,
) -> Result<()> {
    let n = state.len();
    work.draw(weights, state, factor);
    model
        .step_points_into(
            k - 1,
            Points::shared(&work.points, theta),
            work.moved.as_mut_slice(),
            n,
        )
        .map_err(|e| at_time(e, previous))?;
    weighted_mean(weights, &work.moved, state);
    let p = work.moving();
    // The compound matrix's rows i and n + i (the points χ_{1+i} and
    // χ_{1+n+i}) rotated by 45°, an orthogonal change that leaves its Gram
    // matrix alone: √W₁·(χ'_{1+i} − χ'_{1+n+i})/√2, the central difference
    // D = (χ'_{1+i} − χ'_{1+n+i})/(2c), and √W₁·(χ'_{1+i} + χ'_{1+n+i} −
    // 2x⁻)/√2, the second difference. In the unchanged states p… D is
    // S⁺'s own row (2c·s_i/(2c)) and the second difference nothing.
    let root = weights.other.sqrt() * std::f64::consts::FRAC_1_SQRT_2;
    let compound = &mut work.compound;
    let ld = compound.nrows();
    resize(&mut work.curvature, n, p);
    // Column by column of the compound matrix (contiguous), the sigma
    // points' states i of their columns 1 + j and 1 + n + j.
    let moved = work.moved.as_slice();
    for i in 0..p {
        let column = &mut compound.as_mut_slice()[i * ld..i * ld + n];
        let curvature = &mut work.curvature.as_mut_slice()[i * n..(i + 1) * n];
        let mean = state[i];
        for (j, (c, e)) in column.iter_mut().zip(curvature).enumerate() {
            let (plus, minus) = (moved[(1 + j) * n + i], moved[(1 + n + j) * n + i]);
            *c = root * (plus - minus);
            *e = root * ((plus - mean) + (minus - mean));
        }
    }
    let s = factor.as_slice();
    for i in p..n {
        let column = &mut compound.as_mut_slice()[i * ld..i * ld + n];
        for (j, c) in column.iter_mut().enumerate() {
            *c = s[j * n + i];
        }
    }
    // Φ·S⁺ = D, Sᵀ·Φᵀ = Dᵀ, for the rows 0…p; the rows p… are the identity's.
    resize(&mut work.leading, p, n);
    let half = 0.5 / weights.scale;
    for j in 0..n {
        for i in 0..p {
            work.leading[(i, j)] = half * (work.moved[(i, 1 + j)] - work.moved[(i, 1 + n + j)]);
        }
    }
    let transition = &mut work.transition;
    transition.fill_with_identity();
    if solve_right_lower(factor, &mut work.leading) && work.leading.iter().all(|v| v.is_finite()) {
        transition.rows_mut(0, p).copy_from(&work.leading);
    } else {
        transition.fill(f64::NAN);
    }
    // The second differences' n rows of p non-zero columns as the p rows
    // of their triangular factor (the same Gram matrix).
    let mut rows = n;
    if p < n {
        resize(&mut work.curvature_factor, p, p);
        triangularise(&mut work.curvature, n, p, &mut work.curvature_factor);
        for i in 0..n {
            let column = &mut compound.as_mut_slice()[i * ld + rows..i * ld + rows + p];
            for (r, c) in column.iter_mut().enumerate() {
                *c = if i < p {
                    work.curvature_factor[(i, r)]
                } else {
                    0.0
                };
            }
        }
        rows += p;
    } else {
        for j in 0..n {
            for i in 0..n {
                compound[(rows + j, i)] = work.curvature[(j, i)];
            }
        }
        rows += n;
    }
    let r = process.ncols();
    if r > 0 {
        if transition[(0, 0)].is_finite() {
            let half = (0.5 * h).sqrt();
            let moved = &mut work.moved_noise;
            transition_times(transition, p, process, moved);
            for j in 0..r {
                for i in 0..n {
                    compound[(rows + j, i)] = half * process[(i, j)];
                    compound[(rows + r + j, i)] = half * moved[(i, j)];
                }
            }
            rows += 2 * r;
        } else {
            let whole = h.sqrt();
            for j in 0..r {
                for i in 0..n {
                    compound[(rows + j, i)] = whole * process[(i, j)];
                }
            }
            rows += r;
        }
    }
    triangularise(compound, rows, n, factor);
    let zero = &mut work.vector;
    for i in 0..n {
        zero[i] = work.moved[(i, 0)] - state[i];
    }
    Ok(zeroth_point(
        factor,
        &mut zero.as_mut_slice()[..n],
        weights.covariance_zero,
    )
    .map_err(|()| aeroid_numerics::Error::Downdate {
        time: previous,
        step: "time update's zeroth sigma point (W₀ᶜ < 0)",
    })?)
}

/// Φ·G into `into` (n × r) for a Φ whose rows p… are the identity's:
/// column j is Σ_k G_kj·Φ_{·k} over G's non-zeros, its rows p… G's own.
/// For a diagonal Q_c (one non-zero per column of G) every element is a
/// single product, the same as any order of summation gives.
fn transition_times(
    transition: &DMatrix<f64>,
    p: usize,
    process: &DMatrix<f64>,
    into: &mut DMatrix<f64>,
) {
    let n = transition.nrows();
    into.copy_from(process);
    for j in 0..process.ncols() {
        let column = &mut into.as_mut_slice()[j * n..j * n + p];
        column.fill(0.0);
        for k in 0..n {
            let g = process[(k, j)];
            if g != 0.0 {
                let source = &transition.as_slice()[k * n..k * n + p];
                for (c, &f) in column.iter_mut().zip(source) {
                    *c += f * g;
                }
            }
        }
    }
}

/// The measurement update of (x, S) with the outputs `present` measured at
/// t, in place; H, ν, S, S⁻¹ and K into `work`.
///
/// Sigma points of (x⁻, S⁻) (redrawn: the additive-noise form),
/// Y_i = h(t_k, χ_i) (rows of the measured outputs, all in one call,
/// [`StateSpaceModel::outputs_points_into`]), ŷ = Σ Wᵐ_i·Y_i,
/// S_y = qr([√W₁·(Y_{1…2n} − ŷ), √R])ᵀ and
/// S_y = cholupdate(S_y, Y₀ − ŷ, W₀ᶜ); P_xy = Σ Wᶜ_i·(χ_i − x⁻)(Y_i − ŷ)ᵀ
/// = S⁻·(Y_{1…n} − Y_{n+1…2n})ᵀ/(2c); the gain by two triangular solves,
/// K = (P_xy/S_yᵀ)/S_y; x⁺ = x⁻ + K·(z − ŷ); U = K·S_y and
/// S⁺ = cholupdate(S⁻, U, −1), one downdate per column of U. A downdate
/// that would leave a factor without a positive diagonal is an
/// [`aeroid_numerics::Error::Downdate`]. The statistical H = P_xyᵀ·P⁻⁻¹ is again a central
/// difference, H·S⁻ = (Y_{1…n} − Y_{n+1…2n})/(2c).
#[allow(clippy::too_many_arguments)]
// A measurement update at every measured grid point: the output points, S_y, the gain and the downdates share the pass's work buffers; split, each step would take them all.
fn measurement_update<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    weights: &Weights,
    (t, present): (f64, &[(usize, f64)]),
    noise: &Noise,
    state: &mut DVector<f64>,
    factor: &mut DMatrix<f64>,
    work: &mut Work,
) -> Result<()> {
    let n = state.len();
    let m = present.len();
    work.measuring(n, m);
    work.draw(weights, state, factor);
    let all = work.all_outputs.nrows();
    model
        .outputs_points_into(
            t,
            Points::shared(&work.points, theta),
            work.all_outputs.as_mut_slice(),
            all,
        )
        .map_err(|e| at_time(e, t))?;
    for j in 0..2 * n + 1 {
        for (row, &(o, _)) in present.iter().enumerate() {
            work.outputs[(row, j)] = work.all_outputs[(o, j)];
        }
    }
    let outputs = work.outputs.rows(0, m);
    let predicted = &mut work.predicted;
    predicted.fill(0.0);
    for j in 0..2 * n + 1 {
        let w = if j == 0 {
            weights.mean_zero
        } else {
            weights.other
        };
        predicted.axpy(w, &outputs.column(j), 1.0);
    }
    let root = weights.other.sqrt();
    let compound = &mut work.measured;
    for j in 0..2 * n {
        for i in 0..m {
            compound[(j, i)] = root * (outputs[(i, 1 + j)] - predicted[i]);
        }
    }
    for (row, &(o, _)) in present.iter().enumerate() {
        for i in 0..m {
            compound[(2 * n + row, i)] = 0.0;
        }
        compound[(2 * n + row, row)] = noise.measurement[o].max(0.0).sqrt();
    }
    let innovation_factor = &mut work.innovation_factor;
    triangularise(compound, 2 * n + m, m, innovation_factor);
    let zero = &mut work.vector.as_mut_slice()[..m];
    for (i, z) in zero.iter_mut().enumerate() {
        *z = outputs[(i, 0)] - predicted[i];
    }
    zeroth_point(innovation_factor, zero, weights.covariance_zero).map_err(|()| {
        aeroid_numerics::Error::Downdate {
            time: t,
            step: "innovation covariance's zeroth sigma point (W₀ᶜ < 0)",
        }
    })?;
    // E = (Y_{1…n} − Y_{n+1…2n})/(2c): P_xy = S⁻·Eᵀ and H·S⁻ = E.
    central_difference_into(&outputs, n, weights.scale, &mut work.observation);
    work.observation.transpose_to(&mut work.difference);
    multiply_lower(factor, &work.difference, &mut work.cross);
    let singular = || {
        Error::Numerical { reason: "the innovation covariance is not positive definite (a measurement noise variance of zero, or a covariance gone non-finite)".into(), }
    };
    if !(0..m).all(|i| {
        let d = innovation_factor[(i, i)];
        d > 0.0 && d.is_finite()
    }) {
        return Err(at_time(singular(), t));
    }
    // K·S_y·S_yᵀ = P_xy: S_y·Z = P_xyᵀ, then S_yᵀ·Kᵀ = Z.
    let solved = &mut work.solved;
    work.cross.transpose_to(solved);
    if !(innovation_factor.solve_lower_triangular_mut(solved)
        && innovation_factor.tr_solve_lower_triangular_mut(solved))
    {
        return Err(at_time(singular(), t));
    }
    let update = &mut work.update;
    solved.transpose_to(&mut update.gain);
    if !solve_right_lower(factor, &mut work.observation) {
        work.observation.fill(f64::NAN);
    }
    let innovation = &mut work.innovation;
    for (i, &(_, z)) in present.iter().enumerate() {
        innovation[i] = z - predicted[i];
    }
    state.gemv(1.0, &update.gain, innovation, 1.0);
    multiply(&update.gain, innovation_factor, &mut work.spread);
    let column = &mut work.vector;
    for j in 0..m {
        column.rows_mut(0, n).copy_from(&work.spread.column(j));
        cholupdate(factor, &mut column.as_mut_slice()[..n], -1.0).map_err(|()| {
            aeroid_numerics::Error::Downdate {
                time: t,
                step: "measurement update (S⁺ = cholupdate(S⁻, K·S_y, −1))",
            }
        })?;
    }
    let inverse_factor = &mut work.inverse_factor;
    inverse_factor.fill_with_identity();
    if !innovation_factor.solve_lower_triangular_mut(inverse_factor) {
        return Err(at_time(singular(), t));
    }
    let transposed = &mut work.transposed;
    innovation_factor.transpose_to(transposed);
    multiply(
        innovation_factor,
        transposed,
        &mut update.innovation_covariance,
    );
    inverse_factor.transpose_to(transposed);
    multiply(transposed, inverse_factor, &mut update.innovation_inverse);
    // ln det S = 2·Σ ln of S_y's diagonal.
    update.log_determinant = 2.0 * (0..m).map(|i| innovation_factor[(i, i)].ln()).sum::<f64>();
    Ok(())
}

#[cfg(test)]
mod tests;
