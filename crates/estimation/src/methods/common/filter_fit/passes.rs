//! One pass of the filter in the loop: the steady-state filter (Jategaonkar
//! §5.5, K = P·Cᵀ·R⁻¹, Eq. 5.48, P from the discrete Riccati equation of
//! the model linearised at the first point, Eqs. 5.50–5.51) with its
//! sensitivity equations, and the time-varying extended filter (§7.2,
//! Eqs. 7.11–7.19).

use super::*;

/// What one steady-state filter pass gives.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyPass {
    /// ν = z − ỹ at every measurement, in the observations' order (grid
    /// point after grid point, each point's outputs as listed there).
    pub innovations: Vec<f64>,
    /// ỹ at every measurement, in the same order.
    pub predicted: Vec<f64>,
    /// ½·Σ_k (ν_kᵀR⁻¹ν_k + ln det R) over the measurements (without 2π).
    pub negative_log_likelihood: f64,
    /// P, K and R of the filter.
    pub steady: SteadyState,
    /// G·Gᵀ = R − C·P·Cᵀ.
    pub measurement_noise: DMatrix<f64>,
    /// C = ∂h/∂x at the first grid point, where the gain was computed.
    pub output_matrix: DMatrix<f64>,
}

/// One pass of the steady-state filter (docs/methods.md, Filter error) over
/// `observations` on the model's grid, from `initial` at grid point 0,
/// with parameters `theta`, process-noise distribution F = diag(`distribution`)
/// (one entry per state, zero for a state without noise) and innovation
/// covariance R ([`InnovationCovariance`]). With no process noise
/// the gain is zero and the pass is the model's simulation. An error when
/// the model cannot be evaluated, no steady-state filter has this R, or
/// the constraint diag(K·C) ≤ 1 is violated.
pub fn steady_state_pass<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &DVector<f64>,
    distribution: &DVector<f64>,
    innovation: &InnovationCovariance,
    observations: &Observations,
) -> Result<SteadyPass> {
    let (n, outputs) = (model.state_count(), model.output_count());
    let variances = innovation.variances();
    if initial.len() != n
        || distribution.len() != n
        || variances.len() != outputs
        || observations.at.len() != model.len()
        || model.len() < 2
    {
        return Err(Error::Shape {
            reason: format!(
                "the filter's sizes do not agree: {n} states, {outputs} outputs on {} grid points; initial state of {}, {} F entries, {} variances, observations on {} points",
                model.len(),
                initial.len(),
                distribution.len(),
                variances.len(),
                observations.at.len()
            ),
        });
    }
    if !variances.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return Err(Error::Method {
            reason: "the innovation variances must be positive and finite".into(),
        });
    }
    let start = model.time(0);
    let jacobians = model.jacobians(start, initial.as_slice(), theta)?;
    let (steady, measurement_noise) = steady_gain(
        &jacobians,
        distribution,
        innovation,
        (model.time(1) - start) * observations.stride() as f64,
    )?;
    let c = jacobians.outputs_by_state;
    let kc = &steady.gain * &c;
    if let Some(i) = (0..n).find(|&i| kc[(i, i)] > 1.0) {
        return Err(Error::Numerical {
            reason: format!(
                "the gain violates diag(K·C) ≤ 1 (Jategaonkar §5.3): entry {i} is {:.4}",
                kc[(i, i)]
            ),
        });
    }
    let count: usize = observations.at.iter().map(Vec::len).sum();
    let mut pass = SteadyPass {
        innovations: Vec::with_capacity(count),
        predicted: Vec::with_capacity(count),
        negative_log_likelihood: 0.0,
        steady,
        measurement_noise,
        output_matrix: c,
    };
    filter_steadily(
        model,
        theta,
        initial,
        innovation,
        observations,
        &mut pass,
        None,
    )?;
    Ok(pass)
}

/// The steady-state filter of the model linearised as `jacobians` (at the
/// first grid point): K, P and R (Jategaonkar Eq. 5.48) with process noise
/// F·Fᵀ, F = diag(`distribution`), discretised over `interval` (the
/// interval between an output's corrections), and G·Gᵀ = R − C·P·Cᵀ. With
/// no process noise the gain is zero.
pub(crate) fn steady_gain(
    jacobians: &crate::model::state_space::Jacobians,
    distribution: &DVector<f64>,
    innovation: &InnovationCovariance,
    interval: f64,
) -> Result<(SteadyState, DMatrix<f64>)> {
    let a = &jacobians.rates_by_state;
    let c = &jacobians.outputs_by_state;
    let (n, outputs) = (a.nrows(), c.nrows());
    let r = innovation.matrix().clone();
    if distribution.iter().all(|f| *f == 0.0) {
        let steady = SteadyState {
            covariance: DMatrix::zeros(n, n),
            gain: DMatrix::zeros(n, outputs),
            innovation_covariance: r.clone(),
        };
        return Ok((steady, r));
    }
    let spectral = DMatrix::from_diagonal(&distribution.map(|f| f * f));
    let discrete = kalman::discretise(a, &DMatrix::zeros(n, 0), Some(&spectral), interval);
    Ok(kalman::steady_state_for_innovation(
        &discrete.transition,
        c,
        &discrete.process_noise,
        &r,
    )?)
}

/// The sensitivities a steady-state pass carries (Jategaonkar §5.5 style:
/// the filter's own sensitivity equations): the unknowns' `columns` (the
/// parameter each is, None for an F entry), ∂K/∂u_j for each, and the
/// rows ∂ν/∂u written, one per measurement.
pub(crate) struct Tangent<'a> {
    pub(crate) columns: &'a [Option<usize>],
    pub(crate) gains: &'a [DMatrix<f64>],
    pub(crate) rows: DMatrix<f64>,
}

/// The steady-state filter's pass over `observations` with `pass`'s gain,
/// writing its innovations, predictions and likelihood into `pass`; with a
/// `tangent`, the sensitivities S = ∂x/∂u through it (docs/methods.md,
/// Filter error): returns false when the model does not propagate them
/// ([`StateSpaceModel::step_sensitivity`]).
// Not split: one loop over the grid (prediction, outputs, correction,
// each with or without the sensitivities) whose eleven buffers are
// allocated once before it, so that a pass allocates nothing per grid
// point (tests/no_allocation.rs); its phases would each take most of them.
pub(crate) fn filter_steadily<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &DVector<f64>,
    innovation: &InnovationCovariance,
    observations: &Observations,
    pass: &mut SteadyPass,
    mut tangent: Option<&mut Tangent<'_>>,
) -> Result<bool> {
    let (n, outputs) = (model.state_count(), model.output_count());
    let m = tangent.as_ref().map_or(0, |t| t.columns.len());
    let variances = innovation.variances();
    let log_variances = variances.map(f64::ln);
    let mut innovations = DVector::zeros(outputs);
    let mut sensitivity = DMatrix::<f64>::zeros(n, m);
    let mut output_sensitivity = DMatrix::<f64>::zeros(outputs, m);
    let mut correction = DMatrix::<f64>::zeros(n, m);
    let mut linear = crate::model::state_space::Jacobians::empty();
    let mut predicted = DVector::zeros(outputs);
    let mut whitened = DVector::zeros(outputs);
    let mut row = 0;
    let mut state = initial.clone();
    let mut next = DVector::zeros(n);
    for (k, present) in observations.at.iter().enumerate() {
        if k > 0 {
            match tangent {
                Some(ref tangent) => {
                    let stepped = model
                        .step_sensitivity(
                            k - 1,
                            state.as_slice(),
                            theta,
                            tangent.columns,
                            &mut sensitivity,
                        )
                        .map_err(|e| at_time(e, model.time(k - 1)))?;
                    let Some(stepped) = stepped else {
                        return Ok(false);
                    };
                    state = stepped;
                }
                None => {
                    model
                        .step_into(k - 1, state.as_slice(), theta, &mut next)
                        .map_err(|e| at_time(e, model.time(k - 1)))?;
                    std::mem::swap(&mut state, &mut next);
                }
            }
        }
        if present.is_empty() {
            continue;
        }
        let t = model.time(k);
        match tangent {
            Some(ref tangent) => {
                model.jacobians_into(
                    t,
                    state.as_slice(),
                    theta,
                    &mut linear,
                    Some(&mut predicted),
                )?;
                // ∂ỹ/∂u = C·S̃ + ∂h/∂θ
                output_sensitivity.gemm(1.0, &linear.outputs_by_state, &sensitivity, 0.0);
                for (j, column) in tangent.columns.iter().enumerate() {
                    if let Some(p) = *column {
                        output_sensitivity.column_mut(j).axpy(
                            1.0,
                            &linear.outputs_by_parameter.column(p),
                            1.0,
                        );
                    }
                }
                correction.fill(0.0);
            }
            None => model.outputs_into(t, state.as_slice(), theta, &mut predicted)?,
        }
        // ½·(νᵀR⁻¹ν + ln det R) over the outputs measured here: with R
        // full at a point that measures them all, else output by output.
        let joint = match &innovation.whitening {
            Some((inverse, log_det)) if present.len() == outputs => Some((inverse, *log_det)),
            _ => None,
        };
        for &(o, z) in present {
            let innovation = z - predicted[o];
            innovations[o] = innovation;
            pass.innovations.push(innovation);
            pass.predicted.push(predicted[o]);
            if joint.is_none() {
                pass.negative_log_likelihood +=
                    0.5 * (innovation * innovation / variances[o] + log_variances[o]);
            }
            state.axpy(innovation, &pass.steady.gain.column(o), 1.0);
            if let Some(ref mut tangent) = tangent {
                // ∂ν/∂u = −∂ỹ/∂u; Ŝ = S̃ + K·∂ν + ∂K·ν
                let gain = pass.steady.gain.column(o);
                for j in 0..m {
                    let d_innovation = -output_sensitivity[(o, j)];
                    tangent.rows[(row, j)] = d_innovation;
                    correction.column_mut(j).axpy(d_innovation, &gain, 1.0);
                    correction
                        .column_mut(j)
                        .axpy(innovation, &tangent.gains[j].column(o), 1.0);
                }
            }
            row += 1;
        }
        if let Some((inverse, log_det)) = joint {
            inverse.mul_to(&innovations, &mut whitened);
            pass.negative_log_likelihood += 0.5 * (whitened.norm_squared() + log_det);
        }
        if tangent.is_some() {
            sensitivity += &correction;
        }
        if !state.iter().all(|v| v.is_finite()) {
            return Err(Error::Numerical {
                reason: format!("the filter's state went non-finite at t = {t} s"),
            });
        }
    }
    Ok(true)
}

/// What one pass of the time-varying filter gives.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeVaryingPass {
    /// ν = z − ỹ at every measurement, in the observations' order.
    pub innovations: Vec<f64>,
    /// ỹ at every measurement, in the same order.
    pub predicted: Vec<f64>,
    /// ½·Σ_k (ν_kᵀS_k⁻¹ν_k + ln det S_k) over the grid points with
    /// measurements (without 2π), S_k = C_k·P̃_k·C_kᵀ + G·Gᵀ.
    pub negative_log_likelihood: f64,
    /// The output of each innovation, in the same order.
    pub(crate) outputs: Vec<usize>,
    /// At each grid point with measurements: where its innovations start,
    /// their number m, where its S_k (m × m, column-major) starts in
    /// `covariances`.
    pub(crate) spans: Vec<(usize, usize, usize)>,
    /// The S_k, grid point after grid point.
    pub(crate) covariances: Vec<f64>,
}

impl TimeVaryingPass {
    /// At each grid point with measurements: the outputs measured, ν and
    /// S_k over them.
    pub fn updates(
        &self,
    ) -> impl ExactSizeIterator<Item = (&[usize], DVectorView<'_, f64>, DMatrixView<'_, f64>)> + '_
    {
        self.spans.iter().map(|&(start, m, at)| {
            (
                &self.outputs[start..start + m],
                DVectorView::from_slice(&self.innovations[start..start + m], m),
                DMatrixView::from_slice(&self.covariances[at..at + m * m], m, m),
            )
        })
    }
}

/// One pass of the time-varying (extended) filter over `observations`:
/// the continuous–discrete EKF of [`extended_kalman::filter`] from
/// (`initial`, P0 = `initial_covariance`) at grid point 0 with parameters
/// `theta`, process noise F·Fᵀ, F = diag(`distribution`), and measurement
/// noise G·Gᵀ = diag(`measurement_noise`). An error when the model cannot
/// be evaluated or a covariance breaks down.
pub fn time_varying_pass<M: StateSpaceModel + ?Sized>(
    model: &M,
    theta: &[f64],
    initial: &Gaussian,
    distribution: &DVector<f64>,
    measurement_noise: &DVector<f64>,
    observations: &Observations,
) -> Result<TimeVaryingPass> {
    if distribution.len() != model.state_count() {
        return Err(Error::Shape {
            reason: format!(
                "the filter's sizes do not agree: {} states, {} F entries",
                model.state_count(),
                distribution.len()
            ),
        });
    }
    if !measurement_noise.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return Err(Error::Method {
            reason: "the measurement noise variances must be positive and finite".into(),
        });
    }
    let noise = Noise {
        process: DMatrix::from_diagonal(&distribution.map(|f| f * f)),
        measurement: measurement_noise.clone(),
    };
    // The likelihood and the updates are all the pass reads.
    let filtered = extended_kalman::filter_with(
        model,
        theta,
        initial.clone(),
        &noise,
        observations,
        Discretisation::Exact,
        Keep::UPDATES,
    )?;
    // Every buffer reserved once: no allocation per grid point.
    let count: usize = observations.at.iter().map(Vec::len).sum();
    let points = observations.at.iter().filter(|p| !p.is_empty()).count();
    let squares: usize = observations.at.iter().map(|p| p.len() * p.len()).sum();
    let mut pass = TimeVaryingPass {
        innovations: Vec::with_capacity(count),
        predicted: Vec::with_capacity(count),
        negative_log_likelihood: filtered.negative_log_likelihood,
        outputs: Vec::with_capacity(count),
        spans: Vec::with_capacity(points),
        covariances: Vec::with_capacity(squares),
    };
    for (present, update) in observations.at.iter().zip(filtered.measured.iter()) {
        let Some(update) = update else { continue };
        pass.spans.push((
            pass.innovations.len(),
            present.len(),
            pass.covariances.len(),
        ));
        for (i, &(o, z)) in present.iter().enumerate() {
            pass.innovations.push(update.innovation[i]);
            pass.predicted.push(z - update.innovation[i]);
            pass.outputs.push(o);
        }
        pass.covariances
            .extend(update.innovation_covariance.iter().copied());
    }
    Ok(pass)
}

pub(crate) fn at_time(error: Error, t: f64) -> Error {
    Error::Method {
        reason: format!("at t = {t} s: {error}"),
    }
}

/// A pass of the filter in the loop.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterPass {
    Steady(SteadyPass),
    TimeVarying(TimeVaryingPass),
}

impl FilterPass {
    /// ν at every measurement, in the observations' order.
    pub fn innovations(&self) -> &[f64] {
        match self {
            FilterPass::Steady(pass) => &pass.innovations,
            FilterPass::TimeVarying(pass) => &pass.innovations,
        }
    }

    /// ỹ at every measurement, in the same order.
    pub fn predicted(&self) -> &[f64] {
        match self {
            FilterPass::Steady(pass) => &pass.predicted,
            FilterPass::TimeVarying(pass) => &pass.predicted,
        }
    }

    /// The negative log-likelihood of the pass (without 2π).
    pub fn negative_log_likelihood(&self) -> f64 {
        match self {
            FilterPass::Steady(pass) => pass.negative_log_likelihood,
            FilterPass::TimeVarying(pass) => pass.negative_log_likelihood,
        }
    }
}
