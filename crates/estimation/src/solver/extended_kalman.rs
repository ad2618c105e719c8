//! One pass of the continuous–discrete extended Kalman filter over any
//! state-space model ([`StateSpaceModel`]) and a record's observations on
//! its grid ([`Observations`]): the filter the EKF, the EKF + smoother and
//! the filter error method run (Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., §7.2, Eqs. 7.11–7.19; Gelb, "Applied Optimal
//! Estimation", Table 6.1-1, continuous-discrete form).
//!
//! Time update from grid point k − 1 to k: the state by the model's own
//! integration step, x⁻_k = step(x⁺_{k−1}); the covariance by the
//! transition of the model linearised at (t_{k−1}, x⁺_{k−1}),
//! Φ = e^{A·h}, A = ∂f/∂x, P⁻_k = Φ·P⁺_{k−1}·Φᵀ + Q_d with Q_d the
//! discretised continuous process noise (Van Loan; [`kalman::discretise`]).
//! Measurement update at k with the outputs measured there: ŷ = h(t_k, x⁻_k),
//! H = ∂h/∂x at (t_k, x⁻_k) (rows of the measured outputs), R their noise
//! variances (diagonal), [`kalman::update`]; with [`Keep::sequential`] the
//! same update as one scalar update per measured output
//! ([`kalman::sequential_update_with`], Bierman 1977, ch. II), kept for the
//! modified Bryson–Frazier smoother's scalar form. For a linear model whose
//! step is exact ([`crate::model::linear`]) this is the linear
//! Kalman filter.
//!
//! The covariance's transition is exact (Van Loan) by default; with
//! [`Discretisation::SecondOrder`] it is the truncated series of Wang et
//! al. 2012, Eq. 11b, Φ = I + A·h + ½·(A·h)², and the process noise the
//! integral Q_d = ∫₀ʰ (I + A·s)·Q_c·(I + A·s)ᵀ ds
//! = Q_c·h + (A·Q_c + Q_c·Aᵀ)·h²/2 + A·Q_c·Aᵀ·h³/3 (the transition inside
//! the integral to first order: positive semi-definite, as the exact one),
//! a few products of n × n matrices instead of two exponentials of 2n × 2n
//! ones. Both agree to O(‖A·h‖³) relative; the state is always propagated
//! by the model's own step.
//!
//! The pass keeps what smoothers and likelihoods need: predicted and
//! filtered estimates, each update and each transition, the innovations
//! per output with their variances, and the negative log-likelihood
//! −ln L = ½·Σ_k (νᵀS⁻¹ν + ln det S) + const (Jategaonkar Eq. 5.16),
//! each kept quantity in one buffer reserved once per pass
//! ([`aeroid_numerics::kept`]); the predicted and filtered
//! covariances and the transitions it keeps are computed in their place
//! in those buffers ([`kalman::predict_covariance_from`],
//! [`kalman::update_from`]), not copied there. A step allocates nothing
//! once its buffers have grown.

use crate::error::{Error, Result};
use crate::model::observations::Observations;
use crate::model::state_space::{Jacobians, StateSpaceModel};
use aeroid_numerics::kalman::{self, Gaussian, SequentialWorkspace, UpdateWorkspace, resize};
use aeroid_numerics::kept::{Gaussians, Matrices, ScalarUpdates, SparseMatrices, Updates};
use nalgebra::{DMatrix, DVector};

mod discretisation;

pub use discretisation::Discretisation;
use discretisation::TimeUpdate;

/// The filter's noise: continuous process-noise spectral density over the
/// states (n × n; zero: none) and each output's measurement variance.
#[derive(Debug, Clone, PartialEq)]
pub struct Noise {
    pub process: DMatrix<f64>,
    pub measurement: DVector<f64>,
}

/// One innovation: grid point, ν and its predicted variance S_ii.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation {
    pub k: usize,
    pub value: f64,
    pub variance: f64,
}

/// What a pass keeps at every grid point beyond the filtered states, the
/// updates, the innovations and the likelihood: a caller that reads less
/// spares the copies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Keep {
    /// The predicted estimates (what a smoother reads).
    pub predicted: bool,
    /// The transitions (what a smoother and Mehra's tuning read).
    pub transitions: bool,
    /// The transitions by their entries, in [`Pass::sparse_transitions`]
    /// instead of [`Pass::transitions`] (what the smoothers read, a few
    /// hundred values a step where the dense Φ has n²).
    pub sparse_transitions: bool,
    /// The filtered covariance at every grid point (else at the last only).
    pub filtered_covariances: bool,
    /// The measurement update as a sequence of scalar updates, one per
    /// measured output ([`kalman::sequential_update_with`]), kept in
    /// [`Pass::scalar_updates`] instead of [`Pass::measured`] (what the
    /// modified Bryson–Frazier smoother reads; no S, S⁻¹ or K). The
    /// innovations are then the sequential ones: νᵢ against the estimate
    /// updated by the outputs before i, with its variance sᵢ.
    pub sequential: bool,
}

impl Keep {
    /// Everything.
    pub const ALL: Keep = Keep {
        predicted: true,
        transitions: true,
        sparse_transitions: false,
        filtered_covariances: true,
        sequential: false,
    };
    /// What a smoother reads: the predicted estimates and the transitions.
    pub const SMOOTHER: Keep = Keep {
        predicted: true,
        transitions: true,
        sparse_transitions: false,
        filtered_covariances: false,
        sequential: false,
    };
    /// What a smoother reads, the measurement updates as sequences of
    /// scalar updates ([`Keep::sequential`]) and the transitions by their
    /// entries ([`Keep::sparse_transitions`]).
    pub const SEQUENTIAL_SMOOTHER: Keep = Keep {
        sequential: true,
        transitions: false,
        sparse_transitions: true,
        ..Keep::SMOOTHER
    };
    /// Nothing beyond the filtered states, the updates, the innovations,
    /// the likelihood and the last covariance.
    pub const UPDATES: Keep = Keep {
        predicted: false,
        transitions: false,
        sparse_transitions: false,
        filtered_covariances: false,
        sequential: false,
    };
}

/// What one filter pass produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Pass {
    /// (x, P)_{k|k−1}; at k = 0 the initial estimate (empty unless
    /// [`Keep::predicted`]).
    pub predicted: Gaussians,
    /// (x, P)_{k|k}; without [`Keep::filtered_covariances`] the covariance
    /// is empty (0 × 0) but at the last grid point.
    pub filtered: Gaussians,
    /// The update at each grid point (None where nothing is measured;
    /// empty with [`Keep::sequential`]).
    pub measured: Updates,
    /// The scalar updates at each grid point (empty unless
    /// [`Keep::sequential`]).
    pub scalar_updates: ScalarUpdates,
    /// Φ from k to k + 1 (len − 1 of them; empty unless [`Keep::transitions`]).
    pub transitions: Matrices,
    /// The same by their entries (empty unless [`Keep::sparse_transitions`]).
    pub sparse_transitions: SparseMatrices,
    /// Per output, its innovations.
    pub innovations: Vec<Vec<Innovation>>,
    /// ½·Σ (νᵀS⁻¹ν + ln det S).
    pub negative_log_likelihood: f64,
}

/// Runs the filter from `initial` at grid point 0 with the parameters
/// `theta` (a model's own; none for an augmented model). An error names
/// the time where the model departs or a covariance breaks down.
pub fn filter<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: Gaussian,
    noise: &Noise,
    observations: &Observations,
) -> Result<Pass> {
    filter_with(
        model,
        theta,
        initial,
        noise,
        observations,
        Discretisation::Exact,
        Keep::ALL,
    )
}

/// [`filter`] with the covariance's transition and process noise
/// discretised as `discretisation` says, keeping what `keep` says.
// One pass over the grid: the time and measurement updates and what the pass keeps advance together in a dozen buffers; split, each step would take them all.
pub fn filter_with<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: Gaussian,
    noise: &Noise,
    observations: &Observations,
    discretisation: Discretisation,
    keep: Keep,
) -> Result<Pass> {
    let len = model.len();
    check_sizes("filter", model, &initial, noise, observations)?;
    let mut pass = Pass::keeping(len, model.output_count(), keep);
    let n = initial.mean.len();
    let mut state = initial.mean;
    // The filter's own covariance: the initial one, and every predicted
    // and filtered one that the pass does not keep. One the pass keeps is
    // computed in its place in the pass's buffers, and read from there.
    let mut covariance = initial.covariance;
    // Whether the last filtered covariance is the last one in
    // `pass.filtered` (else `covariance`).
    let mut filtered_kept = false;
    // Whether the predicted covariance is computed in `pass.predicted`:
    // where the vector update reads it (the sequential one updates
    // `covariance` in place, and the predicted one is copied).
    let predict_in_kept = keep.predicted && !keep.sequential;
    let process_noise = noise
        .process
        .iter()
        .any(|&v| v != 0.0)
        .then_some(&noise.process);
    let mut time_update = TimeUpdate::default();
    let mut update_workspace = UpdateWorkspace::default();
    let mut sequential_workspace = SequentialWorkspace::default();
    let mut variances = Vec::new();
    let mut linearised = Jacobians::empty();
    let mut predicted = DVector::zeros(0);
    let mut next = DVector::zeros(0);
    let mut innovation = DVector::zeros(0);
    let (mut h, mut r) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0));
    for k in 0..len {
        let t = model.time(k);
        // Whether the predicted covariance is the last one in
        // `pass.predicted` (else `covariance`).
        let mut predicted_kept = false;
        if k > 0 {
            let previous = model.time(k - 1);
            model.jacobians_into(previous, state.as_slice(), theta, &mut linearised, None)?;
            let kept_transition = keep
                .transitions
                .then(|| pass.transitions.push_for_writing(n, n));
            time_update.discretise_into(
                discretisation,
                &linearised.rates_by_state,
                process_noise,
                t - previous,
                kept_transition,
            );
            model
                .step_into(k - 1, state.as_slice(), theta, &mut next)
                .map_err(|e| at_time(e, previous))?;
            std::mem::swap(&mut state, &mut next);
            // P⁻ from P⁺ of k − 1, where each is (None: in place).
            let (from, into) = match (filtered_kept, predict_in_kept) {
                (false, false) => (None, covariance.as_mut_slice()),
                (true, false) => (
                    Some(last_covariance(&pass.filtered)),
                    covariance.as_mut_slice(),
                ),
                (_, true) => {
                    let from = if filtered_kept {
                        last_covariance(&pass.filtered)
                    } else {
                        covariance.as_slice()
                    };
                    let (mean, into) = pass.predicted.push_for_writing(n);
                    mean.copy_from_slice(state.as_slice());
                    predicted_kept = true;
                    (Some(from), into)
                }
            };
            kalman::predict_covariance_from(
                from,
                into,
                &time_update.sparse,
                process_noise
                    .filter(|_| !time_update.noise_on_plan)
                    .map(|_| &time_update.process_noise),
                &mut time_update.work,
            );
            time_update.add_process_noise_on_pattern(into, n);
            if keep.predicted && !predict_in_kept {
                pass.predicted.push_parts(&state, Some(&covariance));
            }
            if keep.sparse_transitions {
                pass.sparse_transitions.push(&time_update.sparse);
            }
        } else if keep.predicted {
            pass.predicted.push_parts(&state, Some(&covariance));
        }
        // Whether the filtered estimate went into `pass.filtered` with the
        // update.
        let mut filtered_pushed = false;
        let present = &observations.at[k];
        if present.is_empty() {
            if keep.sequential {
                pass.scalar_updates.push_none();
            } else {
                pass.measured.push(None);
            }
            if predicted_kept {
                covariance.copy_from_slice(last_covariance(&pass.predicted));
            }
        } else {
            model.jacobians_into(
                t,
                state.as_slice(),
                theta,
                &mut linearised,
                Some(&mut predicted),
            )?;
            // H's rows and R of the measured outputs, ν = z − ŷ.
            let m = present.len();
            resize(&mut h, m, n);
            if innovation.len() != m {
                innovation = DVector::zeros(m);
            }
            variances.clear();
            for (i, &(o, z)) in present.iter().enumerate() {
                for j in 0..n {
                    h[(i, j)] = linearised.outputs_by_state[(o, j)];
                }
                variances.push(noise.measurement[o]);
                innovation[i] = z - predicted[o];
            }
            if keep.sequential {
                let workspace = &mut sequential_workspace;
                kalman::sequential_update_with(
                    &mut state,
                    &mut covariance,
                    &h,
                    &variances,
                    &innovation,
                    workspace,
                )
                .map_err(|e| at_time((e).into(), t))?;
                pass.negative_log_likelihood += 0.5 * workspace.log_likelihood_term();
                for (i, &(o, _)) in present.iter().enumerate() {
                    pass.innovations[o].push(Innovation {
                        k,
                        value: workspace.innovations[i],
                        variance: workspace.variances[i],
                    });
                }
                pass.scalar_updates.push_sequence(
                    workspace.observation(),
                    &workspace.gains,
                    &workspace.innovations,
                    &workspace.variances,
                );
            } else {
                resize(&mut r, m, m);
                r.fill(0.0);
                for (i, &variance) in variances.iter().enumerate() {
                    r[(i, i)] = variance;
                }
                // P⁺ from P⁻, where each is (None: in place).
                let (from, mean, into) = match (predicted_kept, keep.filtered_covariances) {
                    (false, false) => (None, None, covariance.as_mut_slice()),
                    (true, false) => (
                        Some(last_covariance(&pass.predicted)),
                        None,
                        covariance.as_mut_slice(),
                    ),
                    (_, true) => {
                        let from = if predicted_kept {
                            last_covariance(&pass.predicted)
                        } else {
                            covariance.as_slice()
                        };
                        let (mean, into) = pass.filtered.push_for_writing(n);
                        (Some(from), Some(mean), into)
                    }
                };
                kalman::update_from(
                    &mut state,
                    from,
                    into,
                    &h,
                    &r,
                    &innovation,
                    &mut update_workspace,
                )
                .map_err(|e| at_time((e).into(), t))?;
                if let Some(mean) = mean {
                    finite(t, &state)?;
                    mean.copy_from_slice(state.as_slice());
                    filtered_pushed = true;
                }
                let term = update_workspace.log_likelihood_term(&innovation);
                pass.negative_log_likelihood += 0.5 * term;
                let covariance = &update_workspace.innovation_covariance;
                for (i, &(o, _)) in present.iter().enumerate() {
                    pass.innovations[o].push(Innovation {
                        k,
                        value: innovation[i],
                        variance: covariance[(i, i)],
                    });
                }
                pass.measured.push_update(
                    &h,
                    &innovation,
                    covariance,
                    &update_workspace.innovation_inverse,
                    &update_workspace.gain,
                );
            }
        }
        filtered_kept = filtered_pushed;
        if !filtered_pushed {
            let kept = keep.filtered_covariances || k + 1 == len;
            pass.filtered_at(t, &state, kept.then_some(&covariance))?;
        }
    }
    Ok(pass)
}

impl Pass {
    /// An empty pass over `len` grid points and `outputs` outputs that
    /// keeps everything.
    pub(crate) fn with_capacity(len: usize, outputs: usize) -> Pass {
        Pass::keeping(len, outputs, Keep::ALL)
    }

    /// An empty pass over `len` grid points and `outputs` outputs with
    /// room for what `keep` says it keeps.
    pub(crate) fn keeping(len: usize, outputs: usize, keep: Keep) -> Pass {
        Pass {
            predicted: Gaussians::with_capacity(if keep.predicted { len } else { 0 }, true),
            filtered: Gaussians::with_capacity(len, keep.filtered_covariances),
            measured: Updates::with_capacity(if keep.sequential { 0 } else { len }, outputs),
            scalar_updates: ScalarUpdates::with_capacity(
                if keep.sequential { len } else { 0 },
                outputs,
            ),
            transitions: Matrices::with_capacity(if keep.transitions {
                len.saturating_sub(1)
            } else {
                0
            }),
            sparse_transitions: SparseMatrices::with_capacity(if keep.sparse_transitions {
                len.saturating_sub(1)
            } else {
                0
            }),
            innovations: (0..outputs).map(|_| Vec::with_capacity(len)).collect(),
            negative_log_likelihood: 0.0,
        }
    }

    /// Keeps the filtered estimate at time t (its covariance if given,
    /// else an empty one); an error when the state went non-finite.
    pub(crate) fn filtered_at(
        &mut self,
        t: f64,
        state: &DVector<f64>,
        covariance: Option<&DMatrix<f64>>,
    ) -> Result<()> {
        finite(t, state)?;
        self.filtered.push_parts(state, covariance);
        Ok(())
    }
}

/// An error when the filter's state at time t went non-finite.
fn finite(t: f64, state: &DVector<f64>) -> Result<()> {
    if state.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::Numerical {
            reason: format!("the filter's state went non-finite at t = {t} s"),
        })
    }
}

/// The values of the last covariance `kept` holds (column-major; empty
/// where there is none).
fn last_covariance(kept: &Gaussians) -> &[f64] {
    kept.len()
        .checked_sub(1)
        .and_then(|k| kept.values(k))
        .map_or(&[], |(_, covariance)| covariance)
}

/// Checks that a filter's model, initial estimate, noise and observations
/// agree in size; `filter` names the filter in the error.
pub(crate) fn check_sizes<M: StateSpaceModel + ?Sized>(
    filter: &str,
    model: &M,
    initial: &Gaussian,
    noise: &Noise,
    observations: &Observations,
) -> Result<()> {
    let n = model.state_count();
    let outputs = model.output_count();
    let fits = initial.mean.len() == n
        && initial.covariance.shape() == (n, n)
        && noise.process.shape() == (n, n)
        && noise.measurement.len() == outputs
        && observations.at.len() == model.len()
        && observations.names.len() == outputs;
    if fits {
        Ok(())
    } else {
        Err(Error::Shape {
            reason: format!(
                "the {filter}'s sizes do not agree: {n} states and {outputs} outputs on {} grid points; initial {} and {:?}, process noise {:?}, {} measurement variances, observations of {} outputs on {} points",
                model.len(),
                initial.mean.len(),
                initial.covariance.shape(),
                noise.process.shape(),
                noise.measurement.len(),
                observations.names.len(),
                observations.at.len()
            ),
        })
    }
}

/// An error with the time it happened at.
pub(crate) fn at_time(error: Error, t: f64) -> Error {
    Error::Method {
        reason: format!("at t = {t} s: {error}"),
    }
}
